"""The optional GPU paths (`device="gpu"`): all modes of a dense K~ with cuSOLVER through CuPy; and, for the
iterative path on the GPU (`iterative.lowest_modes(device="gpu")`, the registry's `iterative-gpu`), its memory
check (`iterative_gpu_memory`) and its CSR upload (`device_csr`).

Install with ``pip install "vibra[gpu]"`` (CuPy for the CUDA of the machine). ``import vibra``
never imports CuPy: it is imported by the functions here, when a GPU solve is asked for.
Without CuPy or without a GPU the request fails with `GPUUnavailableError`, which names the
extra; there is no silent fallback to the CPU.

The solve is cuSOLVER's divide-and-conquer ``syevd`` (64-bit API ``cusolverDnXsyevd``, the
routine behind ``cupy.linalg.eigh``), called in place on the uploaded K~ so that the matrix is
held once rather than twice. Its device workspace is about 4 n^2 doubles, with or without
vectors, so the whole solve needs about 5 n^2 doubles: 30,000 dofs take 34 GiB, 50,000 dofs
93 GiB. The need is computed before anything is allocated (the workspace is queried from
cuSOLVER, which allocates nothing), and a solve that does not fit in the free GPU memory is
refused with both figures.

Accuracy is that of the CPU's dense path: syevd is backward stable, so each eigenvalue is
exact for K~ + E with ||E|| ~ eps ||K~||; the reported error of each eigenvalue is
n eps ||K~||, raised to the measured residual ||K~ d - lambda d|| for the sampled columns
(the lowest modes and an even spread, `vibra.solvers.SAMPLE` in all, as on the CPU).
Residuals and the orthogonality figure are computed on the GPU.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from vibra.solvers.common import SAMPLE, Matrix, SolveResult, mass_weighted
from vibra.solvers.common import sample_columns, selected

__all__ = [
    "DEVICES",
    "GPU_EXTRA",
    "GPUUnavailableError",
    "check_device",
    "check_gpu_memory",
    "check_iterative_memory",
    "dense_eigh_gpu",
    "device_csr",
    "estimate_gpu_memory",
    "gpu_available",
    "iterative_gpu_memory",
    "solve_gpu",
]

#: Values accepted by ``device=``; "cuda" is accepted as another name for "gpu".
DEVICES = ("cpu", "gpu")
_ALIASES = {"cuda": "gpu"}
#: What to install for the GPU path.
GPU_EXTRA = 'pip install "vibra[gpu]"'
#: Device memory kept free beyond the estimate (cuSOLVER's own small allocations, the
#: CuPy pool's rounding), in bytes.
GPU_RESERVE = 256 * 2**20

_EPS = float(np.finfo(np.float64).eps)
_DOUBLE = 8
# cudaDataType CUDA_R_64F and cuSOLVER / cuBLAS enum values (stable parts of the CUDA API).
_CUDA_R_64F = 1
_FILL_LOWER = 0
_EIG_NOVECTOR, _EIG_VECTOR = 0, 1


class GPUUnavailableError(ImportError, RuntimeError):
    """The GPU path was asked for, but CuPy is missing or sees no GPU (the message says which).

    An `ImportError` (an optional extra is missing) and a `RuntimeError` (a valid request that
    cannot run here): either ``except`` clause catches it.
    """


# ---------------------------------------------------------------------- device selection
def check_device(device: object) -> Literal["cpu", "gpu"]:
    """Validate ``device=``: "cpu", "gpu" (or its alias "cuda"), returned as "cpu" or "gpu".

    Raises
    ------
    TypeError
        `device` is not a string.
    ValueError
        `device` is not one of the accepted names.
    """
    if not isinstance(device, str):
        raise TypeError(f"device must be a string, one of 'cpu', 'gpu'; got {type(device).__name__} {device!r}")
    name = _ALIASES.get(device, device)
    if name == "cpu":
        return "cpu"
    if name == "gpu":
        return "gpu"
    raise ValueError(f"device is {device!r}; expected one of 'cpu', 'gpu' ('cuda' is accepted for 'gpu')")


def _import_cupy() -> Any:
    """CuPy, or GPUUnavailableError naming the extra."""
    try:
        import cupy  # type: ignore[import-not-found, unused-ignore]
    except ImportError as error:  # also a broken install: CuPy built for another CUDA
        raise GPUUnavailableError(
            f"device='gpu' needs CuPy, which is not importable here ({error}); install the GPU "
            f"extra with {GPU_EXTRA}, or use device='cpu'"
        ) from error
    return cupy


def require_gpu() -> ModuleType:
    """The CuPy module, once it is known to see a CUDA device; else GPUUnavailableError."""
    cupy = _import_cupy()
    try:
        count = int(cupy.cuda.runtime.getDeviceCount())
    except Exception as error:  # CUDARuntimeError: no driver, no device
        raise GPUUnavailableError(
            f"device='gpu': CuPy {cupy.__version__} finds no usable GPU ({error}); the GPU extra "
            f"({GPU_EXTRA}) needs an NVIDIA GPU and driver; use device='cpu' here"
        ) from error
    if count < 1:
        raise GPUUnavailableError(
            f"device='gpu': CuPy {cupy.__version__} sees no GPU; use device='cpu' here"
        )
    return cupy


def gpu_available() -> tuple[bool, str]:
    """(True, a description of the GPU) when the GPU path can run here; else (False, why not)."""
    try:
        cupy = require_gpu()
        properties = cupy.cuda.runtime.getDeviceProperties(cupy.cuda.Device().id)
        free, total = cupy.cuda.Device().mem_info
    except GPUUnavailableError as error:
        return False, str(error)
    except Exception as error:  # a device that fails when it is first used
        return False, f"device='gpu': the GPU does not answer ({error})"
    name = properties["name"]
    name = name.decode() if isinstance(name, bytes) else str(name)
    return True, f"{name}, {free / 2**30:.1f} of {total / 2**30:.1f} GiB free, CuPy {cupy.__version__}"


# ---------------------------------------------------------------------- memory
def syevd_workspace_formula(n: int) -> int:
    """Device workspace of cuSOLVER's double syevd for an n x n matrix, in bytes (an upper bound).

    cuSOLVER asks for 4 n^2 + 128 to 160 n doubles, with or without vectors (queried on an
    H100 with CUDA 13.0 for n = 1,000 to 50,000); this bound, 4 n^2 + 256 n + 2^20 doubles,
    serves where it cannot be queried (no CuPy or no GPU).
    """
    return _DOUBLE * (4 * n * n + 256 * n + 2**20)


def _syevd_workspace(n: int, vectors: bool) -> int:
    """cuSOLVER's own figure for the device workspace of Xsyevd, in bytes (no allocation)."""
    try:
        cupy = require_gpu()
        from cupy_backends.cuda.libs import cusolver  # type: ignore[import-not-found, unused-ignore]

        handle = cupy.cuda.device.get_cusolver_handle()
        params = cusolver.createParams()
        try:
            device_bytes, _ = cusolver.xsyevd_bufferSize(
                handle, params, _EIG_VECTOR if vectors else _EIG_NOVECTOR, _FILL_LOWER, n, _CUDA_R_64F, 0, n,
                _CUDA_R_64F, 0, _CUDA_R_64F)
        finally:
            cusolver.destroyParams(params)
        return int(device_bytes)
    except Exception:  # no CuPy / GPU, or a CuPy without the 64-bit API: the documented bound
        return syevd_workspace_formula(n)


def _memory_parts(n: int, vectors: bool, workspace: int) -> dict[str, int]:
    matrix = _DOUBLE * n * n  # K~, overwritten in place by the vectors
    small = _DOUBLE * 4 * n + 2**20  # eigenvalues, info, scratch
    # After the solve the workspace is released; with vectors, K~ is uploaded again for the
    # residuals next to D, with four (n, SAMPLE) blocks.
    figures = _DOUBLE * (n * n + 4 * n * min(n, SAMPLE)) if vectors else 0
    return {"matrix": matrix, "solve": workspace + small, "figures": figures}


def estimate_gpu_memory(n: int, *, vectors: bool) -> int:
    """Peak device memory of `dense_eigh_gpu` on an n x n K~, in bytes, before any allocation.

    The matrix (n^2 doubles, held once: the solve overwrites it with the vectors), plus the
    larger of cuSOLVER's syevd workspace (queried from cuSOLVER where CuPy sees a GPU, else
    `syevd_workspace_formula`) and, with vectors, a second copy of K~ for the residuals.
    """
    parts = _memory_parts(int(n), vectors, _syevd_workspace(int(n), vectors))
    return parts["matrix"] + max(parts["solve"], parts["figures"])


def _free_gpu_memory(cupy: Any) -> int:
    """Bytes the next allocations can take: the device's free memory once CuPy's pool has given
    back its cached blocks (a cached block that is partly in use stays held, and counts as used)."""
    cupy.get_default_memory_pool().free_all_blocks()
    free, _ = cupy.cuda.Device().mem_info
    return int(free)


def _gib(n_bytes: float) -> str:
    return f"{n_bytes / 2**30:.1f} GiB"


def check_gpu_memory(n: int, *, vectors: bool, free: int | None = None) -> int:
    """Raise ValueError with the figures when the solve of an n x n K~ would not fit; else its need.

    Parameters
    ----------
    n : int
        Number of dofs.
    vectors : bool
        Whether mode shapes are asked for.
    free : int, optional
        Free device memory, in bytes (default: what the current GPU reports).

    Returns
    -------
    int
        The estimate of `estimate_gpu_memory`, in bytes.
    """
    needed = estimate_gpu_memory(n, vectors=vectors)
    if free is None:
        free = _free_gpu_memory(require_gpu())
    if needed + GPU_RESERVE > free:
        hint = "ask for n_modes=... (a partial sparse solve on the CPU)"
        if vectors and estimate_gpu_memory(n, vectors=False) + GPU_RESERVE <= free:
            hint += " or vectors=False (frequencies only fit)"
        raise ValueError(
            f"device='gpu': all modes of {n} dofs need {_gib(needed + GPU_RESERVE)} on the GPU "
            f"(K~ {_gib(_DOUBLE * n * n)} and cuSOLVER's syevd workspace), but {_gib(free)} is free; "
            f"{hint}, or use a GPU with more memory"
        )
    return needed


def iterative_gpu_memory(n: int, nnz: int, columns: int) -> int:
    """Peak device memory of the iterative path on the GPU (`iterative.lowest_modes`, ``device="gpu"``), in
    bytes: K~ in double CSR (12 nnz + 4 n), the multigrid's levels in single precision (the fine level's
    8 nnz bytes, a third more for the coarse levels, the prolongators and block-Jacobi inverses, ~200 n),
    and LOBPCG's blocks (X, AX, P, R, W, [W, P], Q, AQ, the cycle's temporaries and the Fortran-ordered copy
    CuPy makes of each block a sparse product takes: 16 n b doubles, b = `columns`; 10.3-10.7 n b counted on
    the numpy stand-in at 3,000-10^4 dofs, where that copy is not made: one block more), as
    `iterative.iterative_cost` counts them on the host."""
    return int(12 * nnz + 4 * n + 1.34 * 8 * nnz + 200 * n + 8 * 16 * n * columns)


def check_iterative_memory(n: int, nnz: int, columns: int, *, free: int | None = None) -> int:
    """Raise ValueError with the figures when the iterative path's blocks and matrices would not fit on the
    GPU (`iterative_gpu_memory`); else the need, in bytes."""
    needed = iterative_gpu_memory(n, nnz, columns)
    if free is None:
        cupy = require_gpu()
        _check_indices(cupy, nnz)
        free = _free_gpu_memory(cupy)
    if needed + GPU_RESERVE > free:
        raise ValueError(
            f"device='gpu': the lowest modes of {n} dofs by the iterative path need {_gib(needed + GPU_RESERVE)} "
            f"on the GPU (K~ of {nnz} entries, its multigrid, LOBPCG's block of {columns} columns), but "
            f"{_gib(free)} is free; ask for fewer modes, or use device='cpu'"
        )
    return needed


def device_csr(matrix: Any) -> Any:
    """A scipy sparse matrix as CuPy's CSR on the GPU (`cupyx.scipy.sparse`: cuSPARSE products; CuPy works out
    once, on the device, whether it is canonical). CuPy before 14.1 uploads the index arrays as 32-bit
    integers: a matrix of 2^31 entries or more is refused there (`check_iterative_memory` says so first)."""
    import scipy.sparse as sp
    from cupyx.scipy import sparse as device_sparse  # type: ignore[import-not-found, unused-ignore]

    host = sp.csr_matrix(matrix)
    _check_indices(require_gpu(), host.nnz)
    return device_sparse.csr_matrix(host)


def _check_indices(cupy: Any, nnz: int) -> None:
    """ValueError where CuPy would wrap K~'s 64-bit row pointers into 32 bits (before CuPy 14.1)."""
    try:
        version = tuple(int(part) for part in str(cupy.__version__).split(".")[:2])
    except ValueError:  # (a development build: its indices are taken as they come)
        return
    if nnz >= 2**31 and version < (14, 1):
        raise ValueError(f"device='gpu': K~ has {nnz} stored entries, and CuPy {cupy.__version__} indexes a sparse "
                         "matrix with 32-bit integers (2^31 entries at most) before version 14.1; upgrade CuPy "
                         "(pip install -U cupy-cuda13x) or use device='cpu'")


# ---------------------------------------------------------------------- solve
def dense_eigh_gpu(Kt: NDArray[np.float64], *, vectors: bool = True) -> SolveResult:
    """All eigenpairs of the dense symmetric K~ on the GPU (cuSOLVER syevd), with error figures.

    Parameters
    ----------
    Kt : (n, n) ndarray
        The mass-weighted, symmetric K~ (only its lower triangle is read), in
        (rad per time unit)^2.
    vectors : bool
        False computes the eigenvalues only.

    Returns
    -------
    SolveResult
        Eigenvalues ascending; mass-weighted vectors (an (n, n) Fortran-ordered ndarray) or
        None; each eigenvalue's absolute error estimate; the largest relative residual and
        the orthogonality error of the sampled columns (NaN without vectors); solver "gpu".

    Raises
    ------
    GPUUnavailableError
        CuPy is not installed, or sees no GPU.
    ValueError
        The solve would not fit in the GPU's free memory (checked before any allocation).
    RuntimeError
        cuSOLVER reports a failure, or the GPU runs out of memory all the same.
    """
    cupy = require_gpu()
    matrix = np.ascontiguousarray(Kt, dtype=np.float64)
    n = matrix.shape[0]
    needed = check_gpu_memory(n, vectors=vectors)
    try:
        values, basis, figures = _solve_on_device(cupy, matrix, vectors)
    except cupy.cuda.memory.OutOfMemoryError as exhausted:
        raise RuntimeError(
            f"device='gpu': the GPU ran out of memory for {n} dofs although {_gib(needed)} was "
            f"estimated and found free (another process?): {exhausted}"
        ) from exhausted
    finally:
        cupy.get_default_memory_pool().free_all_blocks()
    # The eigenvalues are exact for K~ + E, ||E|| ~ n eps ||K~||; ||K~|| is bounded below by
    # the largest |eigenvalue| and |diagonal entry| (Rayleigh quotients).
    norm = max(float(np.abs(np.diagonal(matrix)).max(initial=0.0)), float(np.abs(values).max(initial=0.0)))
    norm = norm if norm > 0 else 1.0
    error = np.full(values.shape, n * _EPS * norm)
    if basis is None:
        return SolveResult(values, None, error, float("nan"), float("nan"), "gpu")
    columns, residuals, orthogonality = figures
    error[columns] = np.maximum(error[columns], residuals)
    return SolveResult(values, basis, error, float(residuals.max(initial=0.0) / norm), orthogonality, "gpu")


def _solve_on_device(cupy: Any, matrix: NDArray[np.float64], vectors: bool
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, Any]:
    """Upload K~, run Xsyevd in place, measure the figures; numpy arrays back."""
    from cupy_backends.cuda.libs import cusolver  # type: ignore[import-not-found, unused-ignore]

    n = matrix.shape[0]
    jobz = _EIG_VECTOR if vectors else _EIG_NOVECTOR
    # K~ is symmetric, so its C-ordered buffer is also its column-major (cuSOLVER) form.
    work_matrix = cupy.asarray(matrix)
    eigenvalues = cupy.empty(n, dtype=cupy.float64)
    info = cupy.zeros((), dtype=cupy.int32)
    handle = cupy.cuda.device.get_cusolver_handle()
    params = cusolver.createParams()
    try:
        device_bytes, host_bytes = cusolver.xsyevd_bufferSize(
            handle, params, jobz, _FILL_LOWER, n, _CUDA_R_64F, work_matrix.data.ptr, n,
            _CUDA_R_64F, eigenvalues.data.ptr, _CUDA_R_64F)
        device_work = cupy.empty(max(int(device_bytes), 1), dtype=cupy.uint8)
        host_work = np.empty(max(int(host_bytes), 1), dtype=np.uint8)
        cusolver.xsyevd(
            handle, params, jobz, _FILL_LOWER, n, _CUDA_R_64F, work_matrix.data.ptr, n,
            _CUDA_R_64F, eigenvalues.data.ptr, _CUDA_R_64F, device_work.data.ptr, int(device_bytes),
            host_work.ctypes.data, int(host_bytes), info.data.ptr)
        status = int(info.get())
    finally:
        cusolver.destroyParams(params)
    del device_work
    cupy.get_default_memory_pool().free_all_blocks()
    if status != 0:
        raise RuntimeError(f"cuSOLVER syevd failed on {n} dofs (info={status}: "
                           + ("did not converge)" if status > 0 else "bad argument)"))
    values = cupy.asnumpy(eigenvalues)
    if not vectors:
        return values, None, None
    basis_device = work_matrix.T  # column k (Fortran order) is the eigenvector of values[k]
    columns = sample_columns(n)  # as the CPU paths: the lowest modes and an even spread
    kt_device = cupy.asarray(matrix)
    sample = basis_device[:, cupy.asarray(columns)]
    residual_block = kt_device @ sample - sample * eigenvalues[cupy.asarray(columns)][None, :]
    residuals = cupy.asnumpy(cupy.linalg.norm(residual_block, axis=0))
    del kt_device, residual_block
    gram = basis_device.T @ sample
    gram[cupy.asarray(columns), cupy.arange(columns.shape[0])] -= 1.0
    orthogonality = float(cupy.abs(gram).max()) if gram.size else 0.0
    del gram, sample
    basis = cupy.asnumpy(work_matrix).T  # Fortran-ordered view, no copy
    return values, basis, (columns, residuals, orthogonality)


def solve_gpu(K: Matrix, mass: NDArray[np.float64], *, n_modes: int | None, vectors: bool,
              band: tuple[float, float] | None) -> SolveResult:
    """`vibra.solvers.solve` for ``device="gpu"``: weight K by the masses, solve all modes on the
    GPU, keep the lowest `n_modes` or those with omega in `band` (signed, rad per time unit).

    K (n, n) ndarray or sparse, and `mass` ((n,) or (n, n)), are validated by the caller. The GPU
    and its free memory are checked before K~ is formed densely on the host.
    """
    check_gpu_memory(K.shape[0], vectors=vectors)
    weighted = mass_weighted(K, mass)
    dense = weighted.toarray() if hasattr(weighted, "toarray") else np.asarray(weighted)
    result = dense_eigh_gpu(dense, vectors=vectors)
    if n_modes is None and band is None:
        return result
    omega = np.sign(result.eigenvalues) * np.sqrt(np.abs(result.eigenvalues))
    keep = selected(omega, n_modes=n_modes, band=band)
    # The figures keep those of all modes: each is a bound for the kept ones too.
    kept = None if result.vectors is None else np.array(result.vectors[:, keep])  # not a view of all n
    return SolveResult(result.eigenvalues[keep], kept,
                       result.error[keep], result.residual, result.orthogonality, result.solver)
