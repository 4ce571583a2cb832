"""Tests of `vibra/solvers/standard/gpu.py`, the optional GPU path (CuPy, cuSOLVER syevd).

The plumbing (device names, the missing-extra errors, the memory estimate and the refusal
before any allocation) runs everywhere, with CuPy hidden or faked. The numbers run only where
CuPy sees a GPU and are reported as skipped elsewhere; their truth is scipy's LAPACK eigh, the
trace of K~, numpy residuals and the six rigid-body modes of a free 3-D spring network.
"""

from __future__ import annotations

import sys
import types
from typing import Any

import numpy as np
import pytest
import scipy.linalg as la
from scipy.spatial import cKDTree

import vibra
from vibra.solvers.standard import gpu

EPS = float(np.finfo(float).eps)
GPU_READY, GPU_REASON = gpu.gpu_available()
needs_gpu = pytest.mark.skipif(not GPU_READY, reason=f"no GPU for the GPU path here: {GPU_REASON}")


def spring_network(n_sites: int, seed: int = 7) -> tuple[Any, np.ndarray]:
    """A free 3-D network: random sites at unit density, springs within 1.6 (about 17 each)."""
    rng = np.random.default_rng(seed)
    positions = rng.uniform(0.0, n_sites ** (1 / 3), size=(n_sites, 3))
    pairs = np.array(sorted(cKDTree(positions).query_pairs(1.6)))
    masses = rng.uniform(1.0, 3.0, n_sites)
    system = vibra.System.from_springs(positions, masses, pairs, rng.uniform(0.5, 2.0, len(pairs)),
                                       units="dimensionless")
    return system.hessian().toarray(), system.mass_matrix()


def weighted(K: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """K~ = M^-1/2 K M^-1/2 for diagonal masses (eq. 139), in numpy."""
    scale = 1.0 / np.sqrt(mass)
    return K * scale[:, None] * scale[None, :]


@pytest.fixture
def no_cupy(monkeypatch: pytest.MonkeyPatch) -> None:
    """`import cupy` fails, as on a machine without the extra."""
    monkeypatch.setitem(sys.modules, "cupy", None)


# ---------------------------------------------------------------------- device argument
@pytest.mark.parametrize(("given", "expected"), [("cpu", "cpu"), ("gpu", "gpu"), ("cuda", "gpu")])
def test_check_device_accepts_the_names(given: str, expected: str) -> None:
    assert gpu.check_device(given) == expected


@pytest.mark.parametrize("given", ["tpu", "GPU", "", "cuda:0"])
def test_check_device_rejects_unknown_names(given: str) -> None:
    with pytest.raises(ValueError, match=r"device is .*expected one of 'cpu', 'gpu'"):
        gpu.check_device(given)


def test_check_device_rejects_non_strings() -> None:
    with pytest.raises(TypeError, match="device must be a string"):
        gpu.check_device(0)


# ---------------------------------------------------------------------- missing CuPy / GPU
def test_without_cupy_the_error_names_the_extra(no_cupy: None) -> None:
    available, reason = gpu.gpu_available()
    assert not available
    assert 'pip install "vibra[gpu]"' in reason
    with pytest.raises(gpu.GPUUnavailableError, match=r'pip install "vibra\[gpu\]"') as caught:
        gpu.dense_eigh_gpu(np.eye(3))
    assert isinstance(caught.value, ImportError) and isinstance(caught.value, RuntimeError)


def test_without_cupy_no_cpu_fallback(no_cupy: None) -> None:
    K = np.array([[1.0, -1.0], [-1.0, 1.0]])
    with pytest.raises(gpu.GPUUnavailableError, match="device='gpu' needs CuPy"):
        gpu.solve_gpu(K, np.ones(2), n_modes=None, vectors=True, band=None)


def test_cupy_without_a_device(monkeypatch: pytest.MonkeyPatch) -> None:
    def no_device() -> int:
        raise RuntimeError("cudaErrorNoDevice: no CUDA-capable device is detected")

    fake = types.SimpleNamespace(__version__="0.0", cuda=types.SimpleNamespace(
        runtime=types.SimpleNamespace(getDeviceCount=no_device)))
    monkeypatch.setitem(sys.modules, "cupy", fake)
    available, reason = gpu.gpu_available()
    assert not available and "finds no usable GPU" in reason and "cudaErrorNoDevice" in reason
    with pytest.raises(gpu.GPUUnavailableError, match="use device='cpu' here"):
        gpu.dense_eigh_gpu(np.eye(2))


def test_import_vibra_does_not_import_cupy() -> None:
    import subprocess

    code = "import sys, vibra, vibra.solvers.standard.gpu; print('cupy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ---------------------------------------------------------------------- memory estimate
def test_memory_estimate_by_hand(no_cupy: None) -> None:
    """Without a GPU to ask, the documented bound: n^2 doubles for K~ plus the larger of
    (4 n^2 + 256 n + 2^20) doubles of syevd workspace + 4 n doubles + 1 MiB, and, with
    vectors, n^2 + 4 n min(n, 256) doubles for the residuals."""
    n = 1000
    matrix = 8 * n * n
    solve = 8 * (4 * n * n + 256 * n + 2**20) + 8 * 4 * n + 2**20
    figures = 8 * (n * n + 4 * n * 256)
    assert solve > figures
    assert gpu.estimate_gpu_memory(n, vectors=True) == matrix + solve == 51_517_184
    assert gpu.estimate_gpu_memory(n, vectors=False) == matrix + solve
    n = 10
    assert gpu.estimate_gpu_memory(n, vectors=True) == 8 * n * n + 8 * (4 * n * n + 256 * n + 2**20) + 8 * 4 * n + 2**20


def test_memory_estimate_of_the_50000_dof_complex(no_cupy: None) -> None:
    """Issue 14: at 50,000 dofs syevd asks for about 80 GB of workspace beside the 20 GB matrix."""
    need = gpu.estimate_gpu_memory(50_000, vectors=True)
    assert 100e9 <= need <= 101e9
    with pytest.raises(ValueError, match=r"50000 dofs need 93\.\d GiB on the GPU .* but 78\.0 GiB is free"):
        gpu.check_gpu_memory(50_000, vectors=True, free=78 * 2**30)


class _NoAllocation:
    """Stands in for CuPy and fails the test on any use."""

    def __init__(self) -> None:
        self.used: list[str] = []

    def __getattr__(self, name: str) -> Any:
        self.used.append(name)
        raise AssertionError(f"cupy.{name} used before the memory check")


def test_refused_before_any_allocation(monkeypatch: pytest.MonkeyPatch) -> None:
    fake = _NoAllocation()
    monkeypatch.setattr(gpu, "require_gpu", lambda: fake)
    monkeypatch.setattr(gpu, "_syevd_workspace", lambda n, vectors: gpu.syevd_workspace_formula(n))
    monkeypatch.setattr(gpu, "_free_gpu_memory", lambda cupy: 64 * 2**20)
    K = np.eye(1200)
    with pytest.raises(ValueError, match=r"1200 dofs need 0\.\d GiB on the GPU.*0\.1 GiB is free; ask for n_modes"):
        gpu.dense_eigh_gpu(K, vectors=True)
    assert fake.used == []


def test_refusal_suggests_frequencies_only_when_they_fit(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(gpu, "estimate_gpu_memory", lambda n, vectors: (10 if vectors else 2) * 2**30)
    with pytest.raises(ValueError, match=r"need 10\.\d GiB .* 5\.0 GiB is free; .* or vectors=False"):
        gpu.check_gpu_memory(100, vectors=True, free=5 * 2**30)
    only_cpu = r"1\.0 GiB is free; ask for n_modes=\.\.\. \(a partial sparse solve on the CPU\), or use"
    with pytest.raises(ValueError, match=only_cpu):
        gpu.check_gpu_memory(100, vectors=True, free=2**30)


# ---------------------------------------------------------------------- numbers (GPU only)
@pytest.fixture(scope="module")
def network() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    K, mass = spring_network(240)  # 720 dofs: more than the 256 sampled columns
    return K, mass, weighted(K, mass)


@needs_gpu
def test_gpu_eigenvalues_match_lapack(network: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    _, _, Kt = network
    n = Kt.shape[0]
    result = gpu.dense_eigh_gpu(Kt, vectors=True)
    reference = la.eigh(Kt, eigvals_only=True, driver="evd")
    norm = float(np.abs(reference).max())
    assert result.solver == "gpu"
    assert np.all(np.diff(result.eigenvalues) >= 0)
    assert np.all(np.abs(result.eigenvalues - reference) <= result.error + n * EPS * norm)
    assert abs(result.eigenvalues.sum() - np.trace(Kt)) <= result.error.sum()  # trace invariant


@needs_gpu
def test_gpu_vectors_residuals_within_reported_error(network: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    _, _, Kt = network
    n = Kt.shape[0]
    result = gpu.dense_eigh_gpu(Kt, vectors=True)
    V = result.vectors
    assert V is not None and V.shape == (n, n)
    residuals = np.linalg.norm(Kt @ V - V * result.eigenvalues, axis=0)  # numpy, on the CPU
    assert np.all(residuals <= result.error)
    assert result.residual <= n * EPS
    gram = V.T @ V - np.eye(n)
    assert np.abs(gram).max() <= n * EPS
    assert result.orthogonality <= n * EPS


@needs_gpu
def test_gpu_free_network_has_six_rigid_modes(network: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    _, _, Kt = network
    result = gpu.dense_eigh_gpu(Kt, vectors=False)
    zero = np.abs(result.eigenvalues) <= result.error
    assert zero.sum() == 6 and zero[:6].all()  # 3 translations + 3 rotations
    assert result.vectors is None and np.isnan(result.residual)


@needs_gpu
def test_gpu_values_only_match_values_with_vectors(network: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    _, _, Kt = network
    values_only = gpu.dense_eigh_gpu(Kt, vectors=False)
    with_vectors = gpu.dense_eigh_gpu(Kt, vectors=True)
    assert np.all(np.abs(values_only.eigenvalues - with_vectors.eigenvalues)
                  <= values_only.error + with_vectors.error)


@needs_gpu
def test_solve_gpu_subsets_and_generalised_mass(network: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
    K, mass, Kt = network
    n = K.shape[0]
    reference = la.eigh(Kt, eigvals_only=True)
    lowest = gpu.solve_gpu(K, mass, n_modes=20, vectors=True, band=None)
    assert lowest.eigenvalues.shape == (20,) and lowest.vectors is not None and lowest.vectors.shape == (n, 20)
    assert np.all(np.abs(lowest.eigenvalues - reference[:20]) <= lowest.error + n * EPS * reference[-1])
    omega = np.sqrt(np.abs(reference))
    band = (0.5 * omega[-1], 0.6 * omega[-1])
    inside = gpu.solve_gpu(K, mass, n_modes=None, vectors=False, band=band)
    assert inside.eigenvalues.shape[0] == int(((omega >= band[0]) & (omega <= band[1])).sum())
    # A dense SPD mass matrix (generalised coordinates): scipy's generalised eigh is the truth.
    rng = np.random.default_rng(3)
    coupling = rng.uniform(-0.1, 0.1, (n, n))
    M = np.diag(mass) + 0.5 * (coupling @ coupling.T) / n
    general = gpu.solve_gpu(K, M, n_modes=None, vectors=False, band=None)
    truth = la.eigh(K, M, eigvals_only=True)
    assert np.all(np.abs(general.eigenvalues - truth) <= general.error + 10 * n * EPS * np.abs(truth).max())


@needs_gpu
def test_gpu_refuses_a_solve_larger_than_the_device() -> None:
    with pytest.raises(ValueError, match=r"all modes of 1000000 dofs need .* GiB on the GPU"):
        gpu.check_gpu_memory(1_000_000, vectors=True)


@needs_gpu
def test_gpu_estimate_uses_cusolver_query() -> None:
    """cuSOLVER's own workspace figure is within 1% of the documented bound."""
    n = 4000
    queried = gpu.estimate_gpu_memory(n, vectors=True)
    assert queried <= 8 * n * n + gpu.syevd_workspace_formula(n) + 8 * 4 * n + 2**20
    assert queried >= 0.99 * 5 * 8 * n * n


# ---------------------------------------------------------------------- normal_modes(device=...)
def test_normal_modes_rejects_an_unknown_device() -> None:
    K = np.array([[1.0, -1.0], [-1.0, 1.0]])
    with pytest.raises(ValueError, match=r"device is 'tpu'; expected one of 'cpu', 'gpu'"):
        vibra.normal_modes(K, [1.0, 1.0], device="tpu")
    with pytest.raises(TypeError, match=r"device must be a string"):
        vibra.normal_modes(K, [1.0, 1.0], device=1)


def test_normal_modes_on_the_gpu_runs_the_dense_and_iterative_paths_only() -> None:
    K = np.array([[1.0, -1.0], [-1.0, 1.0]])
    with pytest.raises(ValueError, match=r"device='gpu' runs the dense and the iterative paths only; solver is 'tridiagonal'"):
        vibra.normal_modes(K, [1.0, 1.0], device="gpu", solver="tridiagonal")


def test_normal_modes_and_system_modes_never_fall_back_to_the_cpu(no_cupy: None) -> None:
    chain = vibra.System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0)
    with pytest.raises(gpu.GPUUnavailableError, match=r'pip install "vibra\[gpu\]"'):
        vibra.normal_modes(chain.hessian(), chain.mass_matrix(), device="gpu")
    with pytest.raises(gpu.GPUUnavailableError, match=r'pip install "vibra\[gpu\]"'):
        chain.modes(device="cuda")


@needs_gpu
def test_system_modes_on_the_gpu_match_the_cpu_within_the_reported_bounds() -> None:
    """The same `Modes` from device="gpu" as from the CPU, within omega_error (truth: LAPACK)."""
    K, mass = spring_network(400)
    system = vibra.System.from_hessian(np.zeros((400, 3)), mass[::3], K, units="dimensionless")
    on_gpu = system.modes(device="gpu")
    on_cpu = system.modes(accuracy="fast")
    assert on_gpu.solver == "gpu" and on_gpu.n_modes == on_cpu.n_modes == 1200
    gap = np.abs(on_gpu.omega_squared - on_cpu.omega_squared)
    assert (gap <= on_gpu.omega_error * 2 * np.abs(on_gpu.omega) + 2 * 1200 * EPS * np.abs(on_cpu.omega_squared).max()).all()
    lowest = vibra.normal_modes(K, mass, n_modes=10, device="gpu")
    np.testing.assert_allclose(lowest.omega_squared, on_cpu.omega_squared[:10], atol=1e-10)
