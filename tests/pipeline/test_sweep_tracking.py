"""Sweep branches tracked by overlap (issue 31, item 2): crossings keep their labels, avoided
crossings give two smooth branches, degenerate points do not break the tracking.

Truth: closed forms of two oscillators (masses m, springs k1 and k2 to the walls, a coupling spring c
between them). Uncoupled: omega = sqrt(k1 / m) and sqrt(k2 / m), which cross at k1 = k2 (the branch
that starts as sqrt(k1 / m) must stay that one). Coupled: the eigenvalues of the 2x2
[[k1 + c, -c], [-c, k2 + c]] / m, lambda = (k1 + k2 + 2c -+ sqrt((k1 - k2)^2 + 4 c^2)) / (2 m), which
never cross (the lower branch stays the lower one while its shape turns from site 1 to site 2).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vibra import System
from vibra.charts import save_figure
from vibra.charts.sweep import sweep_figure
from vibra.pipeline.sweep import ensemble, grid, sweep, vary
from vibra.pipeline.sweep.tracking import BranchTracker

MASS, K2 = 2.0, 3.0
ANGLE = np.deg2rad(30.0)  # the pair seen in rotated coordinates: the eigensolver's basis at a degeneracy is arbitrary


def pair(k1: float, coupling: float = 0.0, rotated: bool = False) -> System:
    K = np.array([[k1 + coupling, -coupling], [-coupling, K2 + coupling]])
    if rotated:
        R = np.array([[np.cos(ANGLE), -np.sin(ANGLE)], [np.sin(ANGLE), np.cos(ANGLE)]])
        K = R @ K @ R.T
    return System.from_hessian([0.0, 1.0], MASS, K, units="dimensionless")


def rotated_pair(k1: float) -> System:
    return pair(k1, rotated=True)


def on_branch(table, branch: int) -> np.ndarray:
    return np.array([row.omega[list(row.branch).index(branch)] for row in table.rows])


@pytest.mark.parametrize("rotated", [False, True])
def test_an_exact_crossing_keeps_its_labels(rotated: bool) -> None:
    k1 = np.linspace(1.0, 5.0, 9)                      # crosses K2 = 3 at the 5th point, exactly on the grid
    table = sweep(rotated_pair if rotated else pair, grid({"k1": list(k1)}))
    np.testing.assert_allclose(on_branch(table, 0), np.sqrt(k1 / MASS), rtol=1e-12)
    np.testing.assert_allclose(on_branch(table, 1), np.sqrt(K2 / MASS), rtol=1e-12)
    # by rank the labels would swap: after the crossing branch 0 is the upper frequency
    assert [list(row.branch) for row in table.rows] == [[0, 1]] * 5 + [[1, 0]] * 4


def test_an_avoided_crossing_gives_two_smooth_branches() -> None:
    k1, c = np.linspace(1.0, 5.0, 41), 0.3
    table = sweep(pair, grid(vary("k1", 1.0, 5.0, 41), {"coupling": [c]}))
    root = np.sqrt((k1 - K2) ** 2 + 4 * c**2)
    np.testing.assert_allclose(on_branch(table, 0), np.sqrt((k1 + K2 + 2 * c - root) / (2 * MASS)), rtol=1e-12)
    np.testing.assert_allclose(on_branch(table, 1), np.sqrt((k1 + K2 + 2 * c + root) / (2 * MASS)), rtol=1e-12)
    # the character swaps: the lower branch's shape moves from site 1 to site 2 (closed-form eigenvector)
    lower = np.sqrt((k1 + K2 + 2 * c - root) / (2 * MASS)) ** 2 * MASS
    weight_site1 = c**2 / (c**2 + (k1 + c - lower) ** 2)
    assert weight_site1[0] > 0.95 and weight_site1[-1] < 0.05 and np.all(np.diff(weight_site1) < 0)


def test_a_degenerate_point_is_labelled_from_its_neighbours() -> None:
    # exactly at a crossing the two vectors may come in any basis of their plane (here rotated by 45
    # degrees, mixing both characters equally): the next point must still be matched right
    tracker = BranchTracker()
    rotation = np.array([[1.0, -1.0], [1.0, 1.0]]) / np.sqrt(2)
    assert tracker.add((), [1.0, 2.0], np.eye(2)).tolist() == [0, 1]
    assert sorted(tracker.add((), [1.5, 1.5], rotation).tolist()) == [0, 1]
    assert tracker.add((), [1.6, 2.0], np.eye(2)[:, ::-1]).tolist() == [1, 0]   # mode 0 is site 2's: branch 1
    assert tracker.add((), [1.7, 2.4], np.eye(2)[:, ::-1]).tolist() == [1, 0]


def test_a_crossing_between_grid_points_and_a_second_swept_key() -> None:
    table = sweep(pair, grid({"k1": list(np.linspace(1.1, 4.9, 8))}, {"coupling": [0.0, 0.3]}))
    lines = table.branch_lines()
    assert [dict(others)["coupling"] for others, _, _ in lines] == [0.0, 0.3]
    (_, x, free), (_, _, coupled) = lines
    np.testing.assert_allclose(free[:, 0], np.sqrt(x / MASS), rtol=1e-12)      # crosses: follows sqrt(k1/m)
    assert np.all(np.diff(coupled[:, 0]) > 0) and np.all(coupled[:, 0] < coupled[:, 1])   # stays below


def test_ensembles_and_untracked_sweeps_use_ranks() -> None:
    untracked = sweep(pair, grid({"k1": [1.0, 5.0]}), track=False)
    assert [list(row.branch) for row in untracked.rows] == [[0, 1], [0, 1]]
    members = sweep(lambda rng: pair(float(rng.uniform(1.0, 5.0))), ensemble(1, 2))
    assert all(list(row.branch) == [0, 1] for row in members.rows)


def test_changing_size_restarts_the_ranks() -> None:
    from vibra.chains import linear_chain

    table = sweep(linear_chain, grid({"n": [3, 4]}))
    assert [list(row.branch) for row in table.rows] == [[0, 1, 2], [0, 1, 2, 3]]


def test_branches_in_the_files_and_the_chart(tmp_path: Path) -> None:
    table = sweep(pair, grid({"k1": list(np.linspace(1.0, 5.0, 9))}, {"coupling": [0.0, 0.3]}))
    rows = list(csv.DictReader(table.to_csv(tmp_path / "t.csv").open()))
    free = [r for r in rows if float(r["coupling"]) == 0.0]          # the grid's first key varies slowest
    assert [(r["branch_0"], r["branch_1"]) for r in free] == [("0", "1")] * 5 + [("1", "0")] * 4
    assert all((r["branch_0"], r["branch_1"]) == ("0", "1") for r in rows if float(r["coupling"]) > 0)
    written = json.loads(table.to_json(tmp_path / "t.json").read_text())
    assert [r["branch"] for r in written["rows"]] == [list(map(int, row.branch)) for row in table.rows]
    figure, caption = sweep_figure(table)
    assert "one curve per branch" in caption
    path = save_figure(figure, tmp_path / "sweep.png")
    with Image.open(path) as image:
        assert np.asarray(image.convert("RGB")).std() > 5.0
    with pytest.raises(AttributeError):
        table.rows[0].branch = None  # type: ignore[misc]
    assert not table.rows[0].branch.flags.writeable


def pair_beside_a_degenerate_pair(k1: float) -> System:
    """The coupled pair (c = 0.3) beside two identical free oscillators (spring 10): a degeneracy all along."""
    c = 0.3
    K = np.zeros((4, 4))
    K[:2, :2] = [[k1 + c, -c], [-c, K2 + c]]
    K[2, 2] = K[3, 3] = 10.0
    return System.from_hessian([0.0, 1.0, 2.0, 3.0], MASS, K, units="dimensionless")


def test_a_degeneracy_present_all_along_does_not_stop_the_tracking() -> None:
    k1, c = np.linspace(1.0, 5.0, 41), 0.3
    table = sweep(pair_beside_a_degenerate_pair, grid({"k1": list(k1)}))
    root = np.sqrt((k1 - K2) ** 2 + 4 * c**2)
    np.testing.assert_allclose(on_branch(table, 0), np.sqrt((k1 + K2 + 2 * c - root) / (2 * MASS)), rtol=1e-12)
    np.testing.assert_allclose(on_branch(table, 1), np.sqrt((k1 + K2 + 2 * c + root) / (2 * MASS)), rtol=1e-12)
    for branch in (2, 3):
        np.testing.assert_allclose(on_branch(table, branch), np.sqrt(10.0 / MASS), rtol=1e-12)
