"""Double-double arithmetic (`vibra.solvers.accurate.dd`) against mpmath at 50 digits."""

from __future__ import annotations

import mpmath
import numpy as np

from vibra.solvers.accurate import dd


def exact(hi: np.ndarray, lo: np.ndarray) -> list[mpmath.mpf]:
    return [mpmath.mpf(float(h)) + mpmath.mpf(float(l)) for h, l in zip(np.ravel(hi), np.ravel(lo))]


def test_operations_are_within_a_few_units() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal(200) * 10.0 ** rng.uniform(-8, 8, 200), rng.standard_normal(200)
    al, bl = a * 2.0**-60 * rng.standard_normal(200), b * 2.0**-60 * rng.standard_normal(200)
    with mpmath.workdps(50):
        A, B = exact(a, al), exact(b, bl)
        for operation, reference in ((dd.add, lambda x, y: x + y), (dd.mul, lambda x, y: x * y),
                                     (dd.div, lambda x, y: x / y)):
            result = exact(*operation(a, al, b, bl))
            for value, x, y in zip(result, A, B):
                truth = reference(x, y)
                scale = abs(truth) if operation is not dd.add else abs(x) + abs(y)
                assert abs(value - truth) <= dd.UNIT * scale


def test_tree_sum_keeps_what_float64_loses() -> None:
    hi = np.array([1.0, 1e-20, -1.0, 3e-25])
    total = dd.tree_sum(hi, np.zeros(4))
    assert float(total[0]) == 1e-20 + 3e-25 and abs(float(total[0]) + float(total[1]) - (1e-20 + 3e-25)) < 1e-40


def test_lu_solve_to_the_condition_times_the_unit() -> None:
    """A symmetric matrix with diagonal over 1e+-8 (condition ~1e5 after pivoting): the solution
    agrees with mpmath's to cond x UNIT, far below float64's 1e-11."""
    rng = np.random.default_rng(1)
    n = 30
    A = rng.standard_normal((n, n))
    A = A @ A.T + np.diag(10.0 ** rng.uniform(-8, 8, n))
    b = rng.standard_normal(n)
    xh, xl = dd.lu_solve(*dd.lu(A, np.zeros_like(A)), b, np.zeros(n))
    with mpmath.workdps(50):
        x = mpmath.lu_solve(mpmath.matrix(A.tolist()), mpmath.matrix(b.tolist()))
        worst = max(abs(v - x[i]) / abs(x[i]) for i, v in enumerate(exact(xh, xl)))
    assert worst < np.linalg.cond(A) * 1e3 * dd.UNIT


def test_split_mp_keeps_the_low_part_outside_a_raised_precision() -> None:
    """The low word is v - hi of the full-precision v, even when split at 15 digits."""
    with mpmath.workdps(40):
        value = mpmath.mpf(1) / 3
    hi, lo = dd.split_mp([value])
    with mpmath.workdps(40):
        assert abs(mpmath.mpf(float(hi[0])) + mpmath.mpf(float(lo[0])) - value) < mpmath.mpf(2) ** -100
