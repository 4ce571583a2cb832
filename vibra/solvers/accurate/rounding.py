"""The actual rounding of a chain's bidiagonal, and a-posteriori bounds of its singular values.

Two questions decide how far a computed chain frequency lies from the true one:

- *Forming*: the bidiagonal (d, e) of B~ = W^1/2 B M^-1/2 is stored in floating point, each
  entry off its exact value sqrt(w) c / sqrt(m) by a factor 1 + delta. `entry_deviation`
  computes each delta itself (error-free transformations: Dekker's TwoProduct and TwoSum on
  the entries' mantissas, so nothing over- or underflows), to ~eps^2. On a path, entry
  factors are exactly diagonal scalings, stored = D1 B D2 (`scaling_logs`: cumulative sums
  along the path), and every singular value moves by a factor within
  [min D1 min D2, max D1 max D2] (`walk_bound`, no vectors), or to first order by
  sum log D1_i u_i^2 + sum log D2_j v_j^2 (`weighted_forming`, with vectors; plus a
  second-order margin). A uniform chain's entries all round alike: a common factor, ~1 eps;
  a disordered chain's factors walk: ~sqrt(size) eps without vectors, less with them.
- *Solving*: `rayleigh_refinement` takes a singular triplet (sigma, u, v) of the stored
  bidiagonal, forms the residuals B v - sigma u and B^T u - sigma v in double-double
  (their rounding bounded rigorously), the Rayleigh quotient rho of the Golub-Kahan form
  at z = [v; u], and `kato_temple` bounds |rho - sigma_true| <= ||r||^2 / gap, gap to the
  neighbouring singular values: ~eps^2-small for a separated mode.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["two_sum", "two_product", "dekker_split", "split_product", "SPLIT", "entry_deviation", "scaling_logs",
           "walk_bound", "weighted_forming", "rayleigh_refinement", "kato_temple", "Scalings", "UNIT", "WORST_ENTRY", "centred", "vector_sums", "forming_from_sums"]

#: Unit roundoff of float64 (half of machine epsilon).
UNIT = float(np.finfo(float).eps) / 2

#: Worst-case relative rounding of one entry sqrt(w) c / sqrt(m) formed in float64 (two square
#: roots, a reciprocal and two products: 5 roundings, with a margin): used where the actual
#: rounding cannot be computed (entries whose exact value is unknown here).
WORST_ENTRY = 6.0 * UNIT

SPLIT = 134217729.0  # 2^27 + 1, Dekker's splitter for float64


def two_sum(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(s, t) with s = fl(a + b) and a + b = s + t exactly (Knuth's TwoSum)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def dekker_split(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    c = SPLIT * a
    high = c - (c - a)
    return high, a - high


def two_product(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(p, e) with p = fl(a b) and a b = p + e exactly (Dekker), for |a|, |b| well inside the range.

    Examples
    --------
    >>> p, e = two_product(np.array([1.0 + 2.0**-30]), np.array([1.0 + 2.0**-30]))
    >>> float(p[0] - 1.0) == 2.0**-29, float(e[0]) == 2.0**-60
    (True, True)
    """
    return split_product(a, b, *dekker_split(a), *dekker_split(b))


def split_product(a: NDArray[np.float64], b: NDArray[np.float64], ah: NDArray[np.float64], al: NDArray[np.float64],
             bh: NDArray[np.float64], bl: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`two_product` with the halves of a and b already split (shared by many products)."""
    p = a * b
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _mantissa(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    fraction, exponent = np.frexp(x)
    return fraction, exponent.astype(np.int64)


def _square_times(x: NDArray[np.float64], y: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """x^2 y as a double-double (hi, lo), error <= 4 u^2 |x^2 y|, for mantissas in [0.5, 1)."""
    p1, e1 = two_product(x, x)
    p2, e2 = two_product(p1, y)
    return two_sum(p2, e2 + e1 * y)


def entry_deviation(values: NDArray[np.float64], weights: NDArray[np.float64], couplings: NDArray[np.float64],
                    masses: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each stored entry's relative deviation from its exact value sqrt(w) c / sqrt(m).

    Parameters
    ----------
    values : (p,) ndarray
        The stored entries x of B~, dimensionless like B~.
    weights, couplings, masses : (p,) ndarray
        The w (spring constant of the entry's row), c (the entry of B) and m (mass of its
        column) it was formed from, as given (exact).

    Returns
    -------
    delta : (p,) ndarray
        x = (1 + delta) sqrt(w) c / sqrt(m), delta to within `slack` (absolute).
    slack : (p,) ndarray
        A bound on the error of each delta: ~1e-31 where the transformation is exact,
        `WORST_ENTRY` (and delta = 0) where it is not available (a zero, a non-finite entry
        or one whose exact value differs from x by more than a few eps: not formed that way).

    Examples
    --------
    >>> x = np.sqrt(np.array([2.0])) * (1.0 / np.sqrt(np.array([3.0])))
    >>> delta, slack = entry_deviation(x, np.array([2.0]), np.array([1.0]), np.array([3.0]))
    >>> bool(abs(delta[0]) <= 2 * np.finfo(float).eps and slack[0] < 1e-29)
    True
    """
    x = np.abs(np.asarray(values, dtype=float))
    xm, xe = _mantissa(x)
    mm, me = _mantissa(np.asarray(masses, dtype=float))
    wm, we = _mantissa(np.asarray(weights, dtype=float))
    cm, ce = _mantissa(np.abs(np.asarray(couplings, dtype=float)))
    # x^2 m against w c^2 (equal when x is exact), mantissas only: no overflow or underflow
    left_hi, left_lo = _square_times(xm, mm)
    right_hi, right_lo = _square_times(cm, wm)
    shift = (2 * xe + me) - (2 * ce + we)
    usable = (x > 0) & np.isfinite(x) & (np.abs(shift) <= 4)
    shift = np.where(usable, shift, 0)
    left_hi, left_lo = np.ldexp(left_hi, shift), np.ldexp(left_lo, shift)  # exact: powers of 2
    head = left_hi - right_hi  # exact (Sterbenz) when the two agree within a factor 2
    t = (head + (left_lo - right_lo)) / right_hi  # (x^2 m - w c^2) / (w c^2): 2 delta + delta^2
    usable &= np.isfinite(t) & (np.abs(t) < 64 * UNIT) & (np.abs(left_hi) <= 2 * np.abs(right_hi))
    delta = np.where(usable, t / (np.sqrt(1.0 + np.where(usable, t, 0.0)) + 1.0), 0.0)
    slack = np.where(usable, 16 * UNIT * np.abs(delta) + 64 * UNIT * UNIT, WORST_ENTRY)
    return delta, slack


def scaling_logs(diagonal_delta: NDArray[np.float64], upper_delta: NDArray[np.float64],
                 diagonal: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(a, b): stored (d, e) = D1 (exact) D2 with D1 = exp(a), D2 = exp(b), for entry factors 1 + delta.

    On an upper bidiagonal, d_i (1 + dd_i) = e^{a_i} d_i e^{b_i} and e_i (1 + de_i) =
    e^{a_i} e_i e^{b_{i+1}}: b_{i+1} - b_i = log(1 + de_i) - log(1 + dd_i), a cumulative sum
    along the path, and a_i = log(1 + dd_i) - b_i. A zero (padding) d_i is exact whatever
    a_i, which then copies a neighbour's. The common shift of b against a is free; it
    cancels in every bound.
    """
    log_d = np.log1p(diagonal_delta)
    log_e = np.log1p(upper_delta)
    size = diagonal_delta.shape[0]
    b = np.zeros(size)
    if size > 1:
        step = log_e - log_d[:-1]
        zero = diagonal[:-1] == 0
        step = np.where(zero, log_e - log_e.mean(), step)  # a free a_i: keep b near the walk
        b[1:] = np.cumsum(step)
    a = log_d - b
    padding = np.zeros(size, dtype=bool)
    padding[-1:] = diagonal[-1:] == 0  # a zero last row: its a is free (a middle one keeps the step's)
    if padding.any():
        others = a[~padding]
        a[padding] = float(np.median(others)) if others.size else 0.0
    return a, b


def walk_bound(a: NDArray[np.float64], b: NDArray[np.float64], slack: float,
               row_slack: NDArray[np.float64] | None = None, column_slack: NDArray[np.float64] | None = None
               ) -> float:
    """Relative bound on every singular value from the scalings exp(a), exp(b) (no vectors).

    sigma(D1 B D2) / sigma(B) lies in [min D1 min D2, max D1 max D2]; `slack` (the entries'
    own uncertainty, summed along the path) widens both ends, `row_slack` / `column_slack`
    (the uncertainty of one row's or column's own scaling: a weight known only to within it)
    widen a and b where they sit.
    """
    if a.size == 0:
        return 0.0
    rows = np.zeros_like(a) if row_slack is None else row_slack
    columns = np.zeros_like(b) if column_slack is None else column_slack
    top = float((a + rows).max() + (b + columns).max()) + slack
    bottom = float((a - rows).min() + (b - columns).min()) - slack
    return max(float(np.expm1(top)), float(-np.expm1(bottom)), 0.0) * (1 + 4 * UNIT)


def weighted_forming(a: NDArray[np.float64], b: NDArray[np.float64], left: NDArray[np.float64],
                     right: NDArray[np.float64], relative_gap: NDArray[np.float64], slack: float,
                     row_slack: NDArray[np.float64] | None = None,
                     column_slack: NDArray[np.float64] | None = None,
                     angle: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Per-mode relative bound of forming with vectors: |sum a u^2 + sum b v^2| + second order.

    left (s, k) and right (s, k) are the stored bidiagonal's singular vectors (unit columns),
    `relative_gap` (k,) each mode's smallest |sigma_j - sigma| / max(sigma_j, sigma). The
    derivative of log sigma along D1(t) = exp(t a), D2(t) = exp(t b) is u(t)^T a u(t) +
    v(t)^T b v(t); the vectors turn by at most ~2 eta t / relative gap (eta = the scalings'
    spread), so the integral stays within 8 eta^2 / relative gap of its value at t = 0. Where
    that margin would reach eta itself, the vector-free `walk_bound` is returned instead.
    Row and column slacks count with the mode's weight there: + row_slack u^2 + column_slack v^2.
    `angle` (k,) bounds each computed vector pair's angle to the exact one (residual / gap): the
    weighted sum then moves by at most 8 eta angle (2 eta (|du| + |dv|), |du| + |dv| <= 2 sqrt 2 angle).
    """
    rows = np.zeros_like(a) if row_slack is None else row_slack
    columns = np.zeros_like(b) if column_slack is None else column_slack
    first, norms = vector_sums(a, b, rows, columns, left, right)
    return forming_from_sums(a, b, first, norms, relative_gap, slack, rows, columns, angle)


def vector_sums(a: NDArray[np.float64], b: NDArray[np.float64], rows: NDArray[np.float64],
                columns: NDArray[np.float64], left: NDArray[np.float64], right: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per mode (column of left, right), the sums `forming_from_sums` needs: |a_c . u^2 +
    b_c . v^2| + rows . u^2 + columns . v^2 (a_c, b_c from `centred`) and |u|^2 + |v|^2."""
    a_centred, b_centred = centred(a, b)
    first = np.abs(a_centred @ left**2 + b_centred @ right**2) + rows @ left**2 + columns @ right**2
    norms = np.sum(left**2, axis=0) + np.sum(right**2, axis=0)  # 2 for unit columns (their rounding)
    return first, norms


def centred(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(a + c, b - c), c centring b's range: the same scalings, the smallest first-order sums."""
    centre = 0.5 * (float(b.max()) + float(b.min())) if b.size else 0.0
    return a + centre, b - centre


def forming_from_sums(a: NDArray[np.float64], b: NDArray[np.float64], first: NDArray[np.float64],
                      norms: NDArray[np.float64], relative_gap: NDArray[np.float64], slack: float,
                      rows: NDArray[np.float64], columns: NDArray[np.float64],
                      angle: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """`weighted_forming` from its vector sums (`vector_sums`, or `triplets.triplet_figures`)."""
    a_centred, b_centred = centred(a, b)
    eta = float(np.abs(a_centred).max(initial=0.0) + np.abs(b_centred).max(initial=0.0)) + slack
    eta += float(rows.max(initial=0.0) + columns.max(initial=0.0))
    first = first + 2 * eta * np.abs(norms - 2.0) + slack
    if angle is not None:
        first = first + 8 * eta * angle
    with np.errstate(divide="ignore", invalid="ignore"):
        margin = np.where(relative_gap > 0, 8.0 * eta * eta / relative_gap, np.inf)
    whole = walk_bound(a, b, slack, rows, columns)
    bound = np.where(margin < eta, np.expm1(first + margin) * (1 + 4 * UNIT), whole)
    return np.minimum(bound, whole)


def _residual(diagonal: NDArray[np.float64], upper: NDArray[np.float64], sigma: NDArray[np.float64],
              here: NDArray[np.float64], there: NDArray[np.float64], transpose: bool
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """B there - sigma here (or B^T there - sigma here) in double-double, rounded; and its error bound.

    Columns are modes. Three TwoProducts and TwoSums: the exact sum of six doubles to within
    u^2-level terms; the rounded result then differs from the exact one by <= u |r| + 8 u^2 sum|p|.
    """
    d = diagonal[:, None]
    there_high, there_low = dekker_split(there)
    p1, e1 = split_product(d, there, *dekker_split(d), there_high, there_low)
    shifted, shifted_high, shifted_low = (np.zeros_like(there) for _ in range(3))
    if transpose:  # (B^T u)_i = d_i u_i + e_{i-1} u_{i-1}
        for target, source in ((shifted, there), (shifted_high, there_high), (shifted_low, there_low)):
            target[1:] = source[:-1]
        coefficient = np.r_[0.0, upper][:, None]
    else:  # (B v)_i = d_i v_i + e_i v_{i+1}
        for target, source in ((shifted, there), (shifted_high, there_high), (shifted_low, there_low)):
            target[:-1] = source[1:]
        coefficient = np.r_[upper, 0.0][:, None]
    p2, e2 = split_product(coefficient, shifted, *dekker_split(coefficient), shifted_high, shifted_low)
    minus = -sigma[None, :]
    p3, e3 = split_product(minus, here, *dekker_split(minus), *dekker_split(here))
    s, t1 = two_sum(p1, p2)
    s, t2 = two_sum(s, p3)
    result = s + (((t1 + t2) + (e1 + e2)) + e3)
    error = UNIT * np.abs(result) + 8 * UNIT * UNIT * (np.abs(p1) + np.abs(p2) + np.abs(p3))
    return result, error


def rayleigh_refinement(diagonal: NDArray[np.float64], upper: NDArray[np.float64], sigma: NDArray[np.float64],
                        left: NDArray[np.float64], right: NDArray[np.float64]
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Rayleigh quotients of the Golub-Kahan form at z = [v; u], and their residual norms.

    Parameters
    ----------
    diagonal, upper : the stored upper bidiagonal (d, e), sizes s and s - 1.
    sigma : (k,) approximate singular values; left, right : (s, k) their vectors u, v.

    Returns
    -------
    rho : (k,) ndarray
        fl(rho), the Rayleigh quotient 2 u^T B v / (|u|^2 + |v|^2) rounded to a double.
    uncertainty : (k,) ndarray
        A bound on |fl(rho) - rho_exact| (its rounding and that of the correction).
    residual : (k,) ndarray
        An upper bound on ||T z - rho_exact z|| / ||z||, T the Golub-Kahan tridiagonal.
    """
    r1, err1 = _residual(diagonal, upper, sigma, left, right, transpose=False)  # B v - sigma u
    r2, err2 = _residual(diagonal, upper, sigma, right, left, transpose=True)  # B^T u - sigma v
    norm2 = np.sum(left**2, axis=0) + np.sum(right**2, axis=0)
    s = diagonal.shape[0]
    dot = np.sum(left * r1, axis=0) + np.sum(right * r2, axis=0)
    dot_error = (np.sum(np.abs(left) * (np.abs(r1) + err1), axis=0) * (2 * s + 4) * UNIT
                 + np.sum(np.abs(left) * err1, axis=0) + np.sum(np.abs(right) * err2, axis=0)
                 + np.sum(np.abs(right) * (np.abs(r2) + err2), axis=0) * (2 * s + 4) * UNIT)
    correction = dot / norm2
    correction_error = dot_error / norm2 + np.abs(correction) * (2 * s + 8) * UNIT
    rho, rounding = two_sum(sigma, correction)
    uncertainty = np.abs(rounding) + correction_error
    # residual at rho: r - (rho - sigma) [u; v], bounded by the triangle inequality
    shifted1 = r1 - correction[None, :] * left
    shifted2 = r2 - correction[None, :] * right
    raw = np.sqrt(np.sum(shifted1**2, axis=0) + np.sum(shifted2**2, axis=0))
    rounding_part = np.sqrt(np.sum(err1**2, axis=0) + np.sum(err2**2, axis=0))
    residual = (raw * (1 + (s + 8) * UNIT) + rounding_part + (uncertainty + 4 * UNIT * np.abs(correction))
                * np.sqrt(norm2)) / (np.sqrt(norm2) * (1 - 4 * UNIT))
    return rho, uncertainty, residual


def kato_temple(rho: NDArray[np.float64], residual: NDArray[np.float64], below: NDArray[np.float64],
                above: NDArray[np.float64]) -> NDArray[np.float64]:
    """|lambda - rho| bound for the one eigenvalue lambda in (below, above) around rho; inf where none.

    Kato-Temple: rho - r^2 / (above - rho) <= lambda <= rho + r^2 / (rho - below), for the
    Rayleigh quotient rho of a unit vector with residual norm r, when (below, above) holds
    rho and no eigenvalue but lambda. Where the residual reaches the gap: Weyl, |lambda - rho| <= r
    (some eigenvalue lies there; it is lambda when [rho - r, rho + r] stays inside (below, above)).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        low_gap = rho - below
        high_gap = above - rho
        squared = residual * residual
        bound = np.maximum(squared / high_gap, squared / low_gap) * (1 + 8 * UNIT)
        inside = (low_gap > residual) & (high_gap > residual)
    return np.where(inside, np.minimum(bound, residual), np.inf)


class Scalings:
    """The forming error of one bidiagonal as diagonal scalings: stored = exp(a) exact exp(b).

    `slack` bounds what the logs a, b leave out (the entries' own uncertainty summed along
    the path, or the whole forming error where it is a worst-case figure and a = b = 0);
    `row_slack` / `column_slack` (optional, per row / column) the uncertainty of a row's or
    column's own scaling (an entry alone in its row or column whose weight is known only
    to within it: a chain's anchor read back from K).
    """

    __slots__ = ("a", "b", "slack", "row_slack", "column_slack")

    def __init__(self, a: NDArray[np.float64], b: NDArray[np.float64], slack: float,
                 row_slack: NDArray[np.float64] | None = None,
                 column_slack: NDArray[np.float64] | None = None) -> None:
        self.a, self.b, self.slack = a, b, float(slack)
        self.row_slack = np.zeros_like(a) if row_slack is None else row_slack
        self.column_slack = np.zeros_like(b) if column_slack is None else column_slack

    @classmethod
    def worst_case(cls, size: int, relative: float) -> "Scalings":
        """No entry-wise figures: every singular value within `relative` (a = b = 0)."""
        return cls(np.zeros(size), np.zeros(size), relative)

    def bound(self) -> float:
        """Relative bound on every singular value (`walk_bound`)."""
        return walk_bound(self.a, self.b, self.slack, self.row_slack, self.column_slack)

    def weighted(self, left: NDArray[np.float64], right: NDArray[np.float64],
                 relative_gap: NDArray[np.float64], angle: NDArray[np.float64] | None = None
                 ) -> NDArray[np.float64]:
        """Per-mode relative bounds with the stored bidiagonal's vectors (`weighted_forming`)."""
        return weighted_forming(self.a, self.b, left, right, relative_gap, self.slack, self.row_slack,
                                self.column_slack, angle)

    def sums(self, left: NDArray[np.float64], right: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The vectors' sums that `from_sums` takes (`vector_sums`)."""
        return vector_sums(self.a, self.b, self.row_slack, self.column_slack, left, right)

    def from_sums(self, first: NDArray[np.float64], norms: NDArray[np.float64], relative_gap: NDArray[np.float64],
                  angle: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
        """`weighted` from the vectors' sums (`sums`, or `triplets.triplet_figures`'s)."""
        return forming_from_sums(self.a, self.b, first, norms, relative_gap, self.slack, self.row_slack,
                                 self.column_slack, angle)
