"""Tests of vibra/system.py: assembly of K and M, freezing, validation, immutability."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from vibra import GeneralizedSystem, System
from vibra.system import Vibrating


def numeric_hessian(positions: np.ndarray, pairs: np.ndarray, stiffness: np.ndarray, h: float = 1e-4) -> np.ndarray:
    """Central-difference Hessian of V = sum k/2 (|r_j - r_i| - l0)^2 (independent of vibra)."""
    rest = np.linalg.norm(positions[pairs[:, 1]] - positions[pairs[:, 0]], axis=1)

    def energy(x: np.ndarray) -> float:
        r = x.reshape(positions.shape)
        length = np.linalg.norm(r[pairs[:, 1]] - r[pairs[:, 0]], axis=1)
        return float(0.5 * np.sum(stiffness * (length - rest) ** 2))

    x0 = positions.ravel()
    n = x0.size
    H = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            e = np.zeros(n)
            f = np.zeros(n)
            e[i] = h
            f[j] = h
            H[i, j] = (energy(x0 + e + f) - energy(x0 + e - f) - energy(x0 - e + f) + energy(x0 - e - f)) / (4 * h * h)
    return H


def test_spring_hessian_blocks_match_finite_differences(rng: np.random.Generator) -> None:
    positions = rng.normal(size=(5, 3))
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [0, 4], [1, 3]])
    stiffness = rng.uniform(1, 5, len(pairs))
    system = System.from_springs(positions, 1.0, pairs, stiffness)
    K = system.hessian()
    assert sp.isspmatrix_csr(K)
    # Central differences of a smooth quartic-free energy: truncation O(h^2 V'''') ~ 1e-8.
    np.testing.assert_allclose(K.toarray(), numeric_hessian(positions, pairs, stiffness), atol=1e-6)


def test_anchor_and_1d_chain_matrix() -> None:
    system = System.from_springs([0.0, 1.0, 2.0], [1.0, 2.0, 3.0], [[0, 1], [1, 2]], [4.0, 5.0],
                                 anchors=[0], anchor_stiffness=7.0)
    expected = np.array([[4.0 + 7.0, -4.0, 0.0], [-4.0, 9.0, -5.0], [0.0, -5.0, 5.0]])
    np.testing.assert_array_equal(system.hessian().toarray(), expected)
    np.testing.assert_array_equal(system.mass_matrix(), [1.0, 2.0, 3.0])
    B, w = system.spring_factor()
    np.testing.assert_allclose((B.T @ sp.diags(w) @ B).toarray(), expected)


def test_frozen_sites_and_dofs_reduce_the_problem() -> None:
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    system = System.from_springs(positions, [1.0, 2.0, 3.0], [[0, 1], [1, 2], [0, 2]], 1.0)
    frozen = system.freeze(sites=[0], dofs=[3])  # site 0 entirely, and site 1's y
    assert frozen.n_dof == 3
    np.testing.assert_array_equal(frozen.free_dofs, [2, 4, 5])
    full = system.hessian().toarray()
    np.testing.assert_allclose(frozen.hessian().toarray(), full[np.ix_([2, 4, 5], [2, 4, 5])])
    np.testing.assert_array_equal(frozen.mass_matrix(), [2.0, 3.0, 3.0])
    expanded = frozen.expand(np.array([1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(expanded, [0, 0, 1, 0, 2, 3])


def test_user_hessian_and_generalized_systems() -> None:
    H = np.array([[2.0, -1.0], [-1.0, 2.0]])
    system = System.from_hessian([[0.0], [1.0]], [1.0, 1.0], H)
    assert system.spring_factor() is None
    np.testing.assert_array_equal(system.hessian().toarray(), H)
    M = np.array([[2.0, 0.3], [0.3, 1.0]])
    generalized = System.generalized(M, np.diag([1.0, 2.0]), coordinates=["theta1", "theta2"])
    assert generalized.is_generalized and generalized.labels == ("theta1", "theta2")
    np.testing.assert_array_equal(generalized.mass_matrix(), M)


def test_user_hessian_block_adds_to_springs() -> None:
    H = np.array([[3.0, -1.0], [-1.0, 3.0]])  # an extra coupling of sites 0 and 2 in 1-D
    system = System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0, blocks=[([0, 2], H)])
    expected = np.array([[1.0 + 3.0, -1.0, -1.0], [-1.0, 2.0, -1.0], [-1.0, -1.0, 1.0 + 3.0]])
    np.testing.assert_array_equal(system.hessian().toarray(), expected)
    assert system.spring_factor() is None  # blocks are not factorised: no accurate path
    np.testing.assert_allclose(system.modes().omega_squared, np.linalg.eigvalsh(expected), atol=1e-13)
    with pytest.raises(ValueError, match=r"blocks\[0\] H must be \(2, 2\) for 2 sites in 1-D"):
        System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1]], 1.0, blocks=[([0, 2], np.eye(3))])
    with pytest.raises(ValueError, match=r"blocks\[0\] H is not symmetric"):
        System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1]], 1.0, blocks=[([0, 2], [[1.0, 2.0], [0.0, 1.0]])])


def test_isotopes_change_masses_only() -> None:
    system = System.from_springs([0.0, 1.0], [1.0, 1.0], [[0, 1]], 2.0)
    heavy = system.with_masses([1.0, 3.0])
    np.testing.assert_array_equal(heavy.hessian().toarray(), system.hessian().toarray())
    # Two masses on one spring: omega = sqrt(k / mu), mu the reduced mass.
    assert heavy.modes().omega[1] == pytest.approx(np.sqrt(2.0 / (3.0 / 4.0)), rel=1e-14)


def test_a_million_springs_assemble_to_the_closed_form_tridiagonal(rng: np.random.Generator) -> None:
    """K of a free 1-D chain of 10^6 springs k_i is the tridiagonal Laplacian of the chain.

    Truth (independent of vibra): (K u)_i = k_{i-1} (u_i - u_{i-1}) + k_i (u_i - u_{i+1}), so
    diag(K) = (k_0, k_0 + k_1, ..., k_{n-2}) and K[i, i+1] = -k_i; a rigid translation has
    no restoring force, and u_i = i^2 on unit springs gives -2 inside and -1, 2n - 3 at the ends.
    """
    n = 1_000_001
    k = rng.uniform(0.5, 2.0, n - 1)
    system = System.from_springs(np.arange(n, dtype=float), 1.0, np.c_[np.arange(n - 1), np.arange(1, n)], k)
    K = system.hessian()
    assert K.shape == (n, n) and K.nnz == 3 * n - 2
    diagonal = np.concatenate([[0.0], k]) + np.concatenate([k, [0.0]])
    expected = sp.diags([-k, diagonal, -k], [-1, 0, 1], format="csr")
    gap = abs(K - expected)
    assert gap.max() <= 4 * np.finfo(float).eps * diagonal.max()
    assert np.abs(K @ np.ones(n)).max() <= 4 * np.finfo(float).eps * diagonal.max()
    unit = System.from_springs(np.arange(n, dtype=float), 1.0, np.c_[np.arange(n - 1), np.arange(1, n)], 1.0)
    u = np.arange(n, dtype=float) ** 2
    force = unit.hessian() @ u
    assert force[0] == -1.0 and force[-1] == 2.0 * n - 3.0
    np.testing.assert_array_equal(force[1:-1], -2.0)


def test_system_is_immutable() -> None:
    system = System.from_springs([0.0, 1.0], 1.0, [[0, 1]], 1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        system.masses = np.ones(2)  # type: ignore[misc]
    with pytest.raises(ValueError):
        system.masses[0] = 5.0
    with pytest.raises(ValueError):
        system.coupling.data[0] = 5.0


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"masses": [1.0, -1.0]}, ValueError, r"masses\[1\] is -1.0; every mass must be positive"),
        ({"masses": [1.0, np.nan]}, ValueError, r"masses\[1\] is nan"),
        ({"masses": [1.0, 1.0, 1.0]}, ValueError, r"masses must have 2 entries"),
        ({"stiffness": -3.0}, ValueError, r"stiffness\[0\] is -3.0; every spring constant must be positive"),
        ({"springs": [[0, 2]]}, ValueError, r"springs\[0,1\] is 2; site indices run from 0 to 1"),
        ({"springs": [[1, 1]]}, ValueError, r"springs\[0\] joins site 1 to itself"),
        ({"springs": [[0.0, 1.0]]}, TypeError, r"springs must hold integer site indices"),
        ({"positions": [0.0, 0.0]}, ValueError, r"springs\[0\] joins sites 0 and 1 at the same position"),
        ({"positions": np.zeros((2, 4))}, ValueError, r"positions must be \(n_sites, dim\) with dim 1, 2 or 3"),
        ({"anchors": [0], "anchor_stiffness": 0.0}, ValueError, r"anchor_stiffness\[0\] is 0.0"),
        ({"frozen_sites": [0, 1]}, ValueError, r"every degree of freedom is frozen"),
        ({"units": "imperial"}, ValueError, r"units is 'imperial'; expected one of"),
    ],
)
def test_from_springs_validation(kwargs, error, match) -> None:  # type: ignore[no-untyped-def]
    arguments = {"positions": [0.0, 1.0], "masses": [1.0, 1.0], "springs": [[0, 1]], "stiffness": 1.0}
    arguments.update(kwargs)
    with pytest.raises(error, match=match):
        System.from_springs(**arguments)


def test_generalized_validation() -> None:
    with pytest.raises(ValueError, match=r"M is not positive definite"):
        System.generalized(np.array([[1.0, 2.0], [2.0, 1.0]]), np.eye(2))
    with pytest.raises(ValueError, match=r"K is not symmetric"):
        System.generalized(np.eye(2), np.array([[1.0, 0.5], [0.0, 1.0]]))
    with pytest.raises(ValueError, match=r"coordinates must name 2 coordinates, got 1"):
        System.generalized(np.eye(2), np.eye(2), coordinates=["a"])
    with pytest.raises(ValueError, match=r"accuracy is 'best'"):
        System.generalized(np.eye(2), np.eye(2)).modes(accuracy="best")  # type: ignore[arg-type]


def test_frozen_dofs_out_of_range_names_dof_indices() -> None:
    with pytest.raises(ValueError, match=r"frozen_dofs\[0\] is 9; dof indices run from 0 to 3"):
        System.from_springs(np.zeros((2, 2)) + [[0.0, 0.0], [1.0, 0.0]], 1.0, [[0, 1]], 1.0, frozen_dofs=[9])


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"springs": None}, ValueError, r"^stiffness was given without springs$"),
        ({"stiffness": None}, ValueError, r"^stiffness is required$"),
        ({"stiffness": [1.0, 2.0]}, ValueError, r"^stiffness must have 1 entries, got 2$"),
        ({"springs": [0, 1, 1]}, ValueError, r"springs must have shape \('n', 2\), got \(3,\)"),
        ({"anchor_stiffness": 1.0}, ValueError, r"^anchor_stiffness was given without anchors$"),
        ({"anchors": [0], "anchor_stiffness": 1.0, "anchor_directions": [[1.0, 0.0]]}, ValueError,
         r"anchor_directions must have shape \(1, 1\), got \(1, 2\)"),
        ({"anchors": [0], "anchor_stiffness": 1.0, "anchor_directions": [[0.0]]}, ValueError,
         r"anchor_directions\[0\] is the zero vector"),
        ({"positions": np.zeros((0, 1)), "masses": [], "springs": None, "stiffness": None}, ValueError,
         r"positions must hold at least one site, got none"),
        ({"positions": ["a", "b"]}, TypeError, r"positions must be an array of real numbers, got list"),
        ({"positions": sp.eye(2)}, TypeError, r"positions must be a dense array here, got a scipy.sparse matrix"),
        ({"blocks": [5]}, TypeError, r"blocks\[0\] must be a pair \(sites, H\)"),
    ],
)
def test_from_springs_argument_pairing_and_shapes(kwargs, error, match) -> None:  # type: ignore[no-untyped-def]
    arguments = {"positions": [0.0, 1.0], "masses": [1.0, 1.0], "springs": [[0, 1]], "stiffness": 1.0}
    arguments.update(kwargs)
    with pytest.raises(error, match=match):
        System.from_springs(**arguments)


def test_from_terms_and_from_hessian_validation() -> None:
    B = sp.csr_matrix([[-1.0, 1.0]])
    with pytest.raises(ValueError, match=r"^coupling must have 3 columns \(n_sites \* dim\), got shape \(1, 2\)$"):
        System.from_terms([0.0, 1.0, 2.0], 1.0, B, [1.0])
    with pytest.raises(ValueError, match=r"^weights must have 1 entries \(one per row of coupling\), got 2$"):
        System.from_terms([0.0, 1.0], 1.0, B, [1.0, 2.0])
    with pytest.raises(ValueError, match=r"^extra_hessian must be \(2, 2\), got \(3, 3\)$"):
        System.from_terms([0.0, 1.0], 1.0, B, [1.0], extra_hessian=np.eye(3))
    with pytest.raises(ValueError, match=r"^hessian must be \(2, 2\), got \(3, 3\)$"):
        System.from_hessian([0.0, 1.0], 1.0, np.eye(3))
    with pytest.raises(ValueError, match=r"^hessian must be square, got shape \(2, 3\)$"):
        System.from_hessian([0.0, 1.0], 1.0, np.ones((2, 3)))


def test_freezing_the_last_free_dof_is_refused() -> None:
    system = System.from_springs([0.0, 1.0], 1.0, [[0, 1]], 1.0, frozen_sites=[1])
    with pytest.raises(ValueError, match=r"^every degree of freedom is frozen; nothing is left to vibrate$"):
        system.freeze(sites=[0])


def test_a_system_of_sites_is_not_generalized() -> None:
    system = System.from_springs([0.0, 1.0], 1.0, [[0, 1]], 1.0)
    assert not system.is_generalized and system.dim == 1 and system.n_sites == 2


# ---------------------------------------------------------------------- generalised coordinates
def two_coordinates() -> GeneralizedSystem:
    """M = diag(2, 1), K = [[8, -1], [-1, 1]] (J/rad^2), coordinates a and b."""
    return System.generalized(np.diag([2.0, 1.0]), [[8.0, -1.0], [-1.0, 1.0]], coordinates=["a", "b"])


def test_generalized_system_stores_M_and_K_and_solves_the_pencil() -> None:
    system = two_coordinates()
    assert isinstance(system, GeneralizedSystem) and isinstance(system, Vibrating) and not isinstance(system, System)
    assert system.is_generalized and system.n_sites == 0 and system.dim == 0
    assert system.spring_factor() is None
    np.testing.assert_array_equal(system.M, np.diag([2.0, 1.0]))
    np.testing.assert_array_equal(system.K, [[8.0, -1.0], [-1.0, 1.0]])
    assert sp.isspmatrix_csr(system.hessian())
    # det(K - w^2 M) = (8 - 2 r)(1 - r) - 1 = 0: r = (5 -+ sqrt(11)) / 2.
    expected = np.array([(5.0 - np.sqrt(11.0)) / 2.0, (5.0 + np.sqrt(11.0)) / 2.0])
    for accuracy in ("high", "fast"):
        np.testing.assert_allclose(system.modes(accuracy=accuracy).omega_squared, expected, rtol=1e-14)
    same = System.generalized([2.0, 1.0], [[8.0, -1.0], [-1.0, 1.0]])  # M as its diagonal
    np.testing.assert_array_equal(same.M, system.M)
    assert same.labels == ("q0", "q1")


def test_generalized_freeze_holds_coordinates_at_rest() -> None:
    frozen = two_coordinates().freeze(dofs=[0])
    assert frozen.n_dof == 1 and frozen.labels == ("a", "b")
    np.testing.assert_array_equal(frozen.free_dofs, [1])
    np.testing.assert_array_equal(frozen.hessian().toarray(), [[1.0]])
    np.testing.assert_array_equal(frozen.mass_matrix(), [[1.0]])
    # q_a = 0: b alone, K_bb / M_bb = 1.
    assert frozen.modes().omega_squared[0] == pytest.approx(1.0, rel=1e-15)
    np.testing.assert_array_equal(frozen.expand(np.array([3.0])), [0.0, 3.0])


def test_generalized_freeze_validation() -> None:
    system = two_coordinates()
    with pytest.raises(ValueError, match=r"generalised coordinates have no sites; freeze coordinates with freeze\(dofs"):
        system.freeze(sites=[0])
    with pytest.raises(ValueError, match=r"^dofs\[0\] is 5; coordinate indices run from 0 to 1$"):
        system.freeze(dofs=[5])
    with pytest.raises(TypeError, match=r"^dofs must hold integer coordinate indices, got dtype float64$"):
        system.freeze(dofs=[0.5])
    with pytest.raises(ValueError, match=r"^every degree of freedom is frozen; nothing is left to vibrate$"):
        system.freeze(dofs=[0]).freeze(dofs=[1])


def test_generalized_matrix_validation() -> None:
    with pytest.raises(ValueError, match=r"^M must have 2 masses to match K, got shape \(3,\)$"):
        System.generalized([1.0, 1.0, 1.0], np.eye(2))
    with pytest.raises(ValueError, match=r"^M must be \(2, 2\) to match K, got shape \(3, 3\)$"):
        System.generalized(np.eye(3), np.eye(2))
    with pytest.raises(ValueError, match=r"^K must be square, got shape \(2, 3\)$"):
        System.generalized(np.eye(2), np.ones((2, 3)))
    with pytest.raises(ValueError, match=r"^K must have at least one row, got shape \(0, 0\)$"):
        System.generalized(np.eye(2), np.zeros((0, 0)))
    with pytest.raises(ValueError, match=r"^units is 'imperial'"):
        System.generalized(np.eye(2), np.eye(2), units="imperial")


def test_generalized_system_is_immutable() -> None:
    system = two_coordinates()
    with pytest.raises(dataclasses.FrozenInstanceError):
        system.K = np.eye(2)  # type: ignore[misc]
    for array in (system.M, system.K, system.frozen):
        with pytest.raises(ValueError):
            array[0] = 0


def test_with_symbols_keeps_one_symbol_per_site_and_refuses_others() -> None:
    chain = System.from_springs([0.0, 1.1, 2.2], [16.0, 12.0, 16.0], [[0, 1], [1, 2]], 1.0)
    assert chain.symbols is None
    labelled = chain.with_symbols(["O", "C", "O"])
    assert labelled.symbols == ("O", "C", "O") and labelled.with_masses([18.0, 12.0, 16.0]).symbols == ("O", "C", "O")
    assert labelled.with_symbols(None).symbols is None
    with pytest.raises(ValueError, match=r"symbols has 2 entries; expected one per site \(3\)"):
        chain.with_symbols(["O", "C"])
    with pytest.raises(TypeError, match=r"symbols must be a sequence of str"):
        chain.with_symbols("OCO")
    with pytest.raises(TypeError, match=r"symbols\[1\] is 6"):
        chain.with_symbols(["O", 6, "O"])
    with pytest.raises(ValueError, match=r"symbols\[2\] is empty"):
        chain.with_symbols(["O", "C", " "])
