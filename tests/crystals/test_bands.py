"""vibra.crystals band structures (issue 30, item 3): paths, labels, connection, group velocities.

Truth: the geometry of the reciprocal lattice (X of fcc is 2 pi / a from Gamma along a cube
axis, L is pi sqrt(3) / a along a body diagonal); finite differences of the frequencies
themselves for the velocities; the smoothness of connected branches against sorted ones.
"""

from __future__ import annotations

import numpy as np
import pytest

from vibra import crystals

A = 4.0


def test_automatic_fcc_path_is_seekpaths_in_the_users_basis() -> None:
    crystal = crystals.fcc(A, 39.95, 1.2, units="ASE")
    bands = crystal.band_structure(npoints=300)
    names = [label for _, label in bands.labels]
    assert names[:3] == ["GAMMA", "X", "U"] and "L" in names and "W" in names
    points = {label: bands.qpoints[k] for k, label in bands.labels}
    k_x = points["X"] @ crystal.reciprocal
    k_l = points["L"] @ crystal.reciprocal
    assert np.linalg.norm(k_x) == pytest.approx(2 * np.pi / A, rel=1e-12)
    assert np.sort(np.abs(k_x)) == pytest.approx([0, 0, 2 * np.pi / A], abs=1e-12)  # along a cube axis
    assert np.linalg.norm(k_l) == pytest.approx(np.pi * np.sqrt(3) / A, rel=1e-12)
    assert bands.omega.shape == (300, 3) and bands.distances[0] == 0 and (np.diff(bands.distances) >= 0).all()
    assert len(bands.breaks) == 1  # U|K: seekpath's fcc path has one break


def test_two_dimensional_paths_stay_in_the_plane() -> None:
    square = crystals.square(1.0, 1.0, 1.0)
    assert [label for _, label in square.band_structure(npoints=60).labels] == ["GAMMA", "X", "M", "GAMMA"]
    honey = crystals.honeycomb(2.46, 12.0, 25.0, transverse=2.0, units="ASE")
    bands = honey.band_structure(npoints=90)
    assert [label for _, label in bands.labels] == ["GAMMA", "M", "K", "GAMMA"]
    assert np.abs(bands.qpoints[:, 2]).max() == 0.0


def test_given_path_with_labels_and_aliases() -> None:
    crystal = crystals.simple_cubic(1.0, 1.0, 1.0)
    bands = crystal.band_structure([["G", "X"], ["R", "Q"]], npoints=40, points={"Q": [0.25, 0.25, 0.25]})
    assert [label for _, label in bands.labels] == ["G", "X", "R", "Q"]
    assert bands.breaks == (bands.segments[1, 0],)
    np.testing.assert_allclose(bands.qpoints[bands.segments[0, 1]], [0.0, 0.5, 0.0])  # seekpath's X of cP
    with pytest.raises(ValueError, match=r"path\[1\]\[1\] is 'Z', not a known point of 'simple cubic'; known points: .*GAMMA"):
        crystal.band_structure([["G", "X"], ["R", "Z"]])
    with pytest.raises(ValueError, match=r"path\[0\] must be a list of at least 2 point labels"):
        crystal.band_structure([["G"]])
    with pytest.raises(ValueError, match=r"npoints is 3"):
        crystal.band_structure([["G", "X", "M"]], npoints=3)


def test_branches_are_connected_across_crossings_and_velocities_are_the_slopes() -> None:
    crystal = crystals.rock_salt(5.64, [22.99, 35.45], 2.0, shells=2, transverse=0.3, units="ASE")
    bands = crystal.band_structure([["GAMMA", "L"]], npoints=400)  # LA crosses TO on Gamma-L
    omega = bands.omega
    ascending = np.sort(omega, axis=1)
    assert np.abs(ascending - omega).max() > 1e-3 * omega.max()  # there are crossings to connect
    # connected branches are smooth: their second differences stay at the grid's O(h^2)
    # (measured: 1.4e-5 connected against 8.7e-4 sorted, which kink at the crossing)
    curvature = np.abs(np.diff(omega[5:], 2, axis=0)).max()
    kinks = np.abs(np.diff(ascending[5:], 2, axis=0)).max()
    assert curvature < kinks / 20
    # group velocities: central differences of the connected branches, O(h^2) ~ 1e-5 relative here
    step = np.diff(bands.distances)
    slope = (omega[2:] - omega[:-2]) / (step[1:] + step[:-1])[:, None]
    inner = bands.velocities[1:-1]
    scale = np.abs(bands.velocities).max()
    assert np.abs(slope[10:-10] - inner[10:-10]).max() < 1e-3 * scale


def test_group_velocities_agree_with_finite_differences_off_the_lines() -> None:
    crystal = crystals.diamond(5.43, [28.0, 12.0], 10.0, shells=2, transverse=[1.0, 0.5], units="ASE")
    q = np.array([[0.13, 0.27, 0.41]])
    direction = np.array([0.3, -0.5, 0.8])
    unit = direction / np.linalg.norm(direction)
    h = 1e-5  # rad / Angstrom; central differences: error O(h^2 omega''') ~ 1e-9 relative
    dq = h * unit @ crystal.cell.T / (2 * np.pi)  # fractional step of a Cartesian dk = h n
    numeric = (crystal.frequencies(q + dq) - crystal.frequencies(q - dq)) / (2 * h)
    analytic = crystals.group_velocities(crystal, q, direction)
    np.testing.assert_allclose(analytic, numeric, rtol=1e-6, atol=1e-8)
