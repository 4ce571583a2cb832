"""A numpy stand-in for CuPy (`cupy` and `cupyx.scipy.sparse`): the GPU paths' plumbing on any machine.

`install(monkeypatch)` puts it in ``sys.modules`` for one test. Its arrays (`DeviceArray`) wrap numpy
arrays and behave as CuPy's do where a host/device slip would fail on a real GPU: arithmetic or a product
between a device array and a host (numpy) array raises TypeError; so does any conversion to a host array
other than ``.get()`` or ``cupy.asnumpy`` (``np.asarray``, numpy's functions, a scipy sparse product, a
host array indexed by a device one: CuPy refuses implicit conversion); the module's functions take device
arrays only (``asarray`` uploads). Its sparse matrices (`DeviceCSR`) count their products by type and
return Fortran-ordered blocks, as cuSPARSE's SpMM through CuPy does. Only the names the GPU paths use are
given, so a name the code takes from the module that this stand-in lacks fails here too. It checks where
every step runs, not CuPy's arithmetic: the real device runs in the tests marked `needs_gpu`.
"""

from __future__ import annotations

import sys
import types
from collections import Counter
from typing import Any

import numpy as np
import scipy.sparse as sp

TOTAL_MEMORY = 80 * 2**30

#: Products of the stand-in's sparse matrices, by the matrix's type ("float32", "float64"), since `install`.
PRODUCTS: Counter[str] = Counter()


def _slip(what: str) -> TypeError:
    return TypeError(f"fake CuPy: {what} (a device array reaches the host only by .get())")


class DeviceArray:
    """An array "on the device": numpy's arithmetic, among device arrays and Python scalars only."""

    __array_priority__ = 1000.0  # (numpy defers its operators to ours, which refuse a host operand)

    def __init__(self, data: np.ndarray) -> None:
        self._data = data

    # what CuPy refuses
    def __array__(self, *args: Any, **kwargs: Any) -> np.ndarray:
        raise _slip("implicit conversion to a numpy array")

    def __array_ufunc__(self, *args: Any, **kwargs: Any) -> Any:
        raise _slip("a numpy function on a device array")

    def __array_function__(self, *args: Any, **kwargs: Any) -> Any:
        raise _slip("a numpy function on a device array")

    def __iter__(self) -> Any:
        raise _slip("iteration over a device array")

    # what it offers
    def get(self) -> np.ndarray:
        return np.array(self._data)

    shape = property(lambda self: self._data.shape)
    dtype = property(lambda self: self._data.dtype)
    ndim = property(lambda self: self._data.ndim)
    size = property(lambda self: self._data.size)
    T = property(lambda self: DeviceArray(self._data.T))
    flags = property(lambda self: self._data.flags)

    def astype(self, dtype: Any, copy: bool = True) -> DeviceArray:
        return DeviceArray(self._data.astype(dtype, copy=copy))

    def reshape(self, *shape: Any) -> DeviceArray:
        return DeviceArray(self._data.reshape(*shape))

    def ravel(self) -> DeviceArray:
        return DeviceArray(self._data.ravel())

    def copy(self) -> DeviceArray:
        return DeviceArray(self._data.copy())

    def max(self) -> DeviceArray:
        return DeviceArray(np.asarray(self._data.max()))

    def __float__(self) -> float:  # (CuPy: a 0-d array to a Python number, synchronising)
        if self._data.ndim:
            raise TypeError("only 0-d device arrays convert to a Python float")
        return float(self._data)

    def __getitem__(self, key: Any) -> DeviceArray:
        return DeviceArray(self._data[_inside(key)])

    def __setitem__(self, key: Any, value: Any) -> None:
        self._data[_inside(key)] = _operand(value)

    def __len__(self) -> int:
        return len(self._data)


def _operand(value: Any) -> Any:
    """A device array's data, a Python or numpy scalar as it is; a host array refused."""
    if isinstance(value, DeviceArray):
        return value._data
    if isinstance(value, np.ndarray) and value.ndim:
        raise _slip("a host array as an operand of a device array")
    if sp.issparse(value):
        raise _slip("a scipy sparse matrix as an operand of a device array")
    return value


def _inside(key: Any) -> Any:
    if isinstance(key, tuple):
        return tuple(_inside(part) for part in key)
    if isinstance(key, np.ndarray):
        raise _slip("a host array indexing a device array")
    return key._data if isinstance(key, DeviceArray) else key


def _binary(name: str) -> Any:
    operator = getattr(np.ndarray, name)

    def method(self: DeviceArray, other: Any) -> Any:
        result = operator(self._data, _operand(other))
        if result is NotImplemented:
            return result
        if name.startswith("__i"):
            return self
        return DeviceArray(np.asarray(result))
    return method


for _name in ("__add__", "__radd__", "__sub__", "__rsub__", "__mul__", "__rmul__", "__truediv__", "__rtruediv__",
              "__matmul__", "__rmatmul__", "__iadd__", "__isub__", "__imul__", "__itruediv__",
              "__lt__", "__le__", "__gt__", "__ge__"):
    setattr(DeviceArray, _name, _binary(_name))
DeviceArray.__neg__ = lambda self: DeviceArray(-self._data)  # type: ignore[attr-defined]


def _device_inputs(value: Any) -> Any:
    if isinstance(value, DeviceArray):
        return value._data
    if isinstance(value, (list, tuple)):
        return type(value)(_device_inputs(part) for part in value)
    if isinstance(value, np.ndarray) and value.ndim:
        raise _slip("a host array given to a CuPy function")
    return value


def _wrap(value: Any) -> Any:
    if isinstance(value, tuple):
        return tuple(_wrap(part) for part in value)
    if isinstance(value, (np.ndarray, np.generic)):
        return DeviceArray(np.asarray(value))
    return value


def _on_device(function: Any) -> Any:
    def wrapped(*args: Any, **kwargs: Any) -> Any:
        return _wrap(function(*_device_inputs(args), **{key: _device_inputs(value) for key, value in kwargs.items()}))
    return wrapped


def asarray(value: Any, dtype: Any = None) -> DeviceArray:
    """Upload (a copy of a host array; a device array as it is, cast where asked)."""
    if isinstance(value, DeviceArray):
        return value if dtype is None or value.dtype == dtype else value.astype(dtype)
    if sp.issparse(value):
        raise TypeError("fake CuPy: asarray of a scipy sparse matrix")
    return DeviceArray(np.array(value, dtype=dtype))


def asnumpy(value: Any) -> np.ndarray:
    return value.get() if isinstance(value, DeviceArray) else np.asarray(value)


class DeviceCSR:
    """`cupyx.scipy.sparse.csr_matrix`: built from a scipy matrix; its product takes device arrays of its own
    type only, is counted in `PRODUCTS`, and comes back Fortran-ordered."""

    def __init__(self, matrix: Any) -> None:
        self._matrix = sp.csr_matrix(matrix)
        self.shape, self.dtype, self.nnz = self._matrix.shape, self._matrix.dtype, self._matrix.nnz

    def __matmul__(self, other: Any) -> DeviceArray:
        if not isinstance(other, DeviceArray):
            raise _slip("a device sparse matrix times a host array")
        if other.dtype != self.dtype:  # (CuPy would copy the matrix to the common type on every product: a slip)
            raise TypeError(f"fake cupyx: a {self.dtype} sparse matrix times a {other.dtype} block")
        PRODUCTS[str(self.dtype)] += 1
        return DeviceArray(np.asfortranarray(self._matrix @ other._data))


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
    cupy.__version__ = "14.2.0"
    cupy.asarray = asarray
    cupy.asnumpy = asnumpy
    cupy.ndarray = DeviceArray
    for name in ("sqrt", "einsum", "concatenate", "abs"):
        setattr(cupy, name, _on_device(getattr(np, name)))
    cupy.zeros = lambda shape, dtype=float: DeviceArray(np.zeros(shape, dtype))
    cupy.linalg = types.SimpleNamespace(qr=_on_device(np.linalg.qr), norm=_on_device(np.linalg.norm))
    pool = _Pool()
    cupy.get_default_memory_pool = lambda: pool
    cupy.cuda = types.SimpleNamespace(runtime=types.SimpleNamespace(getDeviceCount=lambda: 1),
                                      Device=lambda *args: _Device(free))
    return cupy


def install(monkeypatch: Any, free: int = TOTAL_MEMORY) -> types.ModuleType:
    """The stand-in as `cupy` and `cupyx.scipy.sparse` in ``sys.modules`` for one test (`PRODUCTS` reset)."""
    PRODUCTS.clear()
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
