"""The registry of solver paths (issue 29, item 2): the plan names the path that runs, every
registered path is reachable, the springs' shape is classified in one place, and the table of
docs/solvers.md is the registry's.

Truth here is structural: the path a plan names against the path the result reports, for a
grid of requests over every kind of system; `topology.classify` against hand-made patterns.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree
import pytest
import scipy.sparse as sp

from vibra import System, normal_modes, solvers
from vibra.solvers import registry
from vibra.solvers.topology import classify

SOLVERS_PAGE = Path(__file__).resolve().parents[2] / "docs" / "solvers.md"


def test_the_solver_page_table_is_the_registry() -> None:
    assert registry.readme_table() in SOLVERS_PAGE.read_text(encoding="utf-8")


def chain_pattern(n: int, *, ring: bool = False, walls: tuple[int, ...] = ()) -> sp.csr_matrix:
    rows = [[i, i + 1] for i in range(n - 1)] + ([[0, n - 1]] if ring else [])
    data, r, c = [], [], []
    for k, (i, j) in enumerate(rows):
        r += [k, k]
        c += [i, j]
        data += [-1.0, 1.0]
    for k, site in enumerate(walls, start=len(rows)):
        r.append(k)
        c.append(site)
        data.append(1.0)
    return sp.csr_matrix((data, (r, c)), shape=(len(rows) + len(walls), n))


@pytest.mark.parametrize(("pattern", "kind"), [
    (chain_pattern(6), "chain"),
    (chain_pattern(6, walls=(0,)), "chain"),
    (chain_pattern(6, walls=(0, 5)), "chain"),
    (chain_pattern(6, walls=(2,)), "walled-chain"),
    (chain_pattern(6, walls=(0, 0)), "walled-chain"),
    (chain_pattern(6, ring=True), "ring"),
    (chain_pattern(6, ring=True, walls=(3,)), "walled-ring"),
    (sp.vstack([chain_pattern(6), chain_pattern(6)]).tocsr(), "network"),       # parallel springs
    (sp.csr_matrix(np.array([[-1.0, 1.0, 0, 0], [0, 0, -1.0, 1.0]])), "chain"),  # two runs
    (sp.csr_matrix(np.array([[-1.0, 0, 1.0, 0], [0, -1.0, 0, 1.0], [-1.0, 1.0, 0, 0]])), "network"),  # a ladder
    (sp.csr_matrix(np.array([[-1.0, 1.0, 0, 0, 0, 0], [0, -1.0, 1.0, 0, 0, 0], [1.0, 0, -1.0, 0, 0, 0],
                             [0, 0, 0, -1.0, 1.0, 0], [0, 0, 0, 0, -1.0, 1.0], [0, 0, 0, 1.0, 0, -1.0]])),
     "network"),                                                                 # two triangles: two cycles
    (sp.csr_matrix(np.array([[-1.0, 1.0, 0.5]])), "network"),                  # a three-dof term
])
def test_classify_names_the_shape_of_the_springs(pattern: sp.csr_matrix, kind: str) -> None:
    assert classify(pattern) == kind
    assert classify(pattern.toarray()) == kind
    if kind != "network":
        assert classify(pattern, diagonal_mass=False) == "network"


def test_classify_ignores_stored_zeros_and_leaves_b_as_it_was() -> None:
    B = chain_pattern(5, ring=True)
    B.data[-1] = 0.0  # the closing spring's entry at the last site stored as zero: a wall at site 0
    before = B.copy()
    assert classify(B) == "chain"  # (a wall at an end of the run)
    assert (B != before).nnz == 0 and B.nnz == before.nnz


def _kind_by_definition(rows: list[tuple[int, ...]], n: int) -> str:
    """The topology of springs `rows` (the dofs each row of B touches) on n dofs, from the
    definitions of `vibra.solvers.topology` written out plainly: a walk over the sites."""
    if not rows or any(len(row) not in (1, 2) or len(set(row)) != len(row) for row in rows):
        return "network"
    springs = [tuple(sorted(row)) for row in rows if len(row) == 2]
    walls = [row[0] for row in rows if len(row) == 1]
    if all(j == i + 1 for i, j in springs) and len(set(springs)) == len(springs):
        joined = {i for i, _ in springs}  # c joined to c + 1
        first = {c for c in range(n) if c - 1 not in joined}
        last = {c for c in range(n) if c not in joined}
        if all(walls.count(c) <= (c in first) + (c in last) for c in range(n)):
            return "chain"
        return "walled-chain" if len(springs) == n - 1 else "network"
    degree = [sum(c in pair for pair in springs) for c in range(n)]
    if n >= 3 and len(springs) == n and all(d == 2 for d in degree):
        neighbours = {c: [j if i == c else i for i, j in springs if c in (i, j)] for c in range(n)}
        seen, previous, site = {0}, -1, 0
        for _ in range(n - 1):  # walk the cycle from site 0: it must reach every site
            onward = [c for c in neighbours[site] if c != previous]
            if not onward:
                break
            previous, site = site, onward[0]
            seen.add(site)
        if len(seen) == n:
            return "walled-ring" if walls else "ring"
    return "network"


def test_classify_agrees_with_the_definitions_on_random_patterns() -> None:
    """2,000 random patterns of 1..8 dofs (runs, cycles, repeated and crossing springs, walls, a
    three-dof term, an empty row) in random row order: `classify` (numpy, vectorised) gives the
    kind the definitions give."""
    rng = np.random.default_rng(45)
    seen = set()
    for _ in range(2000):
        n = int(rng.integers(1, 9))
        shape = int(rng.integers(0, 3))
        if shape == 0:  # a run, maybe broken
            rows = [(i, i + 1) for i in range(n - 1) if rng.random() < 0.85]
        elif shape == 1:  # a cycle, maybe relabelled or broken
            order = rng.permutation(n) if rng.random() < 0.5 else np.arange(n)
            rows = [(int(order[i]), int(order[(i + 1) % n])) for i in range(n) if rng.random() < 0.9]
        else:
            rows = [tuple(int(c) for c in rng.integers(0, n, size=2)) for _ in range(int(rng.integers(0, 2 * n + 1)))]
        rows += [(int(rng.integers(0, n)),) for _ in range(int(rng.integers(0, 3)))]
        if rng.random() < 0.05:
            rows.append(())
        if rng.random() < 0.05 and n >= 3:
            rows.append((0, 1, 2))
        rows = [rows[i] for i in rng.permutation(len(rows))]
        rows = [row for row in rows if len(row) != 2 or row[0] != row[1]]  # (one entry, in a matrix)
        B = np.zeros((len(rows), n))
        for r, row in enumerate(rows):
            B[r, list(row)] = [(-1.0) ** k for k in range(len(row))]
        expected = _kind_by_definition(rows, n)
        assert classify(B) == expected, (rows, n)
        assert classify(sp.csr_matrix(B)) == expected
        seen.add(expected)
    assert seen == {"chain", "walled-chain", "ring", "walled-ring", "network"}


def systems() -> dict[str, tuple[System, dict[str, object]]]:
    """Small and large systems of every shape, each with what the grid may ask of it."""
    rng = np.random.default_rng(5)
    line = lambda n, **kw: System.from_springs(np.arange(n, dtype=float), kw.get("masses", 1.0),  # noqa: E731
                                               np.c_[np.arange(n - 1), np.arange(1, n)], kw.get("springs", 1.0),
                                               anchors=kw.get("anchors"), anchor_stiffness=kw.get("wall"))
    ring_bonds = lambda n: np.r_[np.c_[np.arange(n - 1), np.arange(1, n)], [[n - 1, 0]]]  # noqa: E731
    net = System.from_springs(rng.normal(size=(30, 3)), 1.0,
                              np.array([(i, j) for i in range(30) for j in range(i + 1, min(30, i + 5))]), 1.0)
    coupled = rng.normal(size=(12, 12))
    # (each site to its 6 nearest: springs between random sites far apart would look wrapped
    # around a periodic box to `System.from_springs`, which refuses them without cell=)
    big_sites = rng.uniform(0, 12, size=(600, 3))
    _, nearest = cKDTree(big_sites).query(big_sites, k=7)
    big_pairs = np.unique(np.sort(np.c_[np.repeat(np.arange(600), 6), nearest[:, 1:].ravel()], axis=1), axis=0)
    big_net = System.from_springs(big_sites, 1.0, big_pairs, 1.0)
    return {
        "chain-50": (line(50), {}),
        "chain-2000": (line(2000), {}),
        "spread-chain-2000": (line(2000, masses=10.0 ** rng.uniform(-3, 3, 2000),
                                   springs=10.0 ** rng.uniform(-3, 3, 1999)), {}),
        "walled-chain-150": (line(150, anchors=np.arange(150), wall=0.5), {}),
        "walled-chain-1600": (line(1600, anchors=np.arange(1600), wall=0.5), {}),
        "ring-60": (System.from_springs(np.arange(60, dtype=float), 1.0, ring_bonds(60), 1.0), {}),
        "ring-1700": (System.from_springs(np.arange(1700, dtype=float), 1.0, ring_bonds(1700), 1.0), {}),
        "walled-ring-300": (System.from_springs(np.arange(300, dtype=float), 1.0, ring_bonds(300), 1.0,
                                                anchors=[0, 100], anchor_stiffness=0.3), {}),
        "network-90": (net, {}),
        "network-1800": (big_net, {}),
        # a full mass matrix: the pencil paths (Jacobi; Cholesky with "fast")
        "generalized-12": (System.generalized(coupled @ coupled.T + 12 * np.eye(12), coupled.T @ coupled), {}),
    }


REQUESTS = [dict(n_modes=None, vectors=False), dict(n_modes=None, vectors=True), dict(n_modes=6, vectors=False),
            dict(n_modes=6, vectors=True), dict(band=(0.05, 0.3), vectors=True)]


@pytest.mark.slow
def test_the_plan_names_the_path_that_runs_and_every_path_is_reached(monkeypatch: pytest.MonkeyPatch) -> None:
    """Over every system above, every request shape and the three levels: `plan(...).path` is
    `modes.solver` (or one of that path's declared fallbacks), and every registered CPU path is
    reached; RING_DENSE_LIMIT and JACOBI_WORK are lowered so that a 1,700-site ring's vectors take
    the band route and an 1,800-dof network's all modes the Rayleigh one, in seconds."""
    monkeypatch.setattr(solvers.common, "RING_DENSE_LIMIT", 1600)
    monkeypatch.setattr(solvers.common, "JACOBI_WORK", 0)
    reached: set[str] = set()
    for (name, (system, _)), request, level in itertools.product(systems().items(), REQUESTS,
                                                                 solvers.ACCURACY_LEVELS):
        if name.startswith("network-1800") and request.get("n_modes") is None and "band" not in request \
                and level != "high":
            continue  # (a 5,400-dof dense solve per level: "high" covers the path)
        factor = system.spring_factor() if level != "fast" else None
        plan = solvers.plan(system.hessian(), system.mass_matrix(), n_modes=request.get("n_modes"),
                            vectors=bool(request["vectors"]), band=request.get("band"), solver="auto",
                            spring_factor=factor, accuracy=level)
        modes = system.modes(request.get("n_modes"), accuracy=level, vectors=bool(request["vectors"]),
                             band=request.get("band"), max_seconds=float("inf"))
        allowed = (plan.path, *registry.BY_NAME[plan.path].fallbacks)
        assert modes.solver in allowed, (name, request, level, plan.path, modes.solver)
        reached.add(plan.path)
    gpu = solvers.plan(np.eye(3), np.ones(3), n_modes=None, vectors=True, band=None, solver="auto",
                       spring_factor=None, device="gpu")
    reached.add(gpu.path)
    slepc = solvers.plan(sp.identity(40, format="csr"), np.ones(40), n_modes=6, vectors=True, band=None,
                         solver="slepc", spring_factor=None)  # (only when named: its runs in tests/solvers/test_slepc.py)
    reached.add(slepc.path)
    # (issue 47) the iterative paths, where the factorisation's estimate is the larger: its rate
    # raised here (the 1,800-dof network's runs: tests/solvers/test_registry_paths.py, tests/solvers/test_iterative.py)
    monkeypatch.setattr(registry, "SPARSE_FACTOR_S", 1.0)
    monkeypatch.setattr(registry, "ITERATIVE_FROM", 0)  # (its gate lowered to 1,800 dofs)
    network = systems()["network-1800"][0]
    for level in ("fast", "high"):
        reached.add(solvers.plan(network.hessian(), network.mass_matrix(), n_modes=8, vectors=True, band=None,
                                 solver="auto", spring_factor=network.spring_factor() if level != "fast" else None,
                                 accuracy=level).path)
    # on the GPU, where its estimate is under the dense solve's, raised here (its runs: tests/solvers/test_iterative_device.py)
    monkeypatch.setattr(registry, "GPU_VECTORS_S", 1.0)
    reached.add(solvers.plan(network.hessian(), network.mass_matrix(), n_modes=8, vectors=True, band=None,
                             solver="auto", spring_factor=None, device="gpu").path)
    reached.update(quadratic_paths())
    from vibra import crystals  # the crystals' D(q): tests/solvers/test_registry_paths.py runs it

    reached.add(crystals.dynamical.solve_plan(crystals.simple_cubic(1.0, 1.0, 1.0), 8, vectors=False).path)
    missing = [path.name for path in registry.PATHS if path.name not in reached]
    assert not missing, f"registered but never planned: {missing}"


def test_named_families_serve_what_they_can_and_refuse_what_they_cannot() -> None:
    chain = System.from_springs(np.arange(20, dtype=float), 1.0, np.c_[np.arange(19), np.arange(1, 20)], 1.0)
    K, M = chain.hessian(), chain.mass_matrix()
    for solver, path in (("dense", "dense"), ("tridiagonal", "tridiagonal"), ("banded", "banded")):
        assert solvers.plan(K, M, n_modes=None, vectors=True, band=None, solver=solver,
                            spring_factor=None).path == path
        assert normal_modes(K, M, solver=solver).solver == path
    assert solvers.plan(K, M, n_modes=3, vectors=True, band=None, solver="sparse", spring_factor=None).path == "sparse"
    with pytest.raises(ValueError, match="sparse"):
        solvers.plan(K, M, n_modes=None, vectors=True, band=None, solver="sparse", spring_factor=None)
    with pytest.raises(ValueError, match="tridiagonal"):
        solvers.plan(np.ones((3, 3)) + np.eye(3), np.ones(3), n_modes=None, vectors=True, band=None,
                     solver="tridiagonal", spring_factor=None)


def quadratic_paths() -> set[str]:
    """G or C: the quadratic family, chosen from what is given, the path the result reports."""
    G = np.array([[0.0, -3.0], [3.0, 0.0]])
    reached = set()
    for K, extra, path in ((np.eye(2), dict(G=G), "skew-symmetric"), (-np.eye(2), dict(G=G), "hamiltonian"),
                           (np.eye(2), dict(C=0.1 * np.eye(2)), "companion"),
                           (np.diag([1.0, 0.0]), dict(C=np.eye(2)), "companion")):
        modes = System.generalized(np.eye(2), K, **extra).modes()
        assert modes.path == path == registry.choose(
            registry.quadratic_problem(2, damped="C" in extra, definite=bool(np.linalg.eigvalsh(K).min() > 0)), "auto").name
        reached.add(modes.path)
    return reached


def test_the_quadratic_methods_are_registry_paths_named_estimated_and_guarded() -> None:
    """A named method serves where it applies and is refused, naming those that do, where it
    does not; the estimate is checked before any work (max_seconds), as for normal_modes."""
    from vibra.solvers.budget import ResourceLimitError

    G = np.array([[0.0, -3.0], [3.0, 0.0]])
    gyroscopic = System.generalized(np.eye(2), np.eye(2), G=G)
    assert gyroscopic.modes(solver="hamiltonian").path == "hamiltonian"  # it applies to any G-only system
    with pytest.raises(ValueError, match=r"solver='skew-symmetric'.*\['hamiltonian'\]"):
        System.generalized(np.eye(2), -np.eye(2), G=G).modes(solver="skew-symmetric")
    with pytest.raises(ValueError, match="solver='dense'"):
        gyroscopic.modes(solver="dense")
    with pytest.raises(ValueError, match="device='gpu'"):
        gyroscopic.modes(device="gpu")
    rng = np.random.default_rng(0)
    A = rng.normal(size=(300, 300))
    damped = System.generalized(np.eye(300), A @ A.T + np.eye(300), C=np.eye(300))
    with pytest.raises(ResourceLimitError, match="companion path"):
        damped.modes(max_seconds=1e-3)
    assert len(quadratic_paths()) == 3
