"""A process forked after its parent ran a parallel kernel (`vibra.solvers.compiled.forked_with_numba`).

GNU OpenMP, numba's threading layer where libgomp is found, terminates a forked child that starts a
parallel region after its parent did ("fork() called from a process already using GNU OpenMP");
``multiprocessing`` forks by default on Linux. The child must instead run the kernels serially and
give the same numbers. Truth: the parent's own values, bit for bit (each value of a bisection is
computed alone, whatever the threads), and the child's exit status (a terminated child gives -15).
Where numba's threading layer is fork-safe (TBB, workqueue) the test passes either way.
"""

from __future__ import annotations

import numpy as np
from helpers.forked import NEEDS_FORK, in_forked_child

from vibra.solvers import compiled
from vibra.solvers.accurate import count_kernels, gk_bisection
from vibra.solvers.accurate.ring import pencil_counts
from vibra.solvers.standard import rows


def _bidiagonal() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(4)
    return rng.uniform(0.5, 2.0, 400), rng.uniform(0.5, 2.0, 400)


def _child(queue) -> None:  # pragma: no cover - runs in the forked child
    d, e = _bidiagonal()
    values = gk_bisection.bidiagonal_values_by_bisection(d, e, 0, 64)
    queue.put((compiled.forked_with_numba(), values, isinstance(gk_bisection._bisect, compiled.Kernel)))


@NEEDS_FORK
def test_a_child_forked_after_a_parallel_kernel_ran_runs_it_serially() -> None:
    d, e = _bidiagonal()
    expected = gk_bisection.bidiagonal_values_by_bisection(d, e, 0, 64)  # the parallel kernel, on numba's threads
    assert not compiled.forked_with_numba()
    status, result = in_forked_child(_child, timeout=300)
    assert status == 0, f"the forked child ended with {status} (-15: terminated by GNU OpenMP; None: still running)"
    forked, values, wrapped = result
    assert forked is True
    assert np.array_equal(values, expected)
    assert wrapped is False  # (the module's name bound to the serial copy once made, not left on the wrapper)


def test_every_parallel_kernel_is_known() -> None:
    """The kernels the fork guard switches: every one declared ``parallel=True`` (in the modules that
    declare them), and in a process that was not forked, each still parallel."""
    names = {f"{kernel.py_func.__module__}.{kernel.py_func.__name__}": kernel for kernel in compiled._PARALLEL}
    assert {f"{gk_bisection.__name__}._bisect", f"{pencil_counts.__name__}._counts", f"{count_kernels.__name__}._counts",
            f"{count_kernels.__name__}._roots", f"{count_kernels.__name__}._chain_counts",
            f"{rows.__name__}._site_block_product"} <= set(names)
    assert not compiled.forked_with_numba()
    assert all(kernel.parallel and kernel.options.get("parallel") for kernel in names.values())
