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

With ``--tradeoff``: time against error for each path (vibra fast, vibra high, scipy ``eigsh``
shift-invert, numpy ``eigh`` where n <= 3,000), lowest 26 modes with vectors, on two families
of 3-D networks: the random networks above (uniform springs) and "spread" networks (each
random site joined to its 8 nearest neighbours, springs log-uniform over 1e-6..1e6, masses over
1e-3..1e3: the issue's ill-conditioned case, where "high" must win). Error: the largest
relative error of omega^2 over modes 7..26 (the six rigid-body modes have no relative
error). Truth: 40-digit mpmath for the spread networks up to 300 dofs; vibra high (the
accurate path, whose own figure is then its reported bound, an upper bound of its error) for
the others; each case names its truth.
Also the cost of "high" against "fast" for all modes, with and without vectors (best of 3
interleaved rounds even with --quick). results/networks_tradeoff.json and .png. Default
sizes 100..50,000 dofs; --quick stops at ~3,000 dofs and runs one round:
    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_networks.py --tradeoff [--quick]

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
from _common import interleaved, new_figure, ratio, save_figure, write_json  # noqa: E402

from vibra import System, networks  # noqa: E402

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


#: Tradeoff sizes in sites: ~100..50,000 dofs (uniform) and 90..30,000 dofs (spread); --quick
#: stops at ~3,000 dofs. Dense numpy eigh only up to EIGH_LIMIT dofs.
TRADEOFF_SITES = {"uniform": [34, 100, 334, 1000, 3334, 10000, 16667], "spread": [30, 100, 334, 1000, 3334, 10000]}
QUICK_LIMIT = 3000
EIGH_LIMIT = 3000
#: Spread networks up to this many dofs take their truth from mpmath (~3 minutes at 300 dofs).
MPMATH_LIMIT = 300
MP_DIGITS = 40
#: A method that failed, or took longer than this at one size, is skipped at the larger ones.
SKIP_AFTER_S = 60.0
#: The six rigid-body modes are left out of the relative error: modes 7..26 count.
RIGID = 6


def spread_network(n_sites: int, seed: int = 0) -> Any:
    """Random normal sites, each joined to its 8 nearest neighbours; springs log-uniform over
    1e-6..1e6, masses over 1e-3..1e3 (the issue's ill-conditioned network)."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(seed)
    positions = rng.normal(size=(n_sites, 3))
    _, nearest = cKDTree(positions).query(positions, k=9)
    pairs = np.unique(np.sort(np.c_[np.repeat(np.arange(n_sites), 8), nearest[:, 1:].ravel()], axis=1), axis=0)
    springs = 10.0 ** rng.uniform(-6.0, 6.0, len(pairs))
    masses = 10.0 ** rng.uniform(-3.0, 3.0, n_sites)
    return System.from_springs(positions, masses, pairs, springs)


def mp_eigenvalues(system: Any, count: int, digits: int = MP_DIGITS) -> np.ndarray:
    """The lowest `count` omega^2 of B~^T B~, B~ = W^1/2 B M^-1/2 formed in mpmath at `digits`
    digits from the float64 spring factor and masses taken as exact (no float64 K)."""
    import mpmath

    coupling, weights = system.spring_factor()
    coupling = sp.coo_matrix(coupling)
    masses = np.asarray(system.mass_matrix(), dtype=float)
    masses = np.diag(masses) if masses.ndim == 2 else masses
    with mpmath.workdps(digits):
        n = coupling.shape[1]
        weighted = mpmath.matrix(coupling.shape[0], n)
        for row, column, value in zip(coupling.row, coupling.col, coupling.data):
            weighted[int(row), int(column)] = (mpmath.sqrt(mpmath.mpf(float(weights[row]))) * mpmath.mpf(float(value))
                                               / mpmath.sqrt(mpmath.mpf(float(masses[column]))))
        values = mpmath.eigsy(weighted.T * weighted, eigvals_only=True)
        return np.array(sorted(float(v) for v in values))[:count]


def _tradeoff_methods(system: Any) -> dict[str, Callable[[], np.ndarray]]:
    """The lowest 26 omega^2 (with vectors) by each path; numpy eigh only up to EIGH_LIMIT dofs."""
    K = sp.csr_matrix(system.hessian())
    masses = np.asarray(system.mass_matrix(), dtype=float)
    masses = np.diag(masses) if masses.ndim == 2 else masses
    root = 1.0 / np.sqrt(masses)
    sigma = -1e-6 * float(abs(sp.diags(root) @ K @ sp.diags(root)).sum(axis=1).max())
    methods: dict[str, Callable[[], Any]] = {
        "vibra_fast": lambda: system.modes(26, accuracy="fast").omega_squared,
        "vibra_high": lambda: system.modes(26).omega_squared,
        "scipy_eigsh": lambda: np.sort(sla.eigsh(K, k=26, M=sp.diags(masses), sigma=sigma, which="LM")[0]),
    }
    if K.shape[0] <= EIGH_LIMIT:
        weighted = (K.toarray() * root[:, None]) * root[None, :]
        methods["numpy_eigh"] = lambda: np.linalg.eigh(weighted)[0][:26]
    return {key: _recorded(method) for key, method in methods.items()}


def _recorded(method: Callable[[], Any]) -> Callable[[], Any]:
    """`method`, with a failure (ARPACK not converging, say) returned as its message, not raised."""
    def run() -> Any:
        try:
            return method()
        except (sla.ArpackNoConvergence, np.linalg.LinAlgError, RuntimeError) as failure:
            return f"{type(failure).__name__}: {failure}"
    return run


def _relative_error(values: np.ndarray, truth: np.ndarray) -> float:
    flexible = slice(RIGID, 26)
    return float(np.max(np.abs(np.asarray(values)[flexible] - truth[flexible]) / np.abs(truth[flexible])))


def tradeoff_case(family: str, n_sites: int, rounds: int, skip: dict[str, str]) -> dict[str, Any]:
    """One network: every path timed (interleaved), its error against the truth named in the case.
    `skip`: methods left out, with the reason (failed or over SKIP_AFTER_S at a smaller size)."""
    system = random_network(n_sites) if family == "uniform" else spread_network(n_sites)
    n_dof = int(system.hessian().shape[0])
    print(f"{family}: {n_sites} sites, {n_dof} dofs", flush=True)
    methods = {key: method for key, method in _tradeoff_methods(system).items() if key not in skip}
    timings = interleaved(methods, rounds, warmup=rounds > 1)
    high = system.modes(26)
    truth_bound: float | None = None
    if family == "spread" and n_dof <= MPMATH_LIMIT:
        truth, source = mp_eigenvalues(system, 26), f"mpmath, {MP_DIGITS} digits, of B~^T B~ from the spring factor"
    else:
        truth, source = high.omega_squared, f"vibra high ({high.solver}); its own figure is its reported bound"
        omega = np.abs(high.omega[RIGID:26])
        bound = high.omega_error[RIGID:26] * (2 * omega + high.omega_error[RIGID:26]) / omega**2
        truth_bound = float(bound.max())  # differences below it are not resolved by this truth
    case: dict[str, Any] = {"family": family, "n_sites": n_sites, "n_dof": n_dof, "truth": source,
                            "truth_bound": truth_bound,
                            "vibra_high_path": high.solver, "vibra_high_refinement": high.refinement,
                            "vibra_fast_path": system.modes(26, accuracy="fast", vectors=False).solver, "methods": {}}
    for key, reason in skip.items():
        case["methods"][key] = {"skipped": reason}
    for key, timing in timings.items():
        if timing.min > SKIP_AFTER_S:
            skip[key] = f"took {timing.min:.0f} s at {n_dof} dofs"
        if isinstance(timing.result, str):  # failed: no error figure, the reason instead
            skip[key] = f"failed at {n_dof} dofs"
            case["methods"][key] = {**timing.summary(), "eigenvalue_rel_error": None, "failed": timing.result}
            continue
        error = _relative_error(timing.result, truth)
        entry = {**timing.summary(), "eigenvalue_rel_error": error}
        if key == "vibra_high" and source.startswith("vibra"):
            entry.update(eigenvalue_rel_error=truth_bound, error_is_reported_bound=True)
        case["methods"][key] = entry
    return case


def high_cost(n_sites: int, family: str, rounds: int) -> dict[str, Any]:
    """All modes, values only and with vectors: vibra high against vibra fast, interleaved."""
    system = random_network(n_sites) if family == "uniform" else spread_network(n_sites)
    print(f"cost of high, {family}: {n_sites} sites, all modes", flush=True)
    methods = {f"{accuracy}_{'vectors' if vectors else 'values'}":
               (lambda accuracy=accuracy, vectors=vectors: system.modes(accuracy=accuracy, vectors=vectors))
               for vectors in (False, True) for accuracy in ("fast", "high")}
    timings = interleaved(methods, rounds)
    entry: dict[str, Any] = {"family": family, "n_sites": n_sites, "n_dof": int(system.hessian().shape[0]),
                             "times": {key: t.summary() for key, t in timings.items()}}
    for what in ("values", "vectors"):
        high, fast = timings[f"high_{what}"], timings[f"fast_{what}"]
        entry[f"high_over_fast_{what}"] = ratio(high, fast)
        entry[f"high_path_{what}"] = high.result.solver
        entry[f"high_refinement_{what}"] = high.result.refinement
        flexible = slice(RIGID, None)
        entry[f"high_vs_fast_max_rel_diff_{what}"] = float(np.max(
            np.abs(fast.result.omega_squared[flexible] - high.result.omega_squared[flexible])
            / np.abs(high.result.omega_squared[flexible])))
    return entry


def tradeoff(sizes: list[int] | None, *, quick: bool) -> None:
    """The time-versus-error figure and JSON (see the module docstring)."""
    rounds = 1 if quick else ROUNDS
    cases = []
    for family, default in TRADEOFF_SITES.items():
        skip: dict[str, str] = {}
        for n_sites in sizes or default:
            if quick and 3 * n_sites > QUICK_LIMIT:
                continue
            cases.append(tradeoff_case(family, n_sites, rounds, skip))
    cost = [high_cost(n_sites, family, max(rounds, 3)) for family, n_sites in
            (("uniform", 500), ("uniform", 1000), ("spread", 500))]
    write_json("networks_tradeoff", {
        "benchmark": "time versus error per path, lowest 26 modes with vectors, 3-D networks",
        "error": f"largest relative error of omega^2 over modes {RIGID + 1}..26 against the case's truth",
        "peers": {"scipy_eigsh": "scipy.sparse.linalg.eigsh(K, k=26, M=diag(m), sigma=-1e-6 ||K~||_inf, "
                                 "which='LM'), default tolerance",
                  "numpy_eigh": f"numpy.linalg.eigh of the dense K~, n <= {EIGH_LIMIT}"},
        "cases": cases, "cost_of_high_all_modes": cost,
        "threads": {key: os.environ.get(key) for key in ("OPENBLAS_NUM_THREADS",)},
    }, rounds)
    plot_tradeoff(cases)


def plot_tradeoff(cases: list[dict[str, Any]]) -> Path:
    """Two log-log panels (uniform, spread): one marker per (path, size), labelled with its dofs."""
    fig, axes = new_figure(1, 2, figsize=(13.0, 6.5))
    styles = {"vibra_fast": ("tab:blue", "o"), "vibra_high": ("tab:red", "s"), "scipy_eigsh": ("tab:green", "^"),
              "numpy_eigh": ("tab:gray", "D")}
    titles = {"uniform": "random 3-D networks, uniform springs",
              "spread": "8-neighbour networks, springs 1e-6..1e6, masses 1e-3..1e3"}
    for ax, family in zip(axes, ("uniform", "spread")):
        for key, (colour, marker) in styles.items():
            entries = [(case["n_dof"], case["methods"][key]) for case in cases
                       if case["family"] == family and "min_s" in case["methods"].get(key, {})]
            points = [(entry["min_s"], max(entry["eigenvalue_rel_error"], 1e-17), dofs,
                       entry.get("error_is_reported_bound", False)) for dofs, entry in entries if not entry.get("failed")]
            failed = [(entry["min_s"], dofs) for dofs, entry in entries if entry.get("failed")]
            if points:
                xs, ys = [p[0] for p in points], [p[1] for p in points]
                ax.loglog(xs, ys, linestyle=":", color=colour, marker=marker, label=key, markersize=7)
            for x, y, dofs, bound in points:
                ax.annotate(f"{dofs}" + ("*" if bound else ""), (x, y), textcoords="offset points", xytext=(4, 4),
                            fontsize=7, color=colour)
            for x, dofs in failed:  # drawn at error 1 (no digit), marked x
                ax.loglog([x], [1.0], linestyle="none", color=colour, marker="x", markersize=9,
                          label=None if points else key)
                ax.annotate(f"{dofs} failed", (x, 1.0), textcoords="offset points", xytext=(4, -10), fontsize=7,
                            color=colour)
        ax.axhline(1e-10, color="black", linewidth=0.8, linestyle="--")
        ax.text(ax.get_xlim()[0], 1.3e-10, " 1e-10 target", fontsize=7, va="bottom")
        ax.set_xlabel("wall time (s), best of the rounds")
        ax.set_ylabel("largest relative error of omega^2, modes 7..26")
        ax.set_title(titles[family], fontsize=10)
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=4, title="labels: dofs; * = high's reported bound, where high is the\n"
                  "truth (others' errors below it are not resolved)", title_fontsize=7)
    return save_figure(fig, "networks_tradeoff")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one small protein, one round (smoke run)")
    parser.add_argument("--random3d", type=int, nargs="*", metavar="SITES",
                        help="random 3-D networks of these sizes instead of the proteins (default 500)")
    parser.add_argument("--tradeoff", type=int, nargs="*", metavar="SITES",
                        help="time versus error per path on uniform and spread 3-D networks (sizes in sites)")
    args = parser.parse_args()
    if args.tradeoff is not None:
        tradeoff(args.tradeoff or None, quick=args.quick)
        return
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
