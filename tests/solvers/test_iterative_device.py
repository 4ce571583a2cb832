"""Tests of the iterative path on the GPU (`iterative.lowest_modes(device="gpu")`, the registry's `iterative-gpu`).

Two kinds. With the numpy stand-in for CuPy (`helpers.fake_cupy`: a host/device slip raises as it would on
a GPU) the plumbing runs everywhere: which array module each step uses, the memory check before the
setup, the plan's choice. Where CuPy sees a GPU (`needs_gpu`, skipped elsewhere with the reason) the
same requests run on it. Truth from outside the path: LAPACK's dense eigh of K~ (3,000 dofs) and scipy's
shift-invert `eigsh` (SuperLU, tol 0) beyond, with Weyl's bound: every computed omega^2 within its
residual of a true eigenvalue, so within its reported error plus the reference's own residual.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

import vibra
from helpers import fake_cupy
from vibra import networks
from vibra.solvers.standard import gpu, iterative, lobpcg
from vibra.solvers.standard.iterative import lowest_modes

GPU_READY, GPU_REASON = gpu.gpu_available()
needs_gpu = pytest.mark.skipif(not GPU_READY, reason=f"no GPU for the GPU path here: {GPU_REASON}")
EPS = float(np.finfo(float).eps)
ROOT = Path(__file__).resolve().parents[2]


def _assembly(n_sites: int):  # type: ignore[no-untyped-def]
    """The benchmark's synthetic assembly (copies of ubiquitin packed face to face), ANM at 15 Å."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from assembly_builder import synthetic_assembly
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return networks.anm(synthetic_assembly(n_sites), cutoff=15.0)


@pytest.fixture(scope="module")
def small() -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """K~ of a 1,000-site assembly (3,000 dofs, masses 1), its sites and LAPACK's eigenvalues."""
    system = _assembly(1000)
    K = sp.csr_matrix(system.hessian())
    return K, np.asarray(system.positions), la.eigh(K.toarray(), eigvals_only=True, driver="evd")


def _within_weyl(values: np.ndarray, error: np.ndarray, truth: np.ndarray, norm: float) -> None:
    """Each value within its reported error (>= its residual) of the true one, plus rounding of the reference."""
    gap = np.abs(values - truth[:values.size])
    assert (gap <= error + 100 * EPS * norm).all(), (gap / norm, error / norm)


# ---------------------------------------------------------------------- the stand-in itself
def test_the_stand_in_refuses_what_cupy_refuses(monkeypatch: pytest.MonkeyPatch) -> None:
    """Mixing a host and a device array, or numpy's own functions on a device array, raise: so a slip in the
    path's plumbing fails these tests as it would fail on a GPU."""
    cupy = fake_cupy.install(monkeypatch)
    device = cupy.asarray(np.ones((4, 2)))
    with pytest.raises(TypeError, match="host array"):
        device * np.ones((4, 2))
    with pytest.raises(TypeError, match="host array"):
        np.ones((2, 4)) @ device
    with pytest.raises(TypeError, match="numpy's"):
        np.linalg.eigh(device.T @ device)
    with pytest.raises(TypeError, match="host array"):
        gpu.device_csr(sp.identity(4)) @ np.ones((4, 2))
    assert isinstance(lobpcg.host(device.T @ device), np.ndarray) and not isinstance(
        lobpcg.host(device), fake_cupy.DeviceArray)


# ---------------------------------------------------------------------- the plumbing, with the stand-in
def test_lowest_modes_on_the_stand_in_device_match_lapack(monkeypatch: pytest.MonkeyPatch, small) -> None:
    """The whole path with the blocks, K~ and the multigrid cycle "on the device": the 20 lowest pairs within
    their reported errors of LAPACK's, residuals measured on the host within the 1e-8 promise, as on the CPU."""
    K, positions, truth = small
    norm = float(abs(K).sum(axis=1).max())
    on_cpu = lowest_modes(K, 20, positions=positions)
    fake_cupy.install(monkeypatch)
    on_device = lowest_modes(K, 20, positions=positions, device="gpu")
    for result in (on_cpu, on_device):
        _within_weyl(result.eigenvalues, result.error, truth, norm)
        residuals = np.linalg.norm(K @ result.vectors - result.vectors * result.eigenvalues, axis=0)
        assert residuals.max() <= iterative.ACCEPTED * norm
    assert np.abs(on_device.eigenvalues - on_cpu.eigenvalues).max() <= on_device.error.max() + on_cpu.error.max()


def test_the_device_memory_is_checked_before_the_setup(monkeypatch: pytest.MonkeyPatch, small) -> None:
    """A device with too little free memory refuses with the figures before pyamg is called."""
    K, positions, _ = small
    fake_cupy.install(monkeypatch, free=2**20)

    def no_setup(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("the multigrid setup ran before the memory check")

    monkeypatch.setattr(iterative, "BlockMultigrid", no_setup)
    with pytest.raises(ValueError, match=r"device='gpu': the lowest modes of 3000 dofs .* need .* GiB .* 0\.0 GiB is free"):
        lowest_modes(K, 20, positions=positions, device="gpu")


def test_iterative_gpu_memory_by_hand() -> None:
    """K~ in double CSR, the single-precision hierarchy and 16 n b doubles of blocks."""
    n, nnz, b = 3 * 10**6, 2 * 10**8, 56
    expected = 12 * nnz + 4 * n + 1.34 * 8 * nnz + 200 * n + 128 * n * b
    assert gpu.iterative_gpu_memory(n, nnz, b) == int(expected)
    with pytest.raises(ValueError, match="GiB is free"):
        gpu.check_iterative_memory(n, nnz, b, free=int(expected))


def test_normal_modes_on_the_gpu_plans_the_iterative_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """device="gpu" with n_modes on a 10^4-dof assembly: the plan takes `iterative-gpu` (its estimate under the
    dense GPU solve's) and `Modes.path` says so; solver="dense" still takes the dense path; the values match
    the CPU's iterative path within both reported errors."""
    system = _assembly(3334)
    on_cpu = system.modes(n_modes=20, accuracy="fast")
    fake_cupy.install(monkeypatch)
    K, M = system.hessian(), system.mass_matrix()
    plan = vibra.solvers.plan(K, M, n_modes=20, vectors=True, band=None, solver="auto", spring_factor=None,
                              device="gpu", positions=np.asarray(system.positions))
    assert plan.path == "iterative-gpu"
    dense = vibra.solvers.plan(K, M, n_modes=20, vectors=True, band=None, solver="dense", spring_factor=None,
                               device="gpu")
    assert dense.path == "gpu"
    on_gpu = system.modes(n_modes=20, device="gpu")
    assert on_gpu.path == "iterative-gpu" and on_cpu.path == "sparse"
    gap = np.abs(on_gpu.omega_squared - on_cpu.omega_squared)
    bound = 2 * on_gpu.omega_error * np.abs(on_gpu.omega) + 2 * on_cpu.omega_error * np.abs(on_cpu.omega)
    assert (gap <= bound + 1e-12 * np.abs(on_cpu.omega_squared).max()).all()


def test_a_gpu_with_another_solver_names_the_choices() -> None:
    K = sp.identity(6, format="csr")
    with pytest.raises(ValueError, match=r"device='gpu' runs the dense and the iterative paths only; solver is 'sparse'"):
        vibra.normal_modes(K, np.ones(6), n_modes=2, device="gpu", solver="sparse")


# ---------------------------------------------------------------------- on a GPU
@needs_gpu
def test_lowest_modes_on_the_gpu_match_lapack(small) -> None:
    K, positions, truth = small
    norm = float(abs(K).sum(axis=1).max())
    result = lowest_modes(K, 20, positions=positions, device="gpu")
    _within_weyl(result.eigenvalues, result.error, truth, norm)
    residuals = np.linalg.norm(K @ result.vectors - result.vectors * result.eigenvalues, axis=0)
    assert residuals.max() <= iterative.ACCEPTED * norm


@needs_gpu
def test_normal_modes_on_the_gpu_of_an_assembly_match_shift_invert() -> None:
    """10^4 dofs on the GPU against scipy's shift-invert eigsh (tol 0): the plan's `iterative-gpu`, every value
    within its error plus eigsh's own residual (Weyl)."""
    system = _assembly(3334)
    K = sp.csc_matrix(system.hessian())
    norm = float(abs(K).sum(axis=1).max())
    values, vectors = sla.eigsh(K, k=20, sigma=-1e-4 * norm, which="LM", tol=0)
    order = np.argsort(values)
    values, vectors = values[order], vectors[:, order]
    reference = np.linalg.norm(K @ vectors - vectors * values, axis=0)
    modes = system.modes(n_modes=20, device="gpu")
    assert modes.path == "iterative-gpu"
    gap = np.abs(modes.omega_squared - values)
    assert (gap <= 2 * modes.omega_error * np.abs(modes.omega) + reference + 100 * EPS * norm).all()


def test_device_csr_uploads_a_canonical_copy_and_leaves_the_input(monkeypatch: pytest.MonkeyPatch) -> None:
    """A CSR matrix with duplicate, unsorted entries (a user's K~ may be one, and is shared with the caller) goes up
    summed and sorted; the caller's arrays are unchanged, and the product is the matrix's."""
    cupy = fake_cupy.install(monkeypatch)
    matrix = sp.csr_matrix((np.array([1.0, 2.0, 3.0]), np.array([1, 0, 1]), np.array([0, 3, 3])), shape=(2, 2))
    before = [matrix.data.copy(), matrix.indices.copy(), matrix.indptr.copy()]
    uploaded = gpu.device_csr(matrix)
    assert uploaded.nnz == 2 and uploaded._matrix.has_canonical_format
    for array, kept in zip((matrix.data, matrix.indices, matrix.indptr), before):
        np.testing.assert_array_equal(array, kept)
    np.testing.assert_array_equal((uploaded @ cupy.asarray(np.eye(2))).get(), [[2.0, 4.0], [0.0, 0.0]])
