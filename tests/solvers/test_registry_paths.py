"""Every solver path is declared once (issue 43, item 1): each path of `vibra.solvers.registry`
is planned and solved on a small problem its predicate accepts, and the result reports the
planned path; the registry finds each runner by a direct reference (no name mangling), one
declaration per runner; the GPU and the quadratic methods go through the same plan and guard.

Truth here is structural: the plan's path, the declaration's name and `Modes.path` /
`QuadraticModes.path`, and the source of `vibra/solvers/registry.py`. No GPU is needed: the
GPU path's device solve is replaced by a numpy one (its plumbing is what is tested).
"""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
import scipy.linalg as la

from helpers import fake_cupy
from vibra import System, normal_modes, solvers
from vibra.solvers import registry, runners
from vibra.solvers.budget import ResourceLimitError
from vibra.solvers.common import SolveResult
from vibra.solvers.dispatch import plan_problem
from vibra.solvers.problem import quadratic_problem
from vibra.solvers.standard import gpu

REGISTRY_SOURCE = Path(registry.__file__).read_text(encoding="utf-8")


def line(n: int, **options: Any) -> System:
    """A chain of n unit-spaced sites (masses and springs 1 unless given, walls by `anchors`)."""
    return System.from_springs(np.arange(n, dtype=float), options.get("masses", 1.0),
                               np.c_[np.arange(n - 1), np.arange(1, n)], options.get("springs", 1.0),
                               anchors=options.get("anchors"), anchor_stiffness=options.get("wall"))


def ring(n: int) -> System:
    bonds = np.r_[np.c_[np.arange(n - 1), np.arange(1, n)], [[n - 1, 0]]]
    return System.from_springs(np.arange(n, dtype=float), 1.0, bonds, 1.0)


def lattice(rows: int, columns: int) -> System:
    """A square 2-D lattice of springs with diagonals (a network, not a chain or a ring)."""
    sites = np.array([(i, j) for i in range(rows) for j in range(columns)], dtype=float)
    index = np.arange(rows * columns).reshape(rows, columns)
    bonds = np.r_[np.c_[index[:, :-1].ravel(), index[:, 1:].ravel()], np.c_[index[:-1].ravel(), index[1:].ravel()],
                  np.c_[index[:-1, :-1].ravel(), index[1:, 1:].ravel()]]
    return System.from_springs(sites, 1.0, bonds, 1.0)


def network(n_sites: int) -> System:
    """A random 3-D elastic network (uniform sites at density 0.05, springs within 8.5 units)."""
    from vibra import networks

    side = (n_sites / 0.05) ** (1.0 / 3.0)
    return networks.anm(np.random.default_rng(0).uniform(0.0, side, size=(n_sites, 3)), cutoff=8.5)


def generalized() -> System:
    rng = np.random.default_rng(3)
    coupled = rng.normal(size=(12, 12))
    return System.generalized(coupled @ coupled.T + 12 * np.eye(12), coupled.T @ coupled)  # type: ignore[return-value]


#: path -> (the system, what is asked of it). Each request is the smallest that path's predicate
#: takes ("auto" chooses it); the limits that keep rings and large networks off these paths
#: below their usual sizes are lowered in `lowered_limits`, and `dense_limit` lowers the size
#: past which one-sided Jacobi is weighed (a 50-dof network's all modes: the Rayleigh path).
CASES: dict[str, tuple[Callable[[], System], dict[str, Any]]] = {
    "gpu": (lambda: line(40), dict(device="gpu", accuracy="fast")),
    "accurate-bisection": (lambda: line(1600, masses=10.0 ** np.random.default_rng(1).uniform(-3, 3, 1600)),
                           dict(n_modes=4, vectors=False)),
    "accurate-walled": (lambda: line(150, anchors=np.arange(150), wall=0.5), dict(vectors=False)),
    "accurate-bidiagonal": (lambda: line(50), dict()),
    "accurate-ring": (lambda: ring(150), dict(vectors=False)),
    "accurate-ring-band": (lambda: ring(1700), dict()),
    "accurate-ritz": (lambda: line(1600), dict(n_modes=4)),
    "accurate-checked": (lambda: lattice(6, 6), dict()),
    "accurate-rayleigh": (lambda: lattice(5, 5), dict(vectors=False, dense_limit=30)),
    "pencil-jacobi": (generalized, dict()),
    "pencil-cholesky": (generalized, dict(accuracy="fast")),
    "tridiagonal": (lambda: line(1600), dict(vectors=False, accuracy="fast")),
    "banded": (lambda: ring(1600), dict(vectors=False, accuracy="fast")),
    "sparse": (lambda: line(1600), dict(n_modes=4, accuracy="fast")),
    "dense": (lambda: line(40), dict(accuracy="fast")),
    # a 3-D network over DENSE_LIMIT dofs, the factorisation's rate raised so that its estimate
    # passes the iterative path's (which the plan weighs, `registry._cheaper_rival`)
    "iterative": (lambda: network(600), dict(n_modes=8, accuracy="fast", factor_rate=1.0)),
    "accurate-iterative": (lambda: network(600), dict(n_modes=8, factor_rate=1.0)),
    # on the GPU (CuPy's numpy stand-in, `helpers.fake_cupy`), the dense GPU solve's rate raised likewise
    "iterative-gpu": (lambda: network(600), dict(n_modes=8, accuracy="fast", device="gpu", gpu_rate=1.0)),
}

#: The quadratic paths: (K, G or C) with M = I, from `tests/solvers/test_registry.py`'s cases.
QUADRATIC = {
    "skew-symmetric": (np.eye(2), dict(G=np.array([[0.0, -3.0], [3.0, 0.0]]))),
    "hamiltonian": (-np.eye(2), dict(G=np.array([[0.0, -3.0], [3.0, 0.0]]))),
    "companion": (np.eye(2), dict(C=0.1 * np.eye(2))),
}


@pytest.fixture
def lowered_limits(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 1,700-site ring's vectors take the band route (RING_DENSE_LIMIT 1,600), and no one-sided
    Jacobi past DENSE_LIMIT (JACOBI_WORK 0)."""
    monkeypatch.setattr(solvers.common, "RING_DENSE_LIMIT", 1600)
    monkeypatch.setattr(solvers.common, "JACOBI_WORK", 0)


@pytest.fixture
def fake_gpu(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The GPU's device solve as numpy's eigh, labelled with a name no path has: the name the
    result reports must come from the registry's declaration, not from the implementation."""
    calls: list[int] = []

    def eigh_on_the_host(Kt: np.ndarray, *, vectors: bool = True) -> SolveResult:
        calls.append(Kt.shape[0])
        values, basis = la.eigh(Kt)
        n = Kt.shape[0]
        error = np.full(n, n * np.finfo(float).eps * float(np.abs(values).max(initial=0.0)))
        return SolveResult(values, basis if vectors else None, error, 0.0, 0.0, "not-a-path")

    monkeypatch.setattr(gpu, "check_gpu_memory", lambda n, *, vectors: 0)
    monkeypatch.setattr(gpu, "dense_eigh_gpu", eigh_on_the_host)
    return calls


#: Paths "auto" never takes (only solver="slepc" names it): planned, solved over MPI and checked
#: against the dense solve in tests/solvers/test_slepc.py, which skips with its reason where MPI is missing.
NAMED_ONLY = {"slepc"}

#: The crystals' path: D(q) at a batch of wave vectors (`vibra.crystals.dynamical.phonons`).
BLOCH = {"hermitian-eigh"}


def test_every_registered_path_has_a_case() -> None:
    assert set(CASES) | set(QUADRATIC) | NAMED_ONLY | BLOCH == set(registry.BY_NAME)


def test_a_crystal_solve_is_planned_guarded_and_reported_by_the_registry() -> None:
    """issue 43 item 1: the crystals' stacked solves are a registry path like any other. The plan
    of a batch of D(q) names it, with the declaration's own estimate; the result reports it (a
    declared fallback where "high" re-solved near Gamma through the spring factor, or where a
    polar crystal's correction ran); and the guard refuses before any work, naming cheaper requests."""
    from vibra import crystals
    from vibra.crystals.dynamical import phonons, solve_plan

    silicon = crystals.diamond(5.43, [28.0855, 28.0855], 1.0, shells=2)
    q = np.array([[0.0, 0.0, 0.0], [1e-4, 0.0, 0.0], [0.1, 0.2, 0.3], [0.5, 0.5, 0.5]])
    for accuracy, vectors in (("fast", False), ("high", True)):
        plan = solve_plan(silicon, len(q), vectors=vectors, accuracy=accuracy)
        assert plan.path == "hermitian-eigh" and plan.cost == registry.BY_NAME[plan.path].estimate(plan.problem)
        assert plan.problem.batch == len(q) and plan.problem.n == silicon.n_branches
        result = phonons(silicon, q, vectors=vectors, accuracy=accuracy)
        assert result.path in (plan.path, *registry.BY_NAME[plan.path].fallbacks)
    assert phonons(silicon, q, accuracy="high").path == "hermitian-eigh + spring-svd"  # (Gamma: a zero mode)
    with pytest.raises(ResourceLimitError, match=r"D\(q\) has 6 branches: the hermitian-eigh path \(6 branches at "
                                                 r"1,000,000 q-points, with vectors\).*fewer wave vectors"):
        phonons(silicon, np.zeros((1_000_000, 3)), vectors=True, max_seconds=1e-3)
    assert phonons(silicon, q, max_seconds=float("inf")).omega.shape == (len(q), 6)


@pytest.mark.parametrize("name", list(CASES))
def test_each_path_is_planned_solved_and_reported_as_declared(name: str, lowered_limits: None, fake_gpu: list[int],
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    build, request = CASES[name]
    if "dense_limit" in request:  # (read by the registry's predicates; this request reaches no other one)
        monkeypatch.setattr(registry, "DENSE_LIMIT", request["dense_limit"])
    if "factor_rate" in request:  # (read by the sparse paths' cost function only)
        monkeypatch.setattr(registry, "SPARSE_FACTOR_S", request["factor_rate"])
        monkeypatch.setattr(registry, "ITERATIVE_FROM", 0)  # (a 1,800-dof network: the path's gate lowered)
    if "gpu_rate" in request:  # (the dense GPU solve's rate, read by its cost function only)
        monkeypatch.setattr(registry, "GPU_VECTORS_S", request["gpu_rate"])
        monkeypatch.setattr(registry, "ITERATIVE_FROM", 0)
        fake_cupy.install(monkeypatch)
    system = build()
    accuracy = request.get("accuracy", "high")
    device = request.get("device", "cpu")
    factor = system.spring_factor() if accuracy != "fast" and device == "cpu" else None
    asked = dict(n_modes=request.get("n_modes"), vectors=request.get("vectors", True), band=None)
    K, M = system.hessian(), system.mass_matrix()
    plan = solvers.plan(K, M, solver="auto", spring_factor=factor, accuracy=accuracy, device=device, **asked)
    assert plan.path == name
    declared = registry.BY_NAME[name]
    assert plan.cost.path == name and plan.cost.seconds > 0 and plan.cost.memory > 0
    assert plan.cost == declared.estimate(plan.problem)  # the declaration's own cost function
    modes = normal_modes(K, M, spring_factor=factor, accuracy=accuracy, device=device, **asked)
    assert modes.path == plan.path
    assert modes.n_modes == (request.get("n_modes") or system.n_dof)
    if name == "gpu":
        assert fake_gpu == [system.n_dof]  # (the device solve ran, through the plan)


@pytest.mark.parametrize("name", list(QUADRATIC))
def test_each_quadratic_path_is_planned_and_reported_as_declared(name: str) -> None:
    K, extra = QUADRATIC[name]
    definite = bool(np.linalg.eigvalsh(K).min() > 0)
    plan = plan_problem(quadratic_problem(2, damped="C" in extra, definite=definite), "auto")
    assert plan.path == name and plan.cost == registry.BY_NAME[name].estimate(plan.problem)
    assert System.generalized(np.eye(2), K, **extra).modes().path == plan.path


def test_the_gpu_path_is_guarded_like_any_path(fake_gpu: list[int]) -> None:
    """device="gpu" is planned and its estimate checked before any work (issue 43: it used to
    solve before the plan and the guard ran)."""
    chain = line(40)
    with pytest.raises(ResourceLimitError, match=r"the gpu path"):
        normal_modes(chain.hessian(), chain.mass_matrix(), device="gpu", max_seconds=1e-12)
    assert fake_gpu == []


def test_the_registry_finds_no_runner_by_name() -> None:
    """No `getattr` on the runners module, no name turned into a function name."""
    assert "getattr(" not in REGISTRY_SOURCE
    assert ".replace(\"-\", \"_\")" not in REGISTRY_SOURCE


def test_every_runner_is_referenced_by_exactly_one_declaration() -> None:
    own = {name: function for name, function in inspect.getmembers(runners, inspect.isfunction)
           if function.__module__ == runners.__name__ and not name.startswith("_")}
    referenced = [path.run for path in registry.PATHS]
    assert all(run in own.values() for run in referenced), "a path runs a function that is not a runner"
    for name, function in own.items():
        users = [path.name for path in registry.PATHS if path.run is function]
        assert len(users) == 1, f"runners.{name} is the runner of {users or 'no path'}"


def test_the_reported_name_is_the_declaration_or_its_fallback() -> None:
    path = registry.BY_NAME["accurate-checked"]
    result = SolveResult(np.zeros(1), None, np.zeros(1), 0.0, 0.0, "accurate-jacobi")
    assert path.reported(result) == "accurate-jacobi"
    result.solver = "whatever the implementation wrote"
    assert path.reported(result) == "accurate-checked"
