"""Sweeps (vibra.pipeline.sweep): grids over scene keys, seeded ensembles, tables, on 1 and 2 Dask workers.

Truth: the Montroll-Potts closed form for the localised mode of a light mass defect
(vibra.chains.montroll_potts_frequency, checked against the literature formula in
tests/chains/test_chains.py), numpy's own SeedSequence.spawn for the ensemble members, the csv and json
modules for the written tables, and invariance: the same seed gives the same table on 1 and
2 worker processes.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from vibra.chains import linear_chain, montroll_potts_frequency
from vibra.cluster import ClusterError
from vibra.pipeline.scene import SceneError, load_scene
from vibra.pipeline.sweep import SweepTable, ensemble, grid, member_rng, parse_vary, sweep, vary

DEFECT = Path(__file__).resolve().parents[2] / "chains" / "mass-defect.toml"
ROOT = DEFECT.parent.parent
SEED = 20261123


def disordered_chain(rng: np.random.Generator):
    """A free chain of 32 masses drawn uniformly from [0.5, 1.5] kg, springs 1 N/m."""
    return linear_chain(32, mass=rng.uniform(0.5, 1.5, size=32), stiffness=1.0)


def first_mass_and_top(system, modes):
    return {"m0": float(np.diag(np.atleast_2d(system.mass_matrix()))[0]) if np.ndim(system.mass_matrix()) == 2
            else float(np.asarray(system.mass_matrix())[0]), "omega_top": float(modes.omega[-1])}


def light_defect(rng: np.random.Generator):
    return {"system.defect_mass": float(rng.uniform(0.3, 0.6))}


def broken_builder(n: int):
    if n == 5:
        raise ValueError("no chain of 5")
    return linear_chain(n)


# ---------------------------------------------------------------- physics
def test_mass_defect_sweep_matches_montroll_potts_on_the_cluster(dask_client) -> None:
    axis = vary("system.defect_mass", 0.2, 0.7, 6)  # the scene's band [19.9, 40] rad/s holds these
    table = sweep(DEFECT, axis, client=dask_client)
    assert table.keys == ("system.defect_mass",) and table.units == "SI" and table.name == "mass-defect"
    np.testing.assert_array_equal(table.column("system.defect_mass"), np.linspace(0.2, 0.7, 6))
    scene = load_scene(DEFECT)
    k, m = scene.system.parameters["stiffness"], scene.system.parameters["mass"]
    for row in table.rows:
        exact = montroll_potts_frequency(2.0 * np.sqrt(k / m), m, dict(row.parameters)["system.defect_mass"])
        assert row.omega[-1] == pytest.approx(exact, rel=1e-10)       # the localised mode, above the band
        assert (row.omega[:-1] < 2.0 * np.sqrt(k / m)).all()        # the rest inside it
        assert row.solver and row.omega_error < 1e-9 * exact


def test_disorder_ensemble_same_table_on_one_and_two_workers(dask_client) -> None:
    members = ensemble(SEED, 200)
    two = sweep(disordered_chain, members, derive=first_mass_and_top, client=dask_client)
    one = sweep(disordered_chain, members, derive=first_mass_and_top, client="local", n_workers=1)
    assert one.json_text() == two.json_text()
    assert one.csv_text() == two.csv_text()
    assert [r.index for r in two.rows] == list(range(200))
    children = np.random.SeedSequence(SEED).spawn(200)               # numpy's own spawn
    for i in (0, 7, 199):
        assert two.rows[i].derived[0] == ("m0", np.random.default_rng(children[i]).uniform(0.5, 1.5, 32)[0])
    tops = two.column("omega_top")
    assert len(set(tops)) == 200                                       # 200 different members


def test_member_rng_is_the_spawned_child() -> None:
    children = np.random.SeedSequence(5).spawn(3)
    for i, child in enumerate(children):
        assert member_rng(5, i).random() == np.random.default_rng(child).random()


def test_scene_ensemble_draws_its_values_per_member() -> None:
    table = sweep(DEFECT, ensemble(3, 4, draw=light_defect))
    again = sweep(DEFECT, ensemble(3, 4, draw=light_defect))
    assert table.json_text() == again.json_text()
    for row in table.rows:
        defect = light_defect(member_rng(3, row.index))["system.defect_mass"]
        assert row.parameters == (("member", row.index), ("system.defect_mass", defect))
        assert row.omega[-1] == pytest.approx(montroll_potts_frequency(20.0, 1.0, defect), rel=1e-10)
    assert len({row.omega[-1] for row in table.rows}) == 4


def test_builder_grid_is_the_cartesian_product_in_order() -> None:
    table = sweep(linear_chain, grid({"n": [3, 4]}, {"stiffness": [1.0, 4.0]}))
    assert [dict(r.parameters) for r in table.rows] == [
        {"n": 3, "stiffness": 1.0}, {"n": 3, "stiffness": 4.0}, {"n": 4, "stiffness": 1.0}, {"n": 4, "stiffness": 4.0}]
    for row in table.rows:  # free chain: omega_k = 2 sqrt(k/m) sin(k pi / 2N), k = 0..N-1
        p = dict(row.parameters)
        exact = 2.0 * np.sqrt(p["stiffness"]) * np.sin(np.arange(p["n"]) * np.pi / (2 * p["n"]))
        np.testing.assert_allclose(row.omega, exact, atol=1e-12)


# ---------------------------------------------------------------- the table
def test_table_files_round_trip_and_are_frozen(tmp_path) -> None:
    table = sweep(DEFECT, vary("system.defect_mass", 0.2, 0.6, 3))
    csv_path, json_path = table.to_csv(tmp_path / "t.csv"), table.to_json(tmp_path / "t.json")
    rows = list(csv.DictReader(csv_path.open()))
    assert [float(r["system.defect_mass"]) for r in rows] == list(table.column("system.defect_mass"))
    assert [float(r["omega_2"]) for r in rows] == [row.omega[2] for row in table.rows]   # exact (repr)
    data = json.loads(json_path.read_text())
    assert data["keys"] == ["system.defect_mass"] and len(data["rows"]) == 3
    assert data["rows"][1]["omega"] == list(table.rows[1].omega)
    with pytest.raises(dataclasses.FrozenInstanceError):
        table.rows = ()  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        table.rows[0].omega[0] = 1.0
    assert isinstance(table, SweepTable)


def test_progress_line_per_point(capsys) -> None:
    sweep(DEFECT, vary("system.defect_mass", 0.2, 0.6, 3), progress=True)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 3 and lines[0].startswith("[1/3] point 0: system.defect_mass=0.2")


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize("call, error, match", [
    (lambda: sweep(DEFECT, vary("system.defect_mas", 0.2, 0.6, 3)), SceneError,
     r"system\.defect_mas: unknown key; did you mean 'defect_mass'\?"),
    (lambda: sweep(DEFECT, vary("defect_mass", 0.2, 0.6, 3)), SceneError, r"defect_mass: .*dotted path"),
    (lambda: vary("system.defect_mass", 0.2, 0.6, 0), ValueError, r"n is 0; an empty range has nothing to sweep"),
    (lambda: vary("system.defect_mass", 0.5, 0.5, 3), ValueError, r"start and stop are both 0\.5"),
    (lambda: vary("system.defect_mass", -1.0, 1.0, 3, spacing="log"), ValueError, r"log spacing needs positive"),
    (lambda: parse_vary("system.defect_mass=0.2:0.6"), ValueError, r"expected KEY=START:STOP:N"),
    (lambda: parse_vary("system.defect_mass=a:0.6:3"), ValueError, r"START and STOP must be numbers"),
    (lambda: parse_vary("system.defect_mass=0.2:0.6:0"), ValueError, r"an empty range"),
    (lambda: grid({"n": []}), ValueError, r"n: no values; an empty range"),
    (lambda: grid(vary("n", 2, 3, 2), vary("n", 2, 3, 2)), ValueError, r"n: the key is swept twice"),
    (lambda: sweep(DEFECT, ensemble(1, 3)), ValueError, r"an ensemble of a scene needs draw"),
    (lambda: sweep(DEFECT, {"system.defect_mass": [0.2]}, chunk_size=0), ValueError, r"chunk_size is 0"),
    (lambda: ensemble(1, 0), ValueError, r"n is 0; an ensemble needs at least 1 member"),
    (lambda: sweep(DEFECT, {"system.defect_mass": [0.2, -0.3]}), SceneError, r"system\.defect_mass: must be positive"),
    (lambda: sweep(42, {"n": [3]}), TypeError, r"target must be a scene file"),
    (lambda: sweep(DEFECT, vary("system.defect_mass", 0.2, 0.6, 3), client="nowhere"), ValueError,
     r"client is 'nowhere'"),
    (lambda: sweep(broken_builder, {"n": [4, 5]}), RuntimeError, r"sweep point point 1: n=5 failed: ValueError: no chain of 5"),
])
def test_bad_input_is_refused(call, error, match) -> None:
    with pytest.raises(error, match=match):
        call()


def test_every_point_is_validated_before_any_is_solved() -> None:
    solved: list[int] = []
    with pytest.raises(SceneError, match=r"system\.defect_mass: must be positive"):
        sweep(DEFECT, {"system.defect_mass": [0.2, 0.3, -1.0]}, progress=lambda done, total, label: solved.append(done))
    assert solved == []


def test_failing_point_on_the_cluster_is_named(dask_client) -> None:
    with pytest.raises(RuntimeError, match=r"1 of 3 sweep tasks failed: point 1: n=5: ValueError: no chain of 5"):
        sweep(broken_builder, {"n": [4, 5, 6]}, client=dask_client)
    with pytest.raises(RuntimeError, match=r"1 of 2 sweep tasks failed: points 0-1: RuntimeError: point 1: n=5: "
                       r"ValueError: no chain of 5"):
        sweep(broken_builder, {"n": [4, 5, 6]}, client=dask_client, chunk_size=2)


def test_chunks_give_the_same_table(dask_client) -> None:
    axis = vary("system.defect_mass", 0.2, 0.6, 7)
    assert (sweep(DEFECT, axis, client=dask_client, chunk_size=3).json_text()
            == sweep(DEFECT, axis, client=dask_client).json_text())


def test_unreachable_scheduler_fails_within_the_timeout(tmp_path, client_timeouts) -> None:
    with pytest.raises(ClusterError, match=r"tcp://127\.0\.0\.1:9"):
        sweep(DEFECT, vary("system.defect_mass", 0.2, 0.6, 3), client="tcp://127.0.0.1:9", timeout=1.0)
    assert client_timeouts == [1.0]


def test_sweep_chart_is_a_non_blank_png(tmp_path) -> None:
    from matplotlib.image import imread

    from vibra.charts import save_figure
    from vibra.charts.sweep import sweep_figure

    table = sweep(DEFECT, vary("system.defect_mass", 0.2, 0.6, 5))
    figure, caption = sweep_figure(table)
    path = save_figure(figure, tmp_path / "sweep.png")
    image = imread(path)
    assert image.shape[:2] == (600, 960) and image[..., :3].std() > 0.05
    assert "5 points of system.defect_mass" in caption


# ---------------------------------------------------------------------- issue 34: lazy, bounded grids
def test_a_lazy_range_gives_numpys_values() -> None:
    # truth: numpy.linspace and numpy.geomspace, value by value
    from vibra.pipeline.sweep import vary

    for spacing, reference in (("linear", np.linspace(0.2, 0.8, 1001)), ("log", np.geomspace(1e-3, 10.0, 1001))):
        low, high = (0.2, 0.8) if spacing == "linear" else (1e-3, 10.0)
        values = vary("k", low, high, 1001, spacing=spacing).values
        assert len(values) == 1001 and list(values) == pytest.approx(reference, rel=1e-15, abs=0)
        assert values[0] == low and values[-1] == high and values[3:5] == tuple(values)[3:5]


def test_a_billion_point_grid_is_not_built_in_memory() -> None:
    import tracemalloc

    from vibra.pipeline.sweep import grid, vary

    tracemalloc.start()
    try:
        points = grid(vary("a", 0.0, 1.0, 10**5), vary("b", 1.0, 2.0, 10**4)).points
        assert len(points) == 10**9
        assert points[0] == (0.0, 1.0) and points[-1] == (1.0, 2.0)
        assert points[10**4] == (pytest.approx(1 / (10**5 - 1), rel=1e-15), 1.0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20  # bytes, for 10^9 points


def test_grid_order_is_the_first_axis_slowest() -> None:
    import itertools

    from vibra.pipeline.sweep import grid

    points = grid({"a": [1.0, 2.0]}, {"b": [3.0, 4.0, 5.0]}).points
    assert list(points) == list(itertools.product([1.0, 2.0], [3.0, 4.0, 5.0]))
    assert [points[i] for i in range(len(points))] == list(points)


def test_the_tasks_of_a_large_grid_are_made_when_read() -> None:
    # issue 34: the task list of a sweep was built in memory (10^5 points: ~41 MiB of tuples and
    # labels before the first solve); now point i's task and label are made when read
    import tracemalloc

    from vibra.pipeline import sweep as sweep_module

    def builder(k: float) -> None:  # never called here
        raise AssertionError

    points = sweep_module.grid(sweep_module.vary("k", 1.0, 2.0, 1_000_001))
    tracemalloc.start()
    tasks, labels, _, _ = sweep_module._prepare(builder, points, {}, None)
    held = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    assert held < 1 << 20, held  # a million points: well under 1 MiB (a list of tuples takes ~200 MiB)
    assert len(tasks) == len(labels) == 1_000_001
    assert tasks[500_000] == (builder, 500_000, (("k", 1.5),), (("k", 1.5),))
    assert labels[-1] == "point 1000000: k=2" and tasks[1:3][1][1] == 2
    with pytest.raises(IndexError):
        tasks[1_000_001]


# ---------------------------------------------------------------------- what a sweep does not apply to
FPUT = ROOT / "dynamics" / "fput-alpha.toml"


@pytest.mark.parametrize("scene, key, low, high, match", [
    (ROOT / "crystals" / "argon-fcc.toml", "system.stiffness", 0.04, 0.06,
     r"argon-fcc\.toml: kind: a crystal scene has phonon branches over the wave vector"),
    (FPUT, "compute.dt", 0.05, 0.1, r"compute\.dt: changes only a dynamics scene's run: .* every point would be the same"),
    (FPUT, "draw.n_modes_drawn", 1, 3, r"draw\.n_modes_drawn: changes no solve"),
    # FPUT's alpha is the cubic term: the normal modes are the harmonic chain's at every alpha
    (FPUT, "system.alpha", 0.1, 0.3, r"system\.alpha: is an anharmonic term: it changes only the trajectory"),
])
def test_a_sweep_that_cannot_vary_the_table_is_refused_up_front(scene, key, low, high, match) -> None:
    with pytest.raises(SceneError, match=match):
        sweep(scene, vary(key, low, high, 3))


def test_a_sweep_whose_points_are_all_equal_warns() -> None:
    from vibra.pipeline.sweep import SweepWarning

    def chain_ignoring(label: float) -> object:  # a builder keyword that changes no mode
        return linear_chain(4)

    with pytest.warns(SweepWarning, match=r"all 3 points of label gave the same frequencies"):
        table = sweep(chain_ignoring, vary("label", 0.1, 0.3, 3))
    assert len(table.rows) == 3
    with warnings.catch_warnings():
        warnings.simplefilter("error", SweepWarning)  # a key that changes the modes: no warning
        sweep(DEFECT, vary("system.defect_mass", 0.2, 0.6, 3))
