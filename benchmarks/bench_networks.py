"""Elastic network models: vibra against ProDy on C-alpha networks of 1,489 and 1,918 residues.

Proteins: pdb3o21.pdb and pdb7pbl.pdb from ProDy's shipped test data, C-alpha atoms read by
`vibra.networks.from_pdb`. Work timed, from coordinates to the 20 lowest non-rigid modes of
the ANM (cutoff 15 Å, gamma 1, unit masses):

- ``prody``: ProDy's defaults, ``ANM.buildHessian(coords)`` (dense) + ``ANM.calcModes(20)``
  (LAPACK ``eigh`` on the dense Hessian, 26 lowest pairs, zero modes dropped);
- ``prody_calcmodes_only``: ``calcModes(20)`` alone on a prebuilt Hessian (the issue's figure);
- ``vibra_fast``: ``networks.anm(coords)`` + ``System.modes(26, accuracy="fast")`` (sparse
  shift-invert Lanczos, SuperLU);
- ``vibra_high``: the same with ``accuracy="high"`` (+ Rayleigh-Ritz in spring space);
- ``scipy_eigsh``: scipy ``eigsh(K, k=26, sigma=-1e-6 ||K||_inf)`` on vibra's sparse K (the
  Hessian build not timed), the plain scipy call a user would write.

Accuracy: largest relative error of the 20 non-rigid eigenvalues and of the square
fluctuations (sum over those 20 modes, as prody.calcSqFlucts) against ProDy's dense result.

With ``--random3d``: random 3-D spring networks instead (uniform sites at density 0.05, ANM
springs within 8.5 units: ~42 per site, the issue's "500 sites, 21,000 springs"), lowest 26
modes by vibra fast, vibra high (the checked path), scipy ``eigsh(sigma=-1e-6 ||K||)`` with
its default factorisation and numpy ``eigh`` (dense, n <= 3,000 only); errors against eigh
(or against vibra high where eigh is skipped). Timed with `_common.interleaved`; results in
results/networks_3d.json.

Protocol: BLAS threads pinned to 1 before numpy loads; one warm-up of every method on 1ubi;
then 3 rounds, the methods interleaved within each round; best time, all times and the
spread (max / min - 1) per method go to results/networks.json. The machine has 2 cores
shared with other jobs: read the ratios and the spreads, not the absolute seconds. Run:
    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_networks.py [--quick]
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"  # before numpy is imported

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable  # noqa: E402

import numpy as np  # noqa: E402
import prody  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as sla  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's vibra
from _common import interleaved, write_json  # noqa: E402

from vibra import networks  # noqa: E402

prody.confProDy(verbosity="none")
DATA = Path(prody.__file__).parent / "tests" / "datafiles"
N_MODES = 20
ROUNDS = 3


def run_prody(coords: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    model = prody.ANM()
    model.buildHessian(coords, cutoff=15.0, gamma=1.0)
    model.calcModes(n_modes=N_MODES)
    return model.getEigvals(), prody.calcSqFlucts(model)


def prody_modes_only(model: prody.ANM) -> tuple[np.ndarray, np.ndarray]:
    model.calcModes(n_modes=N_MODES)
    return model.getEigvals(), prody.calcSqFlucts(model)


def _flucts(values: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    keep = values > 1e-6  # ProDy's ZERO
    values, vectors = values[keep][:N_MODES], vectors[:, keep][:, :N_MODES]
    return np.asarray(((vectors**2) / values).sum(axis=1).reshape(-1, 3).sum(axis=1)), values


def run_vibra(coords: np.ndarray, accuracy: str) -> tuple[np.ndarray, np.ndarray]:
    system = networks.anm(coords)
    modes = system.modes(N_MODES + 6, accuracy=accuracy)  # type: ignore[arg-type]
    square = networks.square_fluctuations(system, modes)
    return modes.omega_squared[6:], square


def run_eigsh(K: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray]:
    sigma = -1e-6 * float(abs(K).sum(axis=1).max())
    values, vectors = sla.eigsh(K, k=N_MODES + 6, sigma=sigma, which="LM", tol=0.0)
    order = np.argsort(values)
    square, kept = _flucts(values[order], vectors[:, order])
    return kept, square


def random_network(n_sites: int, seed: int = 0) -> Any:
    """The issue's random 3-D network: uniform sites at density 0.05, springs within 8.5 units."""
    rng = np.random.default_rng(seed)
    side = (n_sites / 0.05) ** (1.0 / 3.0)
    return networks.anm(rng.uniform(0.0, side, size=(n_sites, 3)), cutoff=8.5)


def random3d(sizes: list[int], rounds: int) -> None:
    """Lowest 26 modes of random 3-D networks: vibra fast / high, scipy eigsh, numpy eigh."""
    cases = []
    for n_sites in sizes:
        system = random_network(n_sites)
        K = sp.csr_matrix(system.hessian())
        springs = int(round((K.nnz / 9 - n_sites) / 2))
        methods: dict[str, Callable[[], np.ndarray]] = {
            "vibra_fast": lambda: system.modes(26, accuracy="fast").omega_squared,
            "vibra_high": lambda: system.modes(26).omega_squared,
            "scipy_eigsh": lambda: np.sort(sla.eigsh(K, k=26, sigma=-1e-6 * float(abs(K).sum(axis=1).max()),
                                                     which="LM", tol=0.0)[0]),
        }
        if K.shape[0] <= 3000:
            methods["numpy_eigh"] = lambda: np.linalg.eigvalsh(K.toarray())[:26]
        print(f"{n_sites} sites, {K.shape[0]} dofs, {springs} springs", flush=True)
        timings = interleaved(methods, rounds, warmup=rounds > 1)
        reference = timings["numpy_eigh" if "numpy_eigh" in timings else "vibra_high"].result
        scale = float(np.abs(reference).max())
        case: dict[str, Any] = {"n_sites": n_sites, "n_dof": int(K.shape[0]), "springs": springs, "methods": {}}
        for key, timing in timings.items():
            error = np.abs(np.asarray(timing.result)[6:] - reference[6:]) / np.maximum(reference[6:], 1e-300 * scale)
            case["methods"][key] = {**timing.summary(), "eigenvalue_rel_error": float(error.max()),
                                    "vs_fast": timing.min / timings["vibra_fast"].min}
        solver = system.modes(26).solver
        case["vibra_high_path"] = solver
        cases.append(case)
    write_json("networks_3d", {"benchmark": "random 3-D spring networks, lowest 26 modes", "cases": cases,
                               "threads": {key: os.environ.get(key) for key in ("OPENBLAS_NUM_THREADS",)}},
               rounds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one small protein, one round (smoke run)")
    parser.add_argument("--random3d", type=int, nargs="*", metavar="SITES",
                        help="random 3-D networks of these sizes instead of the proteins (default 500)")
    args = parser.parse_args()
    if args.random3d is not None:
        random3d(args.random3d or [500], 1 if args.quick else ROUNDS)
        return
    files = ["pdb3enl.pdb"] if args.quick else ["pdb3o21.pdb", "pdb7pbl.pdb"]
    rounds = 1 if args.quick else ROUNDS

    warm = networks.from_pdb(DATA / "pdb1ubi.pdb").positions
    warm_K = networks.anm(warm).hessian()
    run_prody(warm), run_vibra(warm, "fast"), run_vibra(warm, "high"), run_eigsh(warm_K)

    cases = []
    for name in files:
        coords = networks.from_pdb(DATA / name).positions
        K = networks.anm(coords).hessian()
        built = prody.ANM()
        built.buildHessian(coords, cutoff=15.0, gamma=1.0)
        methods: dict[str, Callable[[], tuple[np.ndarray, np.ndarray]]] = {
            "prody": lambda: run_prody(coords),
            "prody_calcmodes_only": lambda: prody_modes_only(built),
            "vibra_fast": lambda: run_vibra(coords, "fast"),
            "vibra_high": lambda: run_vibra(coords, "high"),
            "scipy_eigsh": lambda: run_eigsh(K),
        }
        times: dict[str, list[float]] = {key: [] for key in methods}
        outputs: dict[str, Any] = {}
        for _ in range(rounds):
            for key, method in methods.items():
                start = time.perf_counter()
                outputs[key] = method()
                times[key].append(time.perf_counter() - start)
        reference_values, reference_square = outputs["prody"]
        case: dict[str, Any] = {"file": name, "n_residues": int(coords.shape[0]), "n_dof": int(3 * coords.shape[0]),
                                "methods": {}}
        for key in methods:
            values, square = outputs[key]
            best = min(times[key])
            case["methods"][key] = {
                "best_s": best, "times_s": times[key], "spread": max(times[key]) / best - 1.0,
                "eigenvalue_rel_error": float(np.max(np.abs(values / reference_values - 1.0))),
                "sq_fluct_rel_error": float(np.max(np.abs(square / reference_square - 1.0))),
            }
        prody_times = times["prody"]
        for key in ("prody_calcmodes_only", "vibra_fast", "vibra_high", "scipy_eigsh"):
            case["methods"][key]["speedup_vs_prody"] = min(prody_times) / min(times[key])
            case["methods"][key]["speedup_range"] = [min(prody_times) / max(times[key]),
                                                     max(prody_times) / min(times[key])]
        cases.append(case)
        print(name, coords.shape[0], {k: round(v["best_s"], 3) for k, v in case["methods"].items()},
              {k: round(v.get("speedup_vs_prody", 1.0), 1) for k, v in case["methods"].items()}, flush=True)

    write_json("networks", {
        "benchmark": "ANM, C-alpha, cutoff 15 Å, 20 lowest non-rigid modes",
        "peer": "ProDy %s ANM.buildHessian (dense) + calcModes(n_modes=20), defaults" % prody.__version__,
        "protocol": f"warm-up on 1ubi, best of {rounds} interleaved rounds; threads pinned to 1; "
                    "2 shared cores (noisy)",
        "threads": {key: os.environ.get(key) for key in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")},
        "cases": cases,
    })


if __name__ == "__main__":
    main()
