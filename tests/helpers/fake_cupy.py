"""A numpy stand-in for CuPy (`cupy` and `cupyx.scipy.sparse`): the GPU paths' plumbing on any machine.

`install(monkeypatch)` puts it in ``sys.modules`` for one test. Its arrays (`DeviceArray`) behave as CuPy's
do where a host/device slip would fail on a real GPU: an arithmetic operation or a product between a
device array and a host (numpy) array raises TypeError, as does any numpy function called on a device
array (CuPy's arrays refuse implicit conversion); a host copy comes only from ``.get()`` or
``cupy.asnumpy``. Only the names the GPU paths use are given, so a name the code takes from the module and
this stand-in lacks fails here too. It checks where every step runs, not CuPy's arithmetic: the real
device runs in the tests marked `needs_gpu`.
"""

from __future__ import annotations

import sys
import types
from typing import Any

import numpy as np
import scipy.sparse as sp

TOTAL_MEMORY = 80 * 2**30


class DeviceArray(np.ndarray):
    """An array "on the device": numpy's arithmetic among device arrays only."""

    def __array_ufunc__(self, ufunc: Any, method: str, *inputs: Any, **kwargs: Any) -> Any:
        for value in inputs + tuple(kwargs.get("out", ())):
            if isinstance(value, np.ndarray) and not isinstance(value, DeviceArray) and value.ndim:
                raise TypeError(f"fake CuPy: {ufunc.__name__} between a device array and a host array")
        host = [value.view(np.ndarray) if isinstance(value, DeviceArray) else value for value in inputs]
        if "out" in kwargs:
            kwargs["out"] = tuple(value.view(np.ndarray) for value in kwargs["out"])
        result = getattr(ufunc, method)(*host, **kwargs)
        return _device(result)

    def __array_function__(self, func: Any, types: Any, args: Any, kwargs: Any) -> Any:
        raise TypeError(f"fake CuPy: numpy's {func.__name__} on a device array (bring it to the host with .get())")

    def get(self) -> np.ndarray:
        return np.array(self.view(np.ndarray))


def _device(value: Any) -> Any:
    if isinstance(value, tuple):
        return tuple(_device(part) for part in value)
    if isinstance(value, np.ndarray) and not isinstance(value, DeviceArray):
        return value.view(DeviceArray)
    return value


def _host(value: Any) -> Any:
    if isinstance(value, DeviceArray):
        return value.view(np.ndarray)
    if isinstance(value, (list, tuple)):
        return type(value)(_host(part) for part in value)
    return value


def _on_device(function: Any) -> Any:
    def wrapped(*args: Any, **kwargs: Any) -> Any:
        return _device(function(*_host(args), **{key: _host(value) for key, value in kwargs.items()}))
    return wrapped


def asarray(value: Any, dtype: Any = None) -> DeviceArray:
    """Upload (a copy of a host array; a device array as it is, cast where asked)."""
    if isinstance(value, DeviceArray):
        return value if dtype is None or value.dtype == dtype else value.astype(dtype)
    if sp.issparse(value):
        raise TypeError("fake CuPy: asarray of a scipy sparse matrix")
    return np.array(value, dtype=dtype).view(DeviceArray)


class DeviceCSR:
    """`cupyx.scipy.sparse.csr_matrix`: built from a scipy matrix; its product takes device arrays only."""

    def __init__(self, matrix: Any) -> None:
        self._matrix = sp.csr_matrix(matrix)
        self.shape, self.dtype, self.nnz = self._matrix.shape, self._matrix.dtype, self._matrix.nnz

    def __matmul__(self, other: Any) -> DeviceArray:
        if not isinstance(other, DeviceArray):
            raise TypeError("fake cupyx: a device sparse matrix times a host array")
        if other.dtype != self.dtype:  # (cuSPARSE's products take one type: the path keeps them so)
            raise TypeError(f"fake cupyx: a {self.dtype} sparse matrix times a {other.dtype} block")
        return np.asarray(self._matrix @ other.view(np.ndarray)).view(DeviceArray)


class _Pool:
    def free_all_blocks(self) -> None:
        pass


class _Device:
    def __init__(self, free: int) -> None:
        self.id = 0
        self.mem_info = (free, TOTAL_MEMORY)


def module(free: int = TOTAL_MEMORY) -> types.ModuleType:
    """The stand-in `cupy` module, `free` bytes of device memory free."""
    cupy = types.ModuleType("cupy")
    cupy.__version__ = "fake"
    cupy.asarray = asarray
    cupy.asnumpy = lambda value: value.get() if isinstance(value, DeviceArray) else np.asarray(value)
    for name in ("zeros", "empty", "sqrt", "einsum", "concatenate", "abs", "arange"):
        setattr(cupy, name, _on_device(getattr(np, name)))
    cupy.linalg = types.SimpleNamespace(qr=_on_device(np.linalg.qr), norm=_on_device(np.linalg.norm))
    pool = _Pool()
    cupy.get_default_memory_pool = lambda: pool
    cupy.cuda = types.SimpleNamespace(runtime=types.SimpleNamespace(getDeviceCount=lambda: 1),
                                      Device=lambda *args: _Device(free))
    return cupy


def install(monkeypatch: Any, free: int = TOTAL_MEMORY) -> types.ModuleType:
    """The stand-in as `cupy` and `cupyx.scipy.sparse` in ``sys.modules`` for one test."""
    cupy = module(free)
    sparse = types.ModuleType("cupyx.scipy.sparse")
    sparse.csr_matrix = DeviceCSR
    scipy_part = types.ModuleType("cupyx.scipy")
    scipy_part.sparse = sparse
    cupyx = types.ModuleType("cupyx")
    cupyx.scipy = scipy_part
    for name, value in (("cupy", cupy), ("cupyx", cupyx), ("cupyx.scipy", scipy_part), ("cupyx.scipy.sparse", sparse)):
        monkeypatch.setitem(sys.modules, name, value)
    return cupy
