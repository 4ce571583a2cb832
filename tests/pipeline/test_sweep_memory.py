"""A sweep's memory, from the first point's sizes, before any point is solved (issue 44).

Truth: the peak traced by Python's tracemalloc over real sweeps, and a builder that counts its
calls (a refused sweep solves nothing).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from vibra.chains import linear_chain
from vibra.pipeline.sweep import sweep
from vibra.pipeline.sweep.cost import check_sweep_memory, sweep_memory
from vibra.solvers import ResourceLimitError


@pytest.mark.parametrize("n, points, track", [(200, 200, True), (50, 1000, False)])
def test_estimate_holds_the_traced_peak(n: int, points: int, track: bool) -> None:
    """Every stiffness is its own grid line here (the first key, n, has one value), so a tracked
    sweep holds each point's vectors: the case where the vectors dominate. Bound 0.5-2x: the
    model is within 15 % of the peaks measured; the factor leaves room for another numpy's
    temporaries and still catches a missing term (the vectors are 95 % of the first case)."""
    grid = {"n": [n], "stiffness": list(np.linspace(1.0, 2.0, points))}
    sweep(linear_chain, {"n": [n]})  # imports and caches outside the traced run
    tracemalloc.start()
    try:
        sweep(linear_chain, grid, track=track)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    estimate = sweep_memory(points, n_dof=n, n_modes=n, solve=0.0, track=track, lines=points, distributed=False)
    assert 0.5 < estimate.total / peak < 2.0, (estimate, peak)


def test_a_sweep_over_the_memory_limit_is_refused_before_any_solve_naming_what_fits() -> None:
    calls = []

    def chain(n: int, stiffness: float) -> object:
        calls.append(stiffness)
        return linear_chain(n, stiffness=stiffness)

    grid = {"n": [300], "stiffness": list(np.linspace(1.0, 2.0, 500))}
    with pytest.raises(ResourceLimitError) as error:
        sweep(chain, grid, max_memory=50e6)
    message = str(error.value)
    assert len(calls) <= 1  # the first point built for its sizes, never solved
    assert "500 points of 300 dofs and 300 modes" in message and "max_memory" in message
    assert "track=False" in message  # the vectors are what does not fit
    fits = int(message.split("at most ")[1].split(" points")[0].replace(",", ""))
    check_sweep_memory(fits, n_dof=300, n_modes=300, solve=0.0, track=True, lines=fits, distributed=False,
                       max_memory=50e6)  # the count named fits
    table = sweep(chain, grid, max_memory=50e6, track=False)  # the way out named works
    assert len(table.rows) == 500


def test_one_process_holds_only_each_lines_last_vectors() -> None:
    """A grid of 20 lines x 30 points holds 20 points' vectors in one process, all 600 on a cluster."""
    serial = sweep_memory(600, n_dof=100, n_modes=100, solve=0.0, track=True, lines=20, distributed=False)
    cluster = sweep_memory(600, n_dof=100, n_modes=100, solve=0.0, track=True, lines=20, distributed=True)
    assert serial.vectors == 20 * 8 * 100 * 100 and cluster.vectors == 600 * 8 * 100 * 100


def test_sizes_multiply_in_python_integers() -> None:
    memory = sweep_memory(10**9, n_dof=10**6, n_modes=10**6, solve=0.0, track=True, lines=10**9, distributed=True)
    assert memory.total >= 8e21 and np.isfinite(memory.total)
