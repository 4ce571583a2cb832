"""`gk_bisection`: singular values of a bidiagonal by compiled bisection on its Golub-Kahan form.

Truth: 50-digit mpmath singular values (small bidiagonals) and LAPACK dstebz on the same
Golub-Kahan matrix (an independent implementation of the same relatively accurate counts).
Bisection stops at 2 ulps of each value (hi - lo <= 2 eps hi); the Sturm counts are exact for
entries perturbed by a few ulps relatively (Demmel-Kahan), so each value is within ~8 ulps of
the truth: the tolerance below. Values below the pivot threshold (~1e-308 ||B||^2, reached only
by products of extreme ratios) are reported 0, as a free chain's padding is.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

from vibra._core.lapack import tridiagonal_eigenvalues_by_index
from vibra.solvers.accurate import gk_bisection


EPS = float(np.finfo(float).eps)


def _bidiagonal(size: int, spread: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return 10.0 ** rng.uniform(-spread / 2, spread / 2, size), 10.0 ** rng.uniform(-spread / 2, spread / 2, size - 1)


@pytest.mark.parametrize(("size", "spread"), [(1, 0.0), (2, 3.0), (7, 0.0), (25, 6.0), (40, 12.0)])
def test_values_match_50_digit_singular_values(size: int, spread: float) -> None:
    """Every singular value of small bidiagonals (log-uniform entries over 10^spread) within 8
    ulps of 50-digit mpmath, and the lowest exactly 0 where a zero diagonal entry pads it."""
    for pad in (False, True):
        d, e = _bidiagonal(size, spread, size + int(spread))
        if pad:
            d[-1] = 0.0
        values = gk_bisection.bidiagonal_values_by_bisection(d, e, 0, size)
        with mp.workdps(50):
            B = mp.matrix(size, size)
            for i in range(size):
                B[i, i] = mp.mpf(float(d[i]))
                if i + 1 < size:
                    B[i, i + 1] = mp.mpf(float(e[i]))
            truth = sorted(float(x) for x in mp.svd_r(B, compute_uv=False))
        truth = np.array(truth)
        if pad:
            assert values[0] == 0.0
            values, truth = values[1:], truth[1:]
        assert np.all(np.abs(values - truth) <= 8 * EPS * truth), (size, spread, pad)


@pytest.mark.parametrize("spread", [0.0, 6.0, 12.0])
def test_values_match_lapack_bisection_on_long_bidiagonals(spread: float) -> None:
    """The lowest 20 and 20 from the middle of a 20,000-entry bidiagonal against dstebz on the
    same Golub-Kahan matrix: within 8 ulps (both to ~2 ulps of relatively accurate counts),
    wherever the values lie above the pivot threshold."""
    size = 20000
    d, e = _bidiagonal(size, spread, 3)
    off = np.empty(2 * size - 1)
    off[0::2], off[1::2] = d, e
    for skip in (0, size // 2):
        ours = gk_bisection.bidiagonal_values_by_bisection(d, e, skip, 20)
        lapack, _, _ = tridiagonal_eigenvalues_by_index(np.zeros(2 * size), off, size + skip, size + skip + 19)
        lapack = np.sort(np.abs(lapack))
        # random entries over 1e12 make products of ratios that reach underflow: values near the
        # pivot threshold (~1e-308 ||B||^2) have few or no digits in either (dstebz reports the
        # threshold, this 0; at 4x the threshold they differ by 4e-8): compare above 1e-200 ||B||
        threshold = 1e-200 * float(np.max(off))
        meaningful = lapack > threshold
        assert meaningful.sum() >= 10 and np.all(ours[~meaningful] <= threshold)
        assert np.all(np.abs(ours - lapack)[meaningful] <= 8 * EPS * lapack[meaningful]), (spread, skip)


def test_each_value_is_the_same_asked_alone_or_with_others() -> None:
    """Values are bisected `LANES` at a time, each lane on its own value (a finished lane takes
    the next): a value does not depend on which others were asked with it (bit for bit)."""
    d, e = _bidiagonal(3000, 6.0, 9)
    together = gk_bisection.bidiagonal_values_by_bisection(d, e, 5, 3 * gk_bisection.CHUNK + 3)
    for j in (0, 1, 7, 8, 40, together.shape[0] - 1):
        assert gk_bisection.bidiagonal_values_by_bisection(d, e, 5 + j, 1)[0] == together[j]


def test_bad_indices_are_refused() -> None:
    d, e = _bidiagonal(10, 0.0, 1)
    with pytest.raises(ValueError, match=r"indices must lie in 0\.\.9, got 8\.\.10"):
        gk_bisection.bidiagonal_values_by_bisection(d, e, 8, 3)


@pytest.mark.parametrize(("padded", "spread", "skip"), [(True, 0.0, 0), (True, 6.0, 0), (False, 6.0, 0), (True, 0.0, 4)])
def test_vectors_from_compiled_values_match_the_lapack_route(padded: bool, spread: float, skip: int) -> None:
    """With vectors, `gk_bisection.golub_kahan_lowest` takes its values from the compiled bisection and
    gives dstein the block structure itself (one block, or a free chain's padding: d[-1] = 0
    splits off a 1 x 1 block with one of the two zero eigenvalues). Against the dstebz route on
    a 20,000-site chain's bidiagonal spring factor (its lowest values well apart): the same values within 4 ulps, the same vectors up to sign
    within 1e-12 (distinct values here), residuals ||B v - sigma u|| within 1e-13 ||B||."""
    rng = np.random.default_rng(5)  # a chain's spring factor: masses and springs over 10^spread
    size = 20000
    m, w = 10.0 ** rng.uniform(0, spread, size), 10.0 ** rng.uniform(0, spread, size)
    d, e = np.sqrt(w / m), np.sqrt(w[:-1] / m[1:])  # (fixed at the far end: w[-1] to a wall)
    if padded:
        d[-1] = 0.0  # a free chain: its last row, padding
    ours = gk_bisection.golub_kahan_lowest(d, e, skip, 12, vectors=True)
    saved = gk_bisection._compiled_with_blocks
    gk_bisection._compiled_with_blocks = lambda *arguments: None  # dstebz's values and blocks: the LAPACK route
    try:
        lapack = gk_bisection.golub_kahan_lowest(d, e, skip, 12, vectors=True)
    finally:
        gk_bisection._compiled_with_blocks = saved
    sigma, u, v = ours
    assert np.all(np.abs(sigma - lapack[0]) <= 4 * EPS * lapack[0])
    for mine, theirs in ((u, lapack[1]), (v, lapack[2])):
        assert mine is not None and theirs is not None
        assert np.all(np.minimum(np.abs(mine - theirs).max(axis=0), np.abs(mine + theirs).max(axis=0)) < 1e-12)
    norm = float(max(np.abs(d).max(), np.abs(e).max()))
    for j in range(12):
        assert np.linalg.norm(d * v[:, j] + np.r_[e * v[1:, j], 0.0] - sigma[j] * u[:, j]) <= 1e-13 * norm
