"""accuracy="high" on a ring from a standard solver's values: `ring.pencil_counts` (K - x M's counts,
compiled) and `ring.counted` (each value bracketed by two counts).

Truth: mpmath (eigenvalues of K~ formed from the inputs at 80 digits, `mp_weighted_gram`), the
numpy reference counts (`ring.counts.count_below`, with K's entries formed in mpmath), the
uniform ring's closed form omega_j^2 = 4 sin^2(pi j / n) (Kneller, "Mécanique analytique").
"""

from __future__ import annotations

from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest
import scipy.sparse as sp

from vibra import normal_modes
from vibra.chains import linear_chain
from vibra.solvers.common import SolveResult
from vibra.solvers.accurate import count_kernels
from vibra.solvers.accurate.ring import counted, counts as ring_counts
from vibra.solvers.accurate.ring.pencil_counts import PencilCounts, pencil_entries

from helpers.rings import covered, disordered_ring, mp_weighted_gram, small_ring


def test_the_fused_product_is_exact_as_dekkers() -> None:
    """`count_kernels.scalar_two_product` (one FMA where the CPU has it): p + e = a b exactly (fractions),
    the same two numbers as Dekker's splitting, over 1e-150..1e150 and both signs."""
    rng = np.random.default_rng(5)
    a = 10.0 ** rng.uniform(-150, 150, 400) * rng.choice([-1.0, 1.0], 400)
    b = 10.0 ** rng.uniform(-150, 150, 400) * rng.choice([-1.0, 1.0], 400)
    for x, y in zip(a.tolist(), b.tolist()):
        p, e = count_kernels.scalar_two_product(x, y)
        assert Fraction(p) + Fraction(e) == Fraction(x) * Fraction(y)
        assert p == x * y


def test_pencil_entries_are_within_their_bound_of_mpmaths() -> None:
    """`pencil_entries` (double-double from the springs) against `RingPencil.a`, `.b` (mpmath at
    40 digits): every entry within `entry_error` relatively, on 30 small rings up to 1e12."""
    rng = np.random.default_rng(2)
    for _ in range(30):
        B, springs, mass, _ = small_ring(rng, (0.3, 6.0, 12.0))
        pencil = ring_counts.ring_pencil(sp.csr_matrix(B), springs, mass)
        assert pencil is not None
        ((ah, al), (bh, bl)), error = pencil_entries(pencil)
        for (hi, lo), (ref_hi, ref_lo) in (((ah, al), pencil.a), ((bh, bl), pencil.b)):
            with mp.workdps(40):
                for j in range(hi.shape[0]):
                    ours, theirs = mp.mpf(hi[j]) + mp.mpf(lo[j]), mp.mpf(ref_hi[j]) + mp.mpf(ref_lo[j])
                    assert abs(ours - theirs) <= 2 * error * abs(theirs)  # (the reference's own split: 1 unit)


def test_pencil_counts_are_exact_where_certain() -> None:
    """`PencilCounts.counts` on 40 small rings (masses, springs over up to 1e12, B's entries not
    +-1, walls): at points 1e-20 relatively beside each eigenvalue and across 1e-40..1e20, a
    certain count lies between the true counts at x -+ `width(x)` (mpmath.eigsy of K~ at 80
    digits); 9 in 10 points are certain where the width resolves them; and the counts agree
    with `ring.counts.count_below` (numpy) wherever both are certain."""
    rng = np.random.default_rng(11)
    checked = certain_total = 0
    for _ in range(40):
        B, springs, mass, _ = small_ring(rng, (0.3, 6.0, 12.0))
        pencil = ring_counts.ring_pencil(sp.csr_matrix(B), springs, mass)
        assert pencil is not None
        form = PencilCounts(pencil)
        with mp.workdps(80):
            exact = sorted(mp.eigsy(mp_weighted_gram(B, springs, mass), eigvals_only=True))
            beside = [float(v * (1 + s * mp.mpf("1e-20"))) for v in exact if v > 0 for s in (-1, 1)]
            points = np.r_[beside, np.geomspace(1e-40, 1e20, 13)]
            width = form.width(points)
            low = [sum(1 for v in exact if v < mp.mpf(float(x)) - mp.mpf(float(d))) for x, d in zip(points, width)]
            high = [sum(1 for v in exact if v < mp.mpf(float(x)) + mp.mpf(float(d))) for x, d in zip(points, width)]
        count, certain = form.counts(points)
        assert np.all((np.array(low) <= count) & (count <= np.array(high)) | ~certain), (B.shape, springs, mass)
        reference, reference_certain = ring_counts.count_below(pencil, points)
        both = certain & reference_certain
        assert np.array_equal(count[both], reference[both])
        resolved = np.array(low) == np.array(high)
        checked += int(resolved.sum())
        certain_total += int((certain & resolved).sum())
    assert certain_total >= 0.9 * checked


def certified_values(n: int, spread: float, seed: int, shift: float = 0.0,
                     drop: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(mass, springs, values, bound): a dense solve's values of a disordered ring (each moved by
    `shift` relatively; `drop`: that value removed and the last repeated), through
    `counted.certify_values`."""
    mass, springs = disordered_ring(n, spread, seed)
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    B, w = ring.spring_factor()
    pencil = ring_counts.ring_pencil(B, w, mass)
    assert pencil is not None
    K = ring.hessian().toarray()
    values = np.linalg.eigvalsh(K / np.sqrt(np.outer(mass, mass))) * (1 + shift)
    if drop is not None:
        values = np.r_[values[:drop], values[drop + 1:], values[-1]]
    values[0] = 0.0
    bound = np.full(n, np.inf)
    bound[0] = 0.0
    counted.certify_values(pencil, values, bound, np.finfo(float).eps * pencil.R)
    return mass, springs, values, bound


@pytest.mark.parametrize(("spread", "seed"), [(0.0, 1), (0.3, 2), (2.0, 3)])
def test_every_certified_bound_covers_the_truth(spread: float, seed: int) -> None:
    """200-site rings (uniform: degenerate pairs sharing a bracket; disordered over 10^0.3, 10^2):
    every bound that `certify_values` gives covers the eigenvalue of its index (mpmath counts of
    the ring at 40 digits, `covered`); the mild ones within 1e-10 relative (omega^2)."""
    n = 200
    mass, springs, values, bound = certified_values(n, spread, seed)
    omega = np.sqrt(values)
    error = np.sqrt(values + bound) - omega  # (omega within that of omega_j)
    finite = np.isfinite(bound)
    assert finite.mean() >= 0.95
    if spread < 1:
        assert np.all(bound[1:] <= 1e-10 * values[1:])
    for j in np.flatnonzero(finite)[1:].tolist():
        assert covered(mass, springs, float(omega[j]), float(max(error[j], omega[j] - np.sqrt(values[j] - bound[j]))), j)


def test_values_off_by_more_than_the_levels_are_not_certified() -> None:
    """Values moved by 3e-11 relatively (between two levels): each bound covers the eigenvalue of
    its index (so none is smaller than its value's true error). Moved by 1e-8 (100 times "high"'s
    loosest level): none is certified. A value missing (the rest shifted down an index): none
    from the gap to the top is."""
    n = 200
    mass, springs, values, bound = certified_values(n, 0.3, 4, shift=3e-11)
    finite = np.flatnonzero(np.isfinite(bound))[1:]
    assert finite.shape[0] >= 0.9 * n
    for j in finite.tolist():
        assert covered(mass, springs, float(np.sqrt(values[j])), float(np.sqrt(values[j] + bound[j]) - np.sqrt(values[j])), j)
    _, _, _, bound = certified_values(n, 0.3, 4, shift=1e-8)
    assert not np.any(np.isfinite(bound[1:]))
    _, _, _, bound = certified_values(n, 0.3, 4, drop=100)
    assert not np.any(np.isfinite(bound[100:]))


def test_a_standard_solvers_missing_value_sends_the_ring_to_its_own_path() -> None:
    """`ring_band_counted` with a band result whose values skip one: the counts prove none of the
    values above the gap, more than `LOWEST_SHARE` of the ring, so None (the ring's own path runs)."""
    n = 200
    mass, springs = disordered_ring(n, 0.3, 6)
    ring = linear_chain(n, ends="periodic", mass=mass, stiffness=springs, units="dimensionless")
    B, w = ring.spring_factor()
    pencil = ring_counts.ring_pencil(B, w, mass)
    values = np.linalg.eigvalsh(ring.hessian().toarray() / np.sqrt(np.outer(mass, mass)))
    skipped = np.r_[values[:50], values[51:], values[-1]]
    result = SolveResult(skipped, None, np.zeros(n), 0.0, 0.0, "banded")
    assert counted.ring_band_counted(pencil, result) is None
    whole = counted.ring_band_counted(pencil, SolveResult(values, None, np.zeros(n), 0.0, 0.0, "banded"))
    assert whole is not None and np.all(np.isfinite(whole.error))


@pytest.mark.parametrize("n", [2000, 5000])
def test_high_takes_a_long_rings_band_values_each_bracketed(n: int) -> None:
    """A uniform ring of 2,000 and 5,000 sites, all frequencies at accuracy="high": the band
    solver's values bracketed by counts (at 5,000 its lowest values, ~eps ||K~|| off, from the
    ring's own path), every bound covering the closed form (30-digit mpmath) and within 1e-10 in
    omega^2; "certified" runs the ring's own values path, within 1e-13."""
    ring = linear_chain(n, ends="periodic", units="dimensionless")
    with mp.workdps(30):
        truth = np.sort(np.array([float(2 * abs(mp.sin(mp.pi * j / n))) for j in range(n)]))
    high = ring.modes(vectors=False)
    assert high.solver == "accurate-ring" and "from the band solver" in high.refinement
    true_error = np.maximum(np.abs(high.omega - truth) - 1e-16 * truth, 0.0)  # (truth to 1 ulp)
    assert np.all(true_error <= high.omega_error)
    assert np.all(high.omega_error[1:] <= 0.5e-10 * high.omega[1:])
    assert high.omega[0] == 0.0 and high.omega_error[0] == 0.0
    if n == 2000:
        certified = ring.modes(vectors=False, accuracy="certified")
        assert "from roots of the ring's spring form" in certified.refinement
        assert np.all(certified.omega_error[1:] <= 1e-13 * certified.omega[1:])


def test_a_walled_ring_above_the_dense_limit_is_bracketed_at_high() -> None:
    """A ring of 1,600 pendulums (a spring to a wall at every site, 10^0.3 disorder): "high" takes
    the band solver's values, each bound covering the truth (mpmath counts with the walls)."""
    from helpers.rings import walled_covered, walled_ring

    n = 1600
    B, w, mass, springs, ground = walled_ring(n, 0.3, 9)
    K = (B.T @ sp.diags(w) @ B).tocsr()
    modes = normal_modes(K, mass, spring_factor=(B, w), vectors=False)
    assert modes.solver == "accurate-ring" and "from the band solver" in modes.refinement
    assert np.all(modes.omega_error <= 0.5e-10 * modes.omega)
    rng = np.random.default_rng(3)
    for j in sorted({0, 1, 2, n - 1, *rng.choice(n, 6, replace=False).tolist()}):
        assert walled_covered(mass, springs, ground, float(modes.omega[j]), float(modes.omega_error[j]), j, 40)
