"""The columns the shift-invert paths apply their shifted inverse F = (K~ - sigma I)^-1 to: a work count for tests
(never a time)."""

from __future__ import annotations

from typing import Any, Callable

import numpy as np
import pytest

from vibra.solvers.standard import shifted


def applications(call: Callable[[], Any]) -> tuple[Any, int]:
    """`call()` and the columns `shifted.ShiftedInverse.solve` was applied to meanwhile (a vector counts one)."""
    count = 0
    solve = shifted.ShiftedInverse.solve

    def counted(self: Any, x: np.ndarray) -> np.ndarray:
        nonlocal count
        count += 1 if x.ndim == 1 else x.shape[1]
        return solve(self, x)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(shifted.ShiftedInverse, "solve", counted)
        result = call()
    return result, count
