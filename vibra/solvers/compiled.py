"""Compiled kernels (numba), loaded on their first call: ``import vibra`` imports no numba.

One mechanism for every kernel module (`accurate/count_kernels.py`, `accurate/ring/pencil_counts.py`,
`accurate/gk_bisection.py`, `accurate/chain/triplets.py`, `accurate/products.py`,
`standard/cholmod.py`, `standard/rows.py`): each decorates its loops with `jit` (numba.njit's options) instead of
numba's own decorator and takes `prange`, `intrinsic` and `HOST_FMA` from here. A decorated
function is a `Kernel`, a plain Python object, until it is first called; a kernel declared
``aot=True`` then runs its ahead-of-time copy where one is built and matches the arguments
(`vibra.solvers.aot`: no numba loaded); otherwise numba is imported,
the kernel and every kernel, `prange`, intrinsic and `HOST_FMA` its module names are handed to
numba, and the module's names are bound to numba's dispatchers (`bind`), so that later calls go
straight to numba. What runs is numba's compiled code and on-disk cache (``cache=True``),
unchanged: the same bits as with ``numba.njit`` at import.

Which steps run a kernel is decided in one place too, `compiled_pays`: loading numba and a
kernel's cache costs a process ~0.5 s the first time (`LOAD_SECONDS`), ~3 s on a cold disk, so a
step whose numpy / LAPACK / scipy counterpart is estimated (from sizes, never the clock) under
`COMPILED_FROM_S` takes the counterpart, on every call of every process: the same input gives the
same result whatever ran before. Each step states its counterpart's rate and what its results
share with the kernel's (the same bits, or the same accuracy bound):

- a chain's lowest modes (`gk_bisection.golub_kahan_lowest`): LAPACK dstebz
  (`gk_bisection.DSTEBZ_S`), each value to two ulps as the kernel's;
- a chain's certificates, values only (`chain.bidiagonal.certified_values`): inverse iteration
  and `certify_modes` in numpy (`bidiagonal.NUMPY_CERTIFY_S`), bounds as tight;
- B~ V for the spring-space Ritz step (`products.times`): scipy's product
  (`products.SCIPY_PRODUCT_S`), the same bits;
- B~ V in extended precision (`spring_ritz._error_free_product`): its numpy loop in long double
  (`spring_ritz.NUMPY_PRODUCT_S`), each entry within one unit as the kernel's.
- a 3-D network's products with a block on the iterative path (`rows.products`, its estimate
  `iterative.iterative_cost`): scipy's product on row slabs (`rows.RowSlabs`), each entry within
  the dot product's rounding bound of the kernel's.

The other kernels have no counterpart that costs less than loading numba (a ring's roots and
counts, a chain's Sturm counts, the double-double Rayleigh quotients, a sparse factor's fill):
their paths load numba on their first call, except where the kernel is declared ``aot=True``
(a chain's Sturm counts and triplet figures, a ring's pencil counts) and its copy is built.

**A child forked after numba loaded** (`forked_with_numba`). GNU OpenMP, numba's threading layer
where libgomp is found, terminates a process forked from one that ran a parallel region as soon as
the child starts one (``multiprocessing``'s default start method on Linux forks). In such a child
every parallel kernel is recompiled without threads on its first call, outside the on-disk cache
(whose index does not tell a serial build from a parallel one), and its module's name rebound to it
(`Kernel.serial_after_fork`): the same loop, one thread, a compile of a second or so per kernel and
child instead of a terminated child; a kernel built ahead of time runs its (serial) copy there.

**Ctrl-C between calls** (issue 44). A compiled loop never returns to the interpreter, which
sees a SIGINT only when it does; so a kernel over many independent values (a chain's bisection,
its certificates, a ring's roots) is called on `batches` of them, each estimated (from sizes) to
take about `INTERRUPT_S`, and Ctrl-C stops the solve within about a second. Each value is
computed alone, so the batches give the same bits as one call.
"""

from __future__ import annotations

import functools
import importlib
import os
import sys
import threading
from types import ModuleType
from typing import Any, Callable, Generic, ParamSpec, TypeVar, cast

__all__ = ["Kernel", "AOT_KERNELS", "jit", "intrinsic", "prange", "HOST_FMA", "bind", "threads", "compiled_pays",
           "COMPILED_FROM_S", "LOAD_SECONDS", "batches", "INTERRUPT_S", "SITE_SECONDS", "forked_with_numba"]

#: Seconds a process spends the first time it runs a compiled kernel: importing numba and loading
#: its typing context and the kernel's on-disk cache. 0.44-0.59 s measured on the 2 shared cores
#: of the development machine (benchmarks/bench_startup.py, results/startup.json: "compiled
#: kernel: first", a 3-site kernel), 3.2 s in issue 45's profile (a cold disk). Compiling a kernel
#: not yet in the cache takes seconds more, once per machine and version of its module.
LOAD_SECONDS = 0.5

#: A step takes its compiled kernel where its numpy / LAPACK / scipy counterpart is estimated to
#: take at least this long (seconds, from sizes). Below it, the first call of a process is faster
#: without numba (by ~`LOAD_SECONDS`) and a later call slower by less than this; from it on, the
#: kernel (2-10x faster than the counterpart) saves more on each later call than this. A chain of
#: 2,000 sites, its lowest 10 modes: ~0.05 s by LAPACK bisection, no numba (issue 45).
COMPILED_FROM_S = 0.1


#: Seconds of work one compiled call over many values is given (`batches`): Ctrl-C is seen
#: between calls, so this bounds how long it waits.
INTERRUPT_S = 1.0

#: Seconds per site of one pass of a compiled loop over a chain or ring for one value (a Sturm
#: count, an evaluation of l(x), a sweep of a triplet's recurrences), per thread: ~2 ns measured
#: (a 10^6-site chain's count in ~2 ms). Only sizes `batches`: a factor of 2 off moves the
#: interval between chances to stop from 1 s to 0.5 or 2 s.
SITE_SECONDS = 2e-9


def batches(k: int, seconds_per_value: float, multiple: int = 1) -> list[tuple[int, int]]:
    """[start, stop) ranges covering 0..k, each estimated to take about `INTERRUPT_S` (from
    `seconds_per_value`, from sizes), in whole multiples of `multiple` values (a kernel's lanes
    times its threads) so that each call keeps every thread busy.

    >>> batches(10, 0.3), batches(10, 0.0)
    ([(0, 3), (3, 6), (6, 9), (9, 10)], [(0, 10)])
    """
    if k <= 0:
        return []
    multiple = max(1, int(multiple))
    if seconds_per_value <= 0:
        return [(0, k)]
    size = max(multiple, int(INTERRUPT_S / seconds_per_value) // multiple * multiple)
    return [(start, min(k, start + size)) for start in range(0, k, size)]


def compiled_pays(counterpart_seconds: float) -> bool:
    """Whether a step runs its compiled kernel rather than its counterpart, estimated (from sizes)
    to take `counterpart_seconds`: from `COMPILED_FROM_S` on."""
    return counterpart_seconds >= COMPILED_FROM_S


#: A kernel's parameters and its result (`Kernel`): those of the Python function it compiles.
_P = ParamSpec("_P")
_R = TypeVar("_R")

_LOCK = threading.RLock()
_BOUND: set[int] = set()  # the module namespaces already bound to numba's objects


def _numba() -> ModuleType:
    return importlib.import_module("numba")  # here only: the first kernel call loads numba


class _Lazy:
    """Something a kernel's module names that numba must see as its own object (`bind`)."""

    def resolve(self) -> object:
        raise NotImplementedError


class Kernel(_Lazy, Generic[_P, _R]):
    """A function numba compiles on its first call (`jit`); calling it calls numba's dispatcher."""

    def __init__(self, function: Callable[_P, _R], options: dict[str, object]) -> None:
        self.py_func = function
        self.aot = bool(options.pop("aot", False))
        self.work = cast("Callable[..., float] | None", options.pop("work", None))
        self.parallel = bool(options.get("parallel", False))
        self.options = options
        self._dispatcher: Any = None
        self._exports: list[tuple[Any, Callable[..., Any]]] | None = None
        self._rebind: list[tuple[dict[str, object], str]] = []  # (the names a forked child points back here)
        functools.update_wrapper(self, function)
        if self.aot:
            AOT_KERNELS.append(self)
        if self.parallel:
            _PARALLEL.append(self)
            if _FORKED_WITH_NUMBA:  # (a module first imported in such a child)
                self.serial_after_fork()

    def serial_after_fork(self) -> None:
        """In a child forked from a process that had loaded numba: compile this kernel without
        threads and without the on-disk cache on its next call. The names bound to its parallel
        dispatcher (in the kernel modules loaded) point back to this kernel until then, and to the
        serial dispatcher once it is made (`resolve`)."""
        parallel, self._dispatcher = self._dispatcher, None
        self.parallel = False
        self.options = {**self.options, "parallel": False, "cache": False}
        if parallel is not None:
            modules = [vars(m) for name, m in list(sys.modules.items()) if name.startswith("vibra.") and hasattr(m, "__dict__")]
            for namespace in modules:
                for name, value in list(namespace.items()):
                    if value is parallel:
                        namespace[name] = self
                        self._rebind.append((namespace, name))

    def resolve(self) -> Callable[_P, _R]:
        """numba's dispatcher of this function (created once; its module's names bound first)."""
        with _LOCK:
            if self._dispatcher is None:
                self._dispatcher = _numba().njit(**self.options)(self.py_func)
                bind(self.py_func.__globals__)
                for namespace, name in self._rebind:  # (a forked child's serial copy: `serial_after_fork`)
                    namespace[name] = self._dispatcher
                self._rebind = []
            return cast("Callable[_P, _R]", self._dispatcher)

    def ahead_of_time(self, args: tuple[Any, ...]) -> Callable[..., Any] | None:
        """This kernel's ahead-of-time export for exactly these argument types (`vibra.solvers.aot`),
        or None (none built, or other types); a missing copy starts its build in the background."""
        from vibra.solvers.aot import load, matches, start_background_build

        if self._exports is None:
            module, exports = load()
            name = f"{self.py_func.__module__}.{self.py_func.__name__}"
            self._exports = [] if module is None else [
                (export["args"], getattr(module, export["symbol"])) for export in exports.get(name, ())]
            if module is None:
                start_background_build()
        for spec, function in self._exports:
            if matches(spec, args):
                return function
        return None

    def __call__(self, *args: _P.args, **kwargs: _P.kwargs) -> _R:
        if self.aot and not kwargs and self._dispatcher is None:
            function = self.ahead_of_time(args)
            # a parallel kernel runs its (serial) copy only where loading numba to spread the work
            # over threads would cost more than the whole serial run
            if function is not None and (not self.parallel or (
                    "numba" not in sys.modules and self.work is not None and self.work(*args) < LOAD_SECONDS)):
                return cast("_R", function(*args))
        return self.resolve()(*args, **kwargs)

    def __repr__(self) -> str:
        return f"<compiled kernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


#: Every kernel declared ``aot=True``, in the order their modules were imported (`vibra.solvers.aot_build.build`
#: exports them; a module's names may since have been bound to numba's dispatchers).
AOT_KERNELS: list[Kernel[Any, Any]] = []

#: Every kernel declared ``parallel=True`` (`forked_with_numba`).
_PARALLEL: list[Kernel[Any, Any]] = []

#: Whether this process was forked from one that had loaded numba (`forked_with_numba`).
_FORKED_WITH_NUMBA = False


def forked_with_numba() -> bool:
    """Whether this process was forked from one that had loaded numba: its parallel kernels then run
    serial copies (`Kernel.serial_after_fork`; GNU OpenMP terminates such a child's parallel regions)."""
    return _FORKED_WITH_NUMBA


def _after_fork_in_child() -> None:
    global _FORKED_WITH_NUMBA, _LOCK
    _LOCK = threading.RLock()  # (a parent thread may have held it at the fork)
    if "numba" in sys.modules and not _FORKED_WITH_NUMBA:
        _FORKED_WITH_NUMBA = True
        for kernel in _PARALLEL:
            kernel.serial_after_fork()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)


def jit(**options: object) -> Callable[[Callable[_P, _R]], Kernel[_P, _R]]:
    """``numba.njit(**options)``, applied on the function's first call (a `Kernel`).

    Two options are vibra's, not numba's: ``aot=True`` compiles the kernel ahead of time too
    (`vibra.solvers.aot`: a call with the argument types of its exports runs that copy and loads no
    numba), and, for a parallel one, ``work=f``: ``f(*args)``, its serial run's seconds estimated
    from sizes; the serial copy runs where that is under `LOAD_SECONDS` and numba is not loaded."""
    def wrap(function: Callable[_P, _R]) -> Kernel[_P, _R]:
        return Kernel(function, dict(options))
    return wrap


class _Intrinsic(_Lazy):
    """``numba.extending.intrinsic(function)``, made when a kernel that names it is bound."""

    def __init__(self, function: Callable[..., object]) -> None:
        self.function = function
        self._made: Any = None
        functools.update_wrapper(self, function)

    def resolve(self) -> Any:
        with _LOCK:
            if self._made is None:
                _numba()
                self._made = importlib.import_module("numba.extending").intrinsic(self.function)
            return self._made


def intrinsic(function: Callable[..., object]) -> _Intrinsic:
    """``numba.extending.intrinsic``, lazily (the typing function imports numba and llvmlite itself)."""
    return _Intrinsic(function)


class _Prange(_Lazy):
    """``numba.prange`` in compiled code; ``range`` if called from Python."""

    def __call__(self, *args: int) -> range:
        return range(*args)

    def resolve(self) -> Any:
        return _numba().prange


prange = _Prange()


@functools.cache
def _host_fma() -> bool:
    return bool(importlib.import_module("llvmlite.binding").get_host_cpu_features().get("fma", False))


class _HostFMA(_Lazy):
    """Whether this CPU fuses a multiply and an add in one rounding (LLVM's host features; x86-64
    since 2013, every ARM64): a bool to compiled code, true or false as one in Python."""

    def __bool__(self) -> bool:
        return _host_fma()

    def __repr__(self) -> str:
        return repr(bool(self))

    def resolve(self) -> bool:
        return _host_fma()


HOST_FMA = _HostFMA()


def bind(namespace: dict[str, object]) -> None:
    """Bind every `Kernel`, intrinsic, `prange` and `HOST_FMA` a module names (its globals) to
    numba's objects, the kernels' modules in turn (once per module)."""
    with _LOCK:
        if id(namespace) in _BOUND:
            return
        _BOUND.add(id(namespace))
        for name, value in list(namespace.items()):
            if isinstance(value, _Lazy):
                namespace[name] = value.resolve()


def threads() -> int:
    """numba's thread count (the parallel kernels' threads)."""
    return int(_numba().get_num_threads())
