"""LAPACK routines that scipy ships but does not wrap in `scipy.linalg.lapack`.

`dlasq1` (the dqds algorithm) computes the singular values of a bidiagonal matrix to high
relative accuracy, about 30 N^2 flops. scipy exports the routine through the C-API capsules
of `scipy.linalg.cython_lapack`; we call it with ctypes instead of compiling an extension.
This is the one place vibra binds LAPACK by hand: no installed Python package wraps dqds.
"""

from __future__ import annotations

import ctypes
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vibra._core import validate as _validate

_INT_P = ctypes.POINTER(ctypes.c_int)
_DOUBLE_P = ctypes.POINTER(ctypes.c_double)


def _bidiagonal(diagonal: ArrayLike, superdiagonal: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(d, e) as float64 arrays, e padded to length max(n, 1) as LAPACK's work space wants.

    LAPACK reads NaN and inf without complaint (dlasq1 even returns finite values), so they
    are refused here.
    """
    d = _validate.real_array(diagonal, "diagonal", ndim=1)
    given = _validate.real_array(superdiagonal, "superdiagonal", ndim=1)
    n = d.shape[0]
    if given.shape[0] != max(n - 1, 0):
        raise ValueError(f"superdiagonal must have {max(n - 1, 0)} entries for a {n} x {n} bidiagonal, "
                         f"got {given.shape[0]}")
    _validate.finite(d, "diagonal")
    _validate.finite(given, "superdiagonal")
    e = np.zeros(max(n, 1), dtype=np.float64)
    e[: n - 1] = given
    return np.array(d, dtype=np.float64, order="F"), e


@lru_cache(maxsize=None)
def _routine(name: str, *argtypes: Any) -> Any:
    from scipy.linalg import cython_lapack

    capsule = cython_lapack.__pyx_capi__[name]
    get_name = ctypes.pythonapi.PyCapsule_GetName
    get_name.restype = ctypes.c_char_p
    get_name.argtypes = [ctypes.py_object]
    get_pointer = ctypes.pythonapi.PyCapsule_GetPointer
    get_pointer.restype = ctypes.c_void_p
    get_pointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
    address = get_pointer(capsule, get_name(capsule))
    return ctypes.CFUNCTYPE(None, *argtypes)(address)


def bidiagonal_singular_values(diagonal: ArrayLike, superdiagonal: ArrayLike) -> NDArray[np.float64]:
    """Singular values of the n x n upper bidiagonal matrix, ascending, to high relative accuracy.

    Parameters
    ----------
    diagonal : (n,) array_like
        The diagonal d.
    superdiagonal : (n - 1,) array_like
        The superdiagonal e.

    Returns
    -------
    (n,) ndarray
        sigma_1 <= ... <= sigma_n (LAPACK dlasq1: each to a few ulps relative).

    Raises
    ------
    ValueError
        d or e not finite, or e not of length n - 1.
    RuntimeError
        dqds failed to converge (LAPACK info > 0).

    Examples
    --------
    >>> import numpy as np
    >>> bidiagonal_singular_values([1.0, 1.0], [1.0])  # [[1, 1], [0, 1]]: golden ratio and its inverse
    array([0.61803399, 1.61803399])
    """
    d, e = _bidiagonal(diagonal, superdiagonal)
    n = d.shape[0]
    if n == 0:
        return d
    work = np.empty(4 * n, dtype=np.float64)
    info = ctypes.c_int(0)
    dlasq1 = _routine("dlasq1", _INT_P, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, _INT_P)
    dlasq1(ctypes.byref(ctypes.c_int(n)), d.ctypes.data_as(_DOUBLE_P), e.ctypes.data_as(_DOUBLE_P),
           work.ctypes.data_as(_DOUBLE_P), ctypes.byref(info))
    if info.value != 0:
        raise RuntimeError(f"LAPACK dlasq1 (dqds) failed with info={info.value}")
    return np.sort(d)


def _ref(value: int) -> Any:
    return ctypes.byref(ctypes.c_int(value))


def tridiagonal_eigenvalues_by_index(diagonal: ArrayLike, offdiagonal: ArrayLike, first: int, last: int
                                     ) -> tuple[NDArray[np.float64], NDArray[np.intc], NDArray[np.intc]]:
    """Eigenvalues first..last (0-based, ascending) of a symmetric tridiagonal, by bisection.

    LAPACK dstebz with RANGE='I', ABSTOL = the safe minimum: each value to about two ulps of
    itself where the Sturm counts are relatively accurate (a zero diagonal, as in the
    Golub-Kahan form of a bidiagonal, Demmel-Kahan 1990). O(n (last - first + 1)) per bit.

    Returns
    -------
    values : (m,) ndarray, ascending, and LAPACK's block and split arrays (for `tridiagonal_vectors`).

    Raises
    ------
    ValueError
        Entries not finite, or the index range outside 0..n-1.
    RuntimeError
        Bisection failed (LAPACK info != 0).
    """
    d, e = _bidiagonal(diagonal, offdiagonal)
    n = d.shape[0]
    if not 0 <= first <= last < n:
        raise ValueError(f"eigenvalue indices must satisfy 0 <= first <= last < {n}, got {first}, {last}")
    values = np.zeros(n)
    block = np.zeros(n, dtype=np.intc)
    split = np.zeros(n, dtype=np.intc)
    work = np.empty(4 * n)
    iwork = np.empty(3 * n, dtype=np.intc)
    found = ctypes.c_int(0)
    n_split = ctypes.c_int(0)
    info = ctypes.c_int(0)
    dstebz = _routine("dstebz", ctypes.c_char_p, ctypes.c_char_p, _INT_P, _DOUBLE_P, _DOUBLE_P, _INT_P, _INT_P,
                      _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, _INT_P, _INT_P, _DOUBLE_P, _INT_P, _INT_P, _DOUBLE_P,
                      _INT_P, _INT_P)
    unused = ctypes.c_double(0.0)
    tolerance = ctypes.c_double(2.0 * float(np.finfo(float).tiny))
    int_p = ctypes.POINTER(ctypes.c_int)
    dstebz(b"I", b"B", _ref(n), ctypes.byref(unused), ctypes.byref(unused), _ref(first + 1), _ref(last + 1),
           ctypes.byref(tolerance), d.ctypes.data_as(_DOUBLE_P), e.ctypes.data_as(_DOUBLE_P),
           ctypes.byref(found), ctypes.byref(n_split), values.ctypes.data_as(_DOUBLE_P),
           block.ctypes.data_as(int_p), split.ctypes.data_as(int_p), work.ctypes.data_as(_DOUBLE_P),
           iwork.ctypes.data_as(int_p), ctypes.byref(info))
    if info.value != 0:
        raise RuntimeError(f"LAPACK dstebz (bisection) failed with info={info.value}")
    m = found.value
    return values[:m], block[:m], split[: n_split.value]


def tridiagonal_vectors(diagonal: ArrayLike, offdiagonal: ArrayLike, values: NDArray[np.float64],
                        block: NDArray[np.intc], split: NDArray[np.intc]) -> NDArray[np.float64]:
    """(n, m) eigenvectors of a symmetric tridiagonal for `values` from dstebz (LAPACK dstein).

    Inverse iteration, reorthogonalised inside clusters: angle errors ~ eps ||T|| / gap.
    """
    d, e = _bidiagonal(diagonal, offdiagonal)
    n = d.shape[0]
    m = values.shape[0]
    w = np.ascontiguousarray(values, dtype=np.float64)
    blocks = np.ascontiguousarray(block, dtype=np.intc)
    splits = np.zeros(n, dtype=np.intc)
    splits[: split.shape[0]] = split
    z = np.zeros((max(n, 1), max(m, 1)), order="F")
    work = np.empty(5 * n)
    iwork = np.empty(n, dtype=np.intc)
    failed = np.zeros(max(m, 1), dtype=np.intc)
    info = ctypes.c_int(0)
    int_p = ctypes.POINTER(ctypes.c_int)
    dstein = _routine("dstein", _INT_P, _DOUBLE_P, _DOUBLE_P, _INT_P, _DOUBLE_P, _INT_P, _INT_P, _DOUBLE_P,
                      _INT_P, _DOUBLE_P, _INT_P, _INT_P, _INT_P)
    dstein(_ref(n), d.ctypes.data_as(_DOUBLE_P), e.ctypes.data_as(_DOUBLE_P), _ref(m), w.ctypes.data_as(_DOUBLE_P),
           blocks.ctypes.data_as(int_p), splits.ctypes.data_as(int_p), z.ctypes.data_as(_DOUBLE_P),
           _ref(z.shape[0]), work.ctypes.data_as(_DOUBLE_P), iwork.ctypes.data_as(int_p),
           failed.ctypes.data_as(int_p), ctypes.byref(info))
    if info.value < 0:
        raise RuntimeError(f"LAPACK dstein failed with info={info.value}")
    return np.ascontiguousarray(z[:n, :m])


def bidiagonal_triplets(diagonal: ArrayLike, superdiagonal: ArrayLike
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Singular values and both sides' singular vectors of an upper bidiagonal (LAPACK dbdsqr).

    Returns (sigma, left, right), sigma ascending, B right[:, k] = sigma[k] left[:, k]. O(n^3):
    meant for n up to a few hundred.

    Examples
    --------
    >>> import numpy as np
    >>> sigma, left, right = bidiagonal_triplets([1.0, 1.0], [1.0])
    >>> B = np.array([[1.0, 1.0], [0.0, 1.0]])
    >>> bool(np.allclose(B @ right, left * sigma))
    True
    """
    d, e = _bidiagonal(diagonal, superdiagonal)
    n = d.shape[0]
    vt = np.asfortranarray(np.eye(n))
    u = np.asfortranarray(np.eye(n))
    unused = np.zeros((1, 1), order="F")
    work = np.empty(4 * max(n, 1), dtype=np.float64)
    info = ctypes.c_int(0)
    dbdsqr = _routine("dbdsqr", ctypes.c_char_p, _INT_P, _INT_P, _INT_P, _INT_P, _DOUBLE_P, _DOUBLE_P,
                      _DOUBLE_P, _INT_P, _DOUBLE_P, _INT_P, _DOUBLE_P, _INT_P, _DOUBLE_P, _INT_P)
    dbdsqr(b"U", _ref(n), _ref(n), _ref(n), _ref(0), d.ctypes.data_as(_DOUBLE_P), e.ctypes.data_as(_DOUBLE_P),
           vt.ctypes.data_as(_DOUBLE_P), _ref(max(n, 1)), u.ctypes.data_as(_DOUBLE_P), _ref(max(n, 1)),
           unused.ctypes.data_as(_DOUBLE_P), _ref(1), work.ctypes.data_as(_DOUBLE_P), ctypes.byref(info))
    if info.value != 0:
        raise RuntimeError(f"LAPACK dbdsqr failed with info={info.value}")
    order = np.argsort(d)
    return d[order], np.ascontiguousarray(u[:, order]), np.ascontiguousarray(vt.T[:, order])
