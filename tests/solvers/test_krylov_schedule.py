"""When the block Krylov iteration tests for convergence (`krylov._next_test`, twenty-fifth session).

The stopping test (an eigh of the m x m projection) runs after a quarter's growth of the basis at most, and sooner
where the residuals fall: at `PREDICT` of the columns a straight line in log through the last two tests gives. Truth:
the eigenvalues of diagonal operators (known exactly), the columns a test after every block needs (the fewest that
pass: the schedule may add at most a quarter of them), and the rule's own arithmetic on chosen histories.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vibra.solvers.standard import krylov


def test_plateau_waits_a_quarter_of_the_basis() -> None:
    history: list[tuple[int, float]] = []
    assert krylov._next_test(history, 40, np.array([1e12, 3e11]), 2) == 40 // krylov.SPACING
    assert krylov._next_test(history, 50, np.array([1.1e12]), 2) == 50 // krylov.SPACING  # (rose: no fall to follow)
    assert krylov._next_test([], 4, np.array([1e12]), 2) == 2  # (a block at least)


def test_a_fall_is_followed_to_where_it_passes() -> None:
    history: list[tuple[int, float]] = []
    krylov._next_test(history, 60, np.array([1e6, 1.0]), 2)
    step = krylov._next_test(history, 80, np.array([1e2, 3.0]), 2)
    fall = math.log(1e4) / 20  # per column
    assert step == int(krylov.PREDICT * math.log(1e2) / fall) == 7
    # a slow fall is not followed past a quarter of the basis
    slow: list[tuple[int, float]] = []
    krylov._next_test(slow, 200, np.array([1e8]), 2)
    assert krylov._next_test(slow, 250, np.array([5e7]), 2) == 250 // krylov.SPACING


def test_a_fall_from_the_plateau_halves_the_wait() -> None:
    # 3o21's network, 300 modes: the worst ratio 5.3e11 at 582 columns, 1.7e9 at 728 (the fall begun between them);
    # the line through the two says 405 columns more, where 80 passed: the next test comes after m / 8, not m / 4
    history: list[tuple[int, float]] = []
    krylov._next_test(history, 582, np.array([5.3e11]), 2)
    assert krylov._next_test(history, 728, np.array([1.7e9]), 2) == 728 // (2 * krylov.SPACING) == 91


def test_zero_tolerance_or_value_gives_no_warning() -> None:
    A = np.diag(np.arange(300.0, 0.0, -1.0))
    with np.errstate(all="raise"):  # (the ratio residual / (tol |mu|) divides by 0: no prediction, no warning)
        _, _, applied, done = krylov.block_eigs(lambda X: A @ X, 300, 5, tol=0.0, block=2, max_dim=40)
    assert not done and applied == 40


def test_a_ratio_that_is_not_finite_restarts_the_history() -> None:
    history = [(10, 3.0)]
    assert krylov._next_test(history, 20, np.array([np.inf]), 2) == 20 // krylov.SPACING and history == []
    assert krylov._next_test(history, 8, np.array([]), 4) == 4  # (no wanted pair yet: a block)


# The bound below is the rule's cap (a quarter of the basis past the fewest columns that pass); on these spectra the
# schedule applies 1.000-1.005 times the fewest (measured), and the old one (a test each sixteenth) 1.00-1.05 times.
@pytest.mark.parametrize("n, k, block", [(400, 10, 2), (600, 26, 2), (500, 40, 4), (800, 100, 2)])
def test_columns_past_convergence_stay_few(n: int, k: int, block: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(n + k)
    values = np.sort(rng.uniform(0.0, 1.0, n) ** 3)[::-1]  # (the largest spread, the rest bunched near 0)
    A = np.diag(values)
    mu, Y, applied, done = krylov.block_eigs(lambda X: A @ X, n, k, tol=1e-12, block=block)
    assert done
    np.testing.assert_allclose(mu, values[:k], rtol=1e-11)  # (tol 1e-12 on the residual: values to ~its square)
    calls: list[int] = []

    def every_block(history: list[tuple[int, float]], m: int, ratios: np.ndarray, width: int) -> int:
        calls.append(m)
        return width

    monkeypatch.setattr(krylov, "_next_test", every_block)
    _, _, fewest, done = krylov.block_eigs(lambda X: A @ X, n, k, tol=1e-12, block=block)
    assert done
    assert fewest <= applied <= fewest + max(block, fewest // krylov.SPACING)
