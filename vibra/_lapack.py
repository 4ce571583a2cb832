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

from vibra import _validate

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


def bidiagonal_svd(diagonal: ArrayLike, superdiagonal: ArrayLike, *, left: bool
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Singular values and one side's singular vectors of an upper bidiagonal matrix.

    LAPACK dbdsqr (implicit zero-shift QR): the values to high relative accuracy, the
    vectors to an angle error ~ eps / relative gap. O(n^3): meant for n up to a few hundred.

    Parameters
    ----------
    diagonal : (n,) array_like
    superdiagonal : (n - 1,) array_like
    left : bool
        True for the left singular vectors (columns of U), False for the right ones
        (columns of V, i.e. rows of V^T).

    Returns
    -------
    sigma : (n,) ndarray
        Ascending singular values.
    vectors : (n, n) ndarray
        Column k belongs to sigma[k].

    Raises
    ------
    ValueError
        d or e not finite, or e not of length n - 1.
    RuntimeError
        dbdsqr failed to converge (LAPACK info > 0).

    Examples
    --------
    >>> import numpy as np
    >>> sigma, vectors = bidiagonal_svd([1.0, 1.0], [1.0], left=True)
    >>> np.round(sigma, 8), np.round(np.abs(vectors[:, 1]), 8)
    (array([0.61803399, 1.61803399]), array([0.85065081, 0.52573111]))
    """
    d, e = _bidiagonal(diagonal, superdiagonal)
    n = d.shape[0]
    identity = np.asfortranarray(np.eye(n))
    unused = np.zeros((1, 1), order="F")
    vt, u = (unused, identity) if left else (identity, unused)
    work = np.empty(4 * n, dtype=np.float64)
    info = ctypes.c_int(0)
    dbdsqr = _routine("dbdsqr", ctypes.c_char_p, _INT_P, _INT_P, _INT_P, _INT_P, _DOUBLE_P, _DOUBLE_P,
                      _DOUBLE_P, _INT_P, _DOUBLE_P, _INT_P, _DOUBLE_P, _INT_P, _DOUBLE_P, _INT_P)

    def ref(value: int) -> Any:
        return ctypes.byref(ctypes.c_int(value))

    dbdsqr(b"U", ref(n), ref(0 if left else n), ref(n if left else 0), ref(0),
           d.ctypes.data_as(_DOUBLE_P), e.ctypes.data_as(_DOUBLE_P),
           vt.ctypes.data_as(_DOUBLE_P), ref(vt.shape[0]), u.ctypes.data_as(_DOUBLE_P), ref(u.shape[0]),
           unused.ctypes.data_as(_DOUBLE_P), ref(1), work.ctypes.data_as(_DOUBLE_P), ctypes.byref(info))
    if info.value != 0:
        raise RuntimeError(f"LAPACK dbdsqr failed with info={info.value}")
    vectors = u if left else vt.T
    order = np.argsort(d)
    return d[order], np.ascontiguousarray(vectors[:, order])
