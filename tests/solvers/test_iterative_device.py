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

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as sla

import vibra
from helpers import fake_cupy
from helpers.assemblies import synthetic_assembly
from vibra.solvers.standard import gpu, iterative, lobpcg
from vibra.solvers.standard.iterative import lowest_modes

GPU_READY, GPU_REASON = gpu.gpu_available()
needs_gpu = pytest.mark.skipif(not GPU_READY, reason=f"no GPU for the GPU path here: {GPU_REASON}")
EPS = float(np.finfo(float).eps)


@pytest.fixture(scope="module")
def small() -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """K~ of a 1,000-site assembly (3,000 dofs, masses 1), its sites and LAPACK's eigenvalues."""
    system = synthetic_assembly(1000)
    K = sp.csr_matrix(system.hessian())
    return K, np.asarray(system.positions), la.eigh(K.toarray(), eigvals_only=True, driver="evd")


def _within_weyl(values: np.ndarray, error: np.ndarray, truth: np.ndarray, norm: float) -> None:
    """Each value within its reported error (>= its residual) of the true one, plus rounding of the reference."""
    gap = np.abs(values - truth[:values.size])
    assert (gap <= error + 100 * EPS * norm).all(), (gap / norm, error / norm)


# ---------------------------------------------------------------------- the stand-in itself
def test_the_stand_in_refuses_what_cupy_refuses(monkeypatch: pytest.MonkeyPatch) -> None:
    """Mixing a host and a device array, any implicit conversion to the host (numpy's functions, np.asarray, a
    scipy sparse product, host indexing), or a sparse product of two types, raise: so a slip in the path's
    plumbing fails these tests as it would fail on a GPU; `.get()` and `lobpcg.host` bring arrays back."""
    cupy = fake_cupy.install(monkeypatch)
    device = cupy.asarray(np.ones((4, 2)))
    slips = [lambda: device * np.ones((4, 2)), lambda: np.ones((2, 4)) @ device, lambda: np.asarray(device),
             lambda: np.linalg.eigh(device.T @ device), lambda: sp.identity(4, format="csr") @ device,
             lambda: np.ones(4)[cupy.asarray(np.array([0, 1]))], lambda: cupy.sqrt(np.ones(3)),
             lambda: gpu.device_csr(sp.identity(4)) @ np.ones((4, 2)),
             lambda: gpu.device_csr(sp.identity(4)) @ device.astype(np.float32)]
    for slip in slips:
        with pytest.raises(TypeError, match="fake Cu[Pp]y|fake cupyx"):
            slip()
    product = gpu.device_csr(sp.identity(4)) @ device
    assert product.flags.f_contiguous and fake_cupy.PRODUCTS == {"float64": 1}
    assert isinstance(lobpcg.host(device.T @ device), np.ndarray) and lobpcg.host(device).shape == (4, 2)


# ---------------------------------------------------------------------- the plumbing, with the stand-in
def test_lowest_modes_on_the_stand_in_device_match_lapack(monkeypatch: pytest.MonkeyPatch, small) -> None:
    """The whole path with the blocks, K~ and the multigrid cycle "on the device": the 20 lowest pairs within
    their reported errors of LAPACK's, residuals measured on the host within the 1e-8 promise, as on the CPU."""
    K, positions, truth = small
    norm = float(abs(K).sum(axis=1).max())
    on_cpu = lowest_modes(K, 20, positions=positions)
    fake_cupy.install(monkeypatch)

    def on_the_host(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("a host product was built for the GPU path")

    monkeypatch.setattr(iterative, "products", on_the_host)  # (the CPU path's products: none on the GPU's)
    on_device = lowest_modes(K, 20, positions=positions, device="gpu")
    # K~'s products in double and the cycle's in single precision, all on the "device"
    assert fake_cupy.PRODUCTS["float64"] >= 10 and fake_cupy.PRODUCTS["float32"] >= 10 * 5
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


def test_the_estimate_covers_what_the_stand_in_device_holds(monkeypatch: pytest.MonkeyPatch, small) -> None:
    """`iterative_gpu_memory` against the bytes of every array alive on the stand-in device at its peak during
    a solve (each upload and result counted while it lives): the estimate is an upper bound, within 3x."""
    import gc
    import weakref

    K, positions, _ = small
    fake_cupy.install(monkeypatch)
    alive: dict[int, int] = {}
    peak = [0]
    original = fake_cupy.DeviceArray.__init__

    def counted(self, data):  # type: ignore[no-untyped-def]
        original(self, data)
        if data.base is None:  # (views share their base's bytes)
            key = id(self)
            alive[key] = data.nbytes
            weakref.finalize(self, alive.pop, key, None)
            peak[0] = max(peak[0], sum(alive.values()))

    monkeypatch.setattr(fake_cupy.DeviceArray, "__init__", counted)
    lowest_modes(K, 20, positions=positions, device="gpu")
    gc.collect()
    columns = iterative.block_columns(20, 6)
    blocks = gpu.iterative_gpu_memory(K.shape[0], K.nnz, columns) - gpu.iterative_gpu_memory(K.shape[0], K.nnz, 0)
    assert peak[0] <= blocks <= 3 * peak[0], (peak[0], blocks)
    with pytest.raises(ValueError, match="GiB is free"):
        gpu.check_iterative_memory(K.shape[0], K.nnz, columns, free=gpu.iterative_gpu_memory(K.shape[0], K.nnz, columns))


def test_normal_modes_on_the_gpu_plans_the_iterative_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """device="gpu" with n_modes on a 10^4-dof assembly: the plan takes `iterative-gpu` (its estimate under the
    dense GPU solve's) and `Modes.path` says so; solver="dense" still takes the dense path; the values match
    the CPU's iterative path within both reported errors."""
    system = synthetic_assembly(3334)
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
    system = synthetic_assembly(3334)
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


def test_device_csr_leaves_the_input_and_refuses_what_old_cupy_would_wrap(monkeypatch: pytest.MonkeyPatch) -> None:
    """A CSR matrix with duplicate, unsorted entries (a user's K~ may be one, and is shared with the caller) goes up
    unchanged in the caller's arrays, its product the matrix's; a matrix of 2^31 entries is refused with CuPy
    before 14.1 (its 32-bit indices would wrap), with the figures, before any upload."""
    cupy = fake_cupy.install(monkeypatch)
    matrix = sp.csr_matrix((np.array([1.0, 2.0, 3.0]), np.array([1, 0, 1]), np.array([0, 3, 3])), shape=(2, 2))
    before = [matrix.data.copy(), matrix.indices.copy(), matrix.indptr.copy()]
    uploaded = gpu.device_csr(matrix)
    for array, kept in zip((matrix.data, matrix.indices, matrix.indptr), before):
        np.testing.assert_array_equal(array, kept)
    np.testing.assert_array_equal((uploaded @ cupy.asarray(np.eye(2))).get(), [[2.0, 4.0], [0.0, 0.0]])
    gpu.check_iterative_memory(3, 2**31, 1, free=2**40)  # (given free memory: CuPy's version not asked)
    monkeypatch.setattr(cupy, "__version__", "14.0.1")
    with pytest.raises(ValueError, match=r"2147483648 stored entries, and CuPy 14\.0\.1 .* 32-bit"):
        gpu.check_iterative_memory(3 * 10**7, 2**31, 56)
    monkeypatch.setattr(cupy, "__version__", "14.1.0")
    with pytest.raises(ValueError, match="GiB is free"):  # (the index check passes; the memory one decides)
        gpu.check_iterative_memory(3 * 10**7, 2**31, 56)


def test_without_cupy_the_iterative_request_names_the_extra(monkeypatch: pytest.MonkeyPatch, small) -> None:
    """No CuPy: `GPUUnavailableError` naming the extra, before any setup; never the CPU instead."""
    K, positions, _ = small
    monkeypatch.setitem(sys.modules, "cupy", None)

    def no_setup(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("the multigrid setup ran without a GPU")

    monkeypatch.setattr(iterative, "BlockMultigrid", no_setup)
    with pytest.raises(gpu.GPUUnavailableError, match=r'pip install "vibra\[gpu\]"'):
        lowest_modes(K, 20, positions=positions, device="gpu")
    with pytest.raises(gpu.GPUUnavailableError, match=r'pip install "vibra\[gpu\]"'):
        vibra.normal_modes(K, np.ones(K.shape[0]), n_modes=20, device="gpu", solver="iterative")


def test_a_refused_gpu_request_offers_the_cpu_with_its_estimate() -> None:
    """A GPU request over the limits (here all modes densely, in no time at all) names device="cpu" and the
    CPU's path with its estimate among the cheaper requests, before anything touches a GPU."""
    from vibra.solvers import ResourceLimitError

    chain = vibra.System.from_springs(np.arange(40.0), 1.0, [[i, i + 1] for i in range(39)], 1.0)
    with pytest.raises(ResourceLimitError, match=r'device="cpu" \(\w[\w-]*: ~.*s\)'):
        vibra.normal_modes(chain.hessian(), chain.mass_matrix(), device="gpu", max_seconds=1e-12)


@pytest.mark.parametrize(("mass", "band"), [(np.eye(6) + 0.1 * (np.eye(6, k=1) + np.eye(6, k=-1)), None),
                                           (np.ones(6), (0.0, 1.0))])
def test_iterative_on_the_gpu_refuses_a_band_or_a_full_mass_with_the_gpus_way_out(mass, band) -> None:
    """solver="iterative" with a band or a full M on the GPU names what the GPU serves (its dense path) or the
    CPU, never a CPU-only solver the GPU request would refuse next."""
    K = sp.identity(6, format="csr")
    with pytest.raises(ValueError, match=r"use solver='dense' or 'auto' \(device='gpu'.*device='cpu'") as refused:
        vibra.normal_modes(K, mass, n_modes=None if band else 2, band=band, device="gpu", solver="iterative")
    assert "pencil" not in str(refused.value) and "'sparse'" not in str(refused.value)
