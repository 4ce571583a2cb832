"""Tests of vibra/pipeline/plan/ and vibra/pipeline/report/: plans that compute only what a scene asks, and
the batch report (isolation, atomic outputs, skipping, summary.json, index.html)."""

from __future__ import annotations

import dataclasses
import html
import json
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from ase.data import atomic_masses, atomic_numbers
from PIL import Image

from vibra import molecules
from vibra.pipeline.plan import PlanResult, StepRecord, build_system, execute, make_plan
from vibra.pipeline.report import BatchResult, SceneOutcome, atomic_write_text, report, run_scene, spectrum_figure
from vibra.pipeline.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parents[2]
SMALL = [320, 200]


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text)
    return path


CHAIN = """kind = "chain"
title = "Small <chain> & co"
[system]
builder = "linear_chain"
n = 5
ends = "fixed"
[draw]
modes = true
n_draw = 2
spectrum = true
window_size = [320, 200]
"""

FAILING = """kind = "generalized"
[system]
builder = "matrices"
M = [[1.0, 2.0], [2.0, 1.0]]
K = [[1.0, 0.0], [0.0, 1.0]]
[draw]
modes = true
spectrum = true
"""  # valid schema, but M is not positive definite: fails while building


def pixels(path: Path) -> np.ndarray:
    with Image.open(path) as handle:
        handle.load()
        return np.asarray(handle.convert("RGB"))


# ---------------------------------------------------------------------- plans
def test_axial_co2_solves_three_dof_against_seed_eq_157(tmp_path: Path) -> None:
    scene = load_scene(ROOT / "molecules" / "co2-axial.toml")
    plan = make_plan(scene)
    result = execute(dataclasses.replace(plan, steps=plan.steps[:2]), tmp_path, tmp_path)
    modes = result.modes
    assert modes.n_dof == 3
    kappa = molecules.CO2_STRETCH
    m, M = atomic_masses[atomic_numbers["O"]], atomic_masses[atomic_numbers["C"]]
    expected = np.array([0.0, np.sqrt(kappa / m), np.sqrt(kappa * (1 / m + 2 / M))])
    # eq. 157 in ASE units; 1e-12 relative: a 3x3 eigenproblem loses only a few ulps of ||K~||.
    assert np.allclose(modes.omega, expected, rtol=1e-12, atol=1e-12 * expected.max())
    assert result.records[0].accuracy == "3 degrees of freedom"
    assert result.records[1].solver == modes.solver


def test_no_shapes_when_nothing_is_drawn(tmp_path: Path) -> None:
    scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 8},
                             "draw": {"spectrum": True, "window_size": SMALL}}, source="s.toml")
    plan = make_plan(scene)
    assert plan.vectors is False and "frequencies only" in plan.steps[1].what
    result = execute(plan, tmp_path, tmp_path)
    assert result.modes.shapes is None and result.modes.vectors is None
    assert result.outputs == ("s_spectrum.png",)


def test_partial_solver_for_the_lowest_modes(tmp_path: Path) -> None:
    n, k_modes = 20_000, 4
    scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": n, "ends": "fixed"},
                             "compute": {"n_modes": k_modes}}, source="l.toml")
    plan = make_plan(scene)
    assert plan.n_modes == k_modes and plan.step_names == ("build", "modes")
    modes = execute(plan, tmp_path, tmp_path).modes
    assert modes.n_modes == k_modes and modes.solver != "dense"
    k = np.arange(1, k_modes + 1)
    expected = 2.0 * np.sin(k * np.pi / (2 * (n + 1)))  # fixed chain, Omega = 1 (chains closed form)
    # 1e-9 relative: the accurate path keeps ~10 digits on the lowest modes of a long chain (DESIGN.md).
    assert np.allclose(modes.omega, expected, rtol=1e-9, atol=0)


def test_crosscheck_backends_imported_only_when_asked() -> None:
    code = """
import sys, tempfile
from pathlib import Path
from vibra.pipeline.plan import execute, make_plan
from vibra.pipeline.scene import load_scene
d = Path(tempfile.mkdtemp())
plan = make_plan(load_scene(sys.argv[1]))
execute(plan, d, d)
print('phonopy' in sys.modules, 'ase.vibrations' in sys.modules, 'pyvista' in sys.modules)
"""
    axial = ROOT / "molecules" / "co2-axial.toml"  # no cross-check asked; it draws modes
    run = subprocess.run([sys.executable, "-c", code, str(axial)], capture_output=True, text=True, check=True)
    assert run.stdout.split() == ["False", "False", "True"]


def test_plan_steps_for_a_full_chain_scene() -> None:
    plan = make_plan(load_scene(ROOT / "chains" / "forced-damped.toml"))
    assert plan.step_names == ("build", "modes", "response", "chart-spectrum", "chart-response")
    plan = make_plan(load_scene(ROOT / "molecules" / "co2.toml"))
    assert plan.step_names[:3] == ("build", "modes", "crosscheck")


def test_mass_defect_builds_the_defect(tmp_path: Path) -> None:
    scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 5, "defect_site": 2,
                                                          "defect_mass": 0.25}}, source="d.toml")
    system = build_system(scene)
    assert list(system.masses) == [1.0, 1.0, 0.25, 1.0, 1.0]


def test_result_records_are_immutable(tmp_path: Path) -> None:
    record = StepRecord(name="modes", what="all", seconds=0.1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        record.seconds = 0.0  # type: ignore[misc]
    result = PlanResult(records=(record,), outputs=(), captions=(), frequencies=())
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.outputs = ("x",)  # type: ignore[misc]
    outcome = SceneOutcome(source="a", name="a", title="a", status="ok")
    with pytest.raises(dataclasses.FrozenInstanceError):
        outcome.status = "failed"  # type: ignore[misc]
    batch = BatchResult(out_dir=tmp_path, outcomes=(outcome,), seconds=0.0, jobs=1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        batch.jobs = 2  # type: ignore[misc]


# ---------------------------------------------------------------------- batch
def test_report_outputs_summary_and_index(tmp_path: Path) -> None:
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    write(scenes, "small.toml", CHAIN)
    out = tmp_path / "out"
    result = report([scenes], out, progress=False)
    [outcome] = result.outcomes
    assert outcome.status == "ok", outcome.error
    assert outcome.outputs == ("small_modes.png", "small_view.json", "small_spectrum.png")
    picture = pixels(out / "small_modes.png")
    assert picture.shape == (200, 320, 3) and picture.std() > 5.0  # not blank (see tests/pipeline/test_render.py)
    assert pixels(out / "small_spectrum.png").std() > 5.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_scenes"] == 1 and summary["n_failed"] == 0
    entry = summary["scenes"][0]
    assert entry["name"] == "small" and entry["outputs"] == list(outcome.outputs)
    steps = {s["name"]: s for s in entry["steps"]}
    assert steps["modes"]["solver"] and "residual" in steps["modes"]["accuracy"]
    assert all(s["seconds"] >= 0 for s in entry["steps"])
    index = (out / "index.html").read_text()
    assert "Small &lt;chain&gt; &amp; co" in index and "<chain>" not in index
    assert "href='scenes/small.html'" in index and "src='small_modes.png'" in index  # the thumbnail
    page = (out / "scenes" / "small.html").read_text()
    assert "Small &lt;chain&gt; &amp; co" in page and "<chain>" not in page
    for name in outcome.outputs:
        if name.endswith(".png"):
            assert f"src='../{name}'" in page
    assert "class='view-data'" in page and "src='../assets/3Dmol-min.js'" in page
    assert not (out / ".work").exists()
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "assets", "index.html", "references.html", "scenes", "small_modes.png", "small_spectrum.png",
        "small_view.json", "summary.json"]


def test_failing_scene_does_not_stop_others_and_leaves_nothing(tmp_path: Path) -> None:
    good = write(tmp_path, "good.toml", CHAIN)
    bad = write(tmp_path, "bad.toml", FAILING)
    broken = ROOT / "tests" / "broken_scenes" / "typo-key.toml"
    out = tmp_path / "out"
    unreadable = write(tmp_path, "empty.toml", "")  # readable, but no scene: fails alone
    result = report([bad, good, broken, unreadable], out, progress=False)
    status = {o.name: o for o in result.outcomes}
    assert status["good"].status == "ok"
    assert status["bad"].status == "failed" and "not positive definite" in status["bad"].error
    assert status["typo-key"].status == "failed" and "did you mean 'stiffness'" in status["typo-key"].error
    assert status["empty"].status == "failed" and "kind: is required" in status["empty"].error
    assert len(result.failed) == 3
    assert not list(out.glob("bad_*")) and not list(out.glob("typo-key*"))
    assert not (out / ".work").exists()
    table = result.table()
    assert "bad" in table and "failed" in table and "3 failed" in table


def test_a_missing_path_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    # Issue 16: a typo used to count as a failed scene and rewrite index.html and summary.json
    # with that one entry. Now nothing is touched: not even the output folder is created.
    good = write(tmp_path, "good.toml", CHAIN)
    out = tmp_path / "out"
    with pytest.raises(FileNotFoundError, match=r"missing\.toml: no such file or folder"):
        report([good, tmp_path / "missing.toml"], out, progress=False)
    assert not out.exists()


def test_unchanged_scenes_are_skipped_until_forced_or_edited(tmp_path: Path) -> None:
    path = write(tmp_path, "small.toml", CHAIN)
    out = tmp_path / "out"
    first = run_scene(path, out)
    assert first.status == "ok"
    again = run_scene(path, out)
    assert again.status == "skipped" and again.outputs == first.outputs
    assert run_scene(path, out, force=True).status == "ok"
    path.write_text(CHAIN.replace("n = 5", "n = 6"))
    assert run_scene(path, out).status == "ok"
    (out / "small_modes.png").unlink()  # an output removed by hand: redo
    assert run_scene(path, out).status == "ok"


def test_duplicate_scene_names_fail(tmp_path: Path) -> None:
    a = write(tmp_path, "a.toml", CHAIN.replace('kind = "chain"', 'kind = "chain"\nname = "same"'))
    b = write(tmp_path, "b.toml", CHAIN.replace('kind = "chain"', 'kind = "chain"\nname = "same"'))
    result = report([a, b], tmp_path / "out", progress=False)
    assert [o.status for o in result.outcomes] == ["ok", "failed"]
    assert "scene name 'same' is already used" in result.outcomes[1].error


def test_report_argument_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"jobs is 0; expected jobs >= 1"):
        report([tmp_path], tmp_path / "out", jobs=0)
    with pytest.raises(TypeError, match=r"jobs must be an int, got str"):
        report([tmp_path], tmp_path / "out", jobs="2")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"paths holds no scene file"):
        report([tmp_path], tmp_path / "out")


def test_atomic_write_text(tmp_path: Path) -> None:
    target = atomic_write_text(tmp_path / "a" / "b.txt", "hello")
    assert target.read_text() == "hello"
    assert [p.name for p in target.parent.iterdir()] == ["b.txt"]


def test_oscillator_and_generalized_scenes(tmp_path: Path) -> None:
    osc = write(tmp_path, "osc.toml", """kind = "oscillator"
title = "Seed figure 7"
[system]
builder = "oscillator"
w0 = 1.0
gamma = [0.5, 1.0, 2.0, 4.0]
[compute.response]
omega_min = 0.0
omega_max = 3.0
[draw]
response = true
""")
    gen = write(tmp_path, "gen.toml", FAILING.replace("[[1.0, 2.0], [2.0, 1.0]]", "[[2.0, 1.0], [1.0, 2.0]]"))
    result = report([osc, gen], tmp_path / "out", progress=False)
    assert [o.status for o in result.outcomes] == ["ok", "ok"], [o.error for o in result.outcomes]
    assert result.outcomes[0].outputs == ("osc_response.png",)
    assert result.outcomes[1].outputs == ("gen_modes.png", "gen_spectrum.png")
    for outcome in result.outcomes:
        for name in outcome.outputs:
            assert pixels(tmp_path / "out" / name).std() > 5.0


# ---------------------------------------------------------------------- charts
@pytest.mark.parametrize("file_name", ["chains/monatomic-free.toml", "molecules/h2o.toml", "chains/mass-defect.toml",
                                       "chains/long-chain.toml"])
def test_spectrum_labels_are_distinct_apart_and_inside(file_name: str) -> None:
    # Regression: close sticks (H2O's two stretches, the top of a chain's band, the two
    # modes at the band edge of the mass-defect chain) had overlapping or identical labels,
    # and the outermost ones were cut at the axes edge. Checked on the drawn text boxes.
    scene = load_scene(ROOT / file_name)
    if scene.system.builder == "linear_chain" and scene.system.parameters["n"] > 1000:
        system = build_system(dataclasses.replace(scene, system=dataclasses.replace(
            scene.system, parameters={**scene.system.parameters, "n": 2000})))  # same labels, fast
    else:
        system = build_system(scene)
    modes = system.modes(scene.compute.n_modes, band=scene.compute.band, vectors=False)
    figure, _ = spectrum_figure(scene, modes)
    renderer = figure.canvas.get_renderer()
    axes = figure.axes[0]
    labels = [t for t in axes.texts if t.get_text()]
    assert len(labels) == int((~modes.zero_modes(1e-6)).sum())  # one per non-zero stick here
    assert len({t.get_text() for t in labels}) == len(labels)
    boxes = [t.get_window_extent(renderer) for t in labels]
    frame = axes.get_window_extent(renderer)
    for a, box in enumerate(boxes):
        assert frame.x0 <= box.x0 and box.x1 <= frame.x1 and box.y1 <= frame.y1, labels[a].get_text()
        for other in boxes[a + 1:]:
            assert not box.overlaps(other), (labels[a].get_text(), box, other)


def test_response_chart_names_scene_and_receptance_unit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The generic FRF chart labels |x| in "length"; a report of an SI scene says m/N.
    import vibra.pipeline.plan.steps

    seen = []
    monkeypatch.setattr(vibra.pipeline.plan.steps, "_save_chart",
                        lambda context, figure, what, caption: seen.append(figure))
    scene = load_scene(ROOT / "chains" / "forced-damped.toml")
    plan = make_plan(dataclasses.replace(scene, draw=dataclasses.replace(scene.draw, spectrum=False)))
    execute(plan, tmp_path, tmp_path)
    [figure] = seen
    assert "(m/N)" in figure.axes[0].get_ylabel() and "length" not in figure.axes[0].get_ylabel()
    assert figure.axes[0].get_title().startswith(scene.title)


def test_oscillator_chart_in_si_units(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The generic oscillator chart says "rad / time unit" and "length"; an SI scene says rad/s and m.
    import vibra.pipeline.plan.steps

    seen = []
    monkeypatch.setattr(vibra.pipeline.plan.steps, "_save_chart",
                        lambda context, figure, what, caption: seen.append(figure))
    scene = Scene.from_dict({"kind": "oscillator", "system": {"builder": "oscillator", "w0": 1.0, "gamma": 0.5},
                             "draw": {"response": True}},
                            source="osc.toml")
    execute(make_plan(scene), tmp_path, tmp_path)
    [figure] = seen
    assert [a.get_xlabel() for a in figure.axes[:2]] == ["driving angular frequency $\\omega$ (rad/s)"] * 2
    assert figure.axes[0].get_ylabel().endswith("(m)")


# ---------------------------------------------------------------------- failures
def test_empty_band_fails_with_a_clear_message(tmp_path: Path) -> None:
    path = write(tmp_path, "empty.toml", """kind = "chain"
[system]
builder = "linear_chain"
n = 4
[compute]
band = [100.0, 200.0]
[draw]
spectrum = true
""")  # omega of a 4-mass free chain with unit springs and masses stays below 2 rad/s
    outcome = run_scene(path, tmp_path / "out")
    assert outcome.status == "failed"
    assert "compute.band: no mode has omega in [100, 200] rad/s" in outcome.error


def test_failure_after_an_image_was_drawn_publishes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The modes image is rendered (into the scene's work folder) before the spectrum step
    # fails: the output folder must get neither that image nor a manifest.
    import vibra.pipeline.plan.steps

    rendered = []
    render_step = vibra.pipeline.plan.steps.STEPS["render-modes"]

    def render_and_remember(plan: object, context: object, renderer: object) -> tuple[None, None]:
        result = render_step(plan, context, renderer)
        rendered.extend(context.out_dir / name for name in context.outputs)  # type: ignore[attr-defined]
        return result

    def fail(plan: object, context: object, renderer: object) -> None:
        assert all(path.is_file() for path in rendered) and rendered  # drawn, not yet published
        raise RuntimeError("disk full")

    monkeypatch.setitem(vibra.pipeline.plan.steps.STEPS, "render-modes", render_and_remember)
    monkeypatch.setitem(vibra.pipeline.plan.steps.STEPS, "chart-spectrum", fail)
    path = write(tmp_path, "late.toml", CHAIN)
    out = tmp_path / "out"
    outcome = run_scene(path, out)
    assert outcome.status == "failed" and "RuntimeError: disk full" in outcome.error
    assert [p.name for p in rendered] == ["late_modes.png", "late_view.json"]
    assert [p.name for p in out.iterdir() if not p.name.startswith(".")] == []
    assert not list(out.rglob("*.png")) and not list(out.glob("*.json")) and not (out / ".vibra" / "late.json").exists()


# ---------------------------------------------------------------------- one atomic writer
@pytest.fixture
def umask_027() -> object:
    """Run with umask 027 (files 0640), restored afterwards."""
    import os

    previous = os.umask(0o027)
    yield
    os.umask(previous)


def test_every_writer_gives_files_the_umask_mode(tmp_path: Path, umask_027: object) -> None:
    # Truth: what open() gives a new file under the same umask (0666 & ~027 = 0640).
    import os
    import stat

    from vibra._core import filesystem as _io
    from vibra.charts import new_figure, save_figure
    from vibra.pipeline.render import write_gif, write_png

    reference = tmp_path / "reference"
    reference.write_text("x")
    expected = stat.S_IMODE(reference.stat().st_mode)
    assert expected == 0o640
    frame = np.zeros((8, 8, 3), dtype=np.uint8)
    figure, _ = new_figure()
    written = [_io.atomic_write_text(tmp_path / "a.txt", "a"), _io.atomic_write_bytes(tmp_path / "b.bin", b"b"),
               save_figure(figure, tmp_path / "c.png"), write_png(frame, tmp_path / "d.png"),
               write_gif([frame, frame], tmp_path / "e.gif"), atomic_write_text(tmp_path / "f.txt", "f")]
    for path in written:
        assert stat.S_IMODE(os.stat(path).st_mode) == expected, path.name


def test_report_outputs_get_the_umask_mode(tmp_path: Path) -> None:
    # Every file `vibra report` writes (images, summary.json, index.html, manifests) gets
    # 0666 & ~umask, 0644 under umask 022: no 0600 images beside 0644 summaries.
    import os
    import stat

    previous = os.umask(0o022)
    try:
        write(tmp_path, "small.toml", CHAIN)
        out = tmp_path / "out"
        result = report([tmp_path / "small.toml"], out, progress=False)
    finally:
        os.umask(previous)
    assert result.outcomes[0].status == "ok", result.outcomes[0].error
    files = [p for p in out.rglob("*") if p.is_file()]
    assert {p.name for p in files} >= {"small_modes.png", "small_spectrum.png", "summary.json", "index.html",
                                       "small.json"}
    for path in files:
        assert stat.S_IMODE(path.stat().st_mode) == 0o644, path


@pytest.mark.parametrize("error", [OSError("disk full"), KeyboardInterrupt()])
def test_atomic_write_cleans_up_and_keeps_the_old_file(tmp_path: Path, error: BaseException) -> None:
    from vibra._core.filesystem import atomic_write

    target = tmp_path / "result.png"
    target.write_bytes(b"old complete file")

    def write_half_then_fail(temporary: Path) -> None:
        temporary.write_bytes(b"half of a new")
        raise error

    with pytest.raises(type(error)):
        atomic_write(target, write_half_then_fail)
    assert target.read_bytes() == b"old complete file"
    assert [p.name for p in tmp_path.iterdir()] == ["result.png"]  # no temporary file left


def test_atomic_write_is_a_rename_in_the_target_folder(tmp_path: Path) -> None:
    from vibra._core.filesystem import atomic_write

    seen = []
    atomic_write(tmp_path / "sub" / "x.txt", lambda temporary: (seen.append(temporary), temporary.write_text("x")))
    assert seen[0].parent == tmp_path / "sub" and seen[0].name.startswith(".x.txt.")
    assert (tmp_path / "sub" / "x.txt").read_text() == "x" and not seen[0].exists()


# ---------------------------------------------------------------------- charts
def test_charts_leave_the_matplotlib_backend_alone() -> None:
    # A session's backend (a notebook's inline one, here 'svg') stays as it was, and pyplot is
    # never imported: figures draw on their own Agg canvas.
    code = """
import sys, tempfile, pathlib
import matplotlib
before = matplotlib.get_backend()
from vibra import chains
from vibra.charts import save_figure
from vibra.charts.chains import plot_dispersion
from vibra.continuum import dispersion_curves
from vibra.charts.modes import spectrum_figure
from vibra.pipeline.scene import Scene
system = chains.linear_chain(6)
modes = system.modes()
scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 6}}, source="s.toml")
figure, _ = spectrum_figure(scene, modes)
save_figure(figure, pathlib.Path(tempfile.mkdtemp()) / "s.png")
png = plot_dispersion(dispersion_curves(modes=modes))._repr_png_()
print(before, matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules, png[:4] == b"\\x89PNG")
"""
    import os

    env = {**os.environ, "MPLBACKEND": "svg"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env,
                         cwd=ROOT).stdout
    assert out.split() == ["svg", "svg", "False", "True"]


def test_dispersion_step_computes_what_the_chart_draws(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Truth: the monatomic chain's closed form omega = 2 sqrt(kappa/m) |sin(q a / 2)|; each mode
    # of the finite chain sits on it at its assigned wavenumber (exact for a uniform chain).
    import vibra.pipeline.plan.steps

    drawn = []
    monkeypatch.setattr(vibra.pipeline.plan.steps, "_save_chart",
                        lambda context, figure, what, caption: drawn.append(what))
    scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 12, "mass": 2.0,
                                                         "stiffness": 8.0, "spacing": 0.5, "ends": "fixed"},
                             "draw": {"dispersion": True}}, source="d.toml")
    plan = make_plan(scene)
    assert plan.step_names == ("build", "modes", "dispersion", "chart-dispersion")
    seen = {}
    original = vibra.pipeline.plan.steps.STEPS["chart-dispersion"]

    def remember(plan: object, context: object, renderer: object) -> object:
        seen["curves"] = context.dispersion  # type: ignore[attr-defined]
        return original(plan, context, renderer)  # type: ignore[arg-type]

    monkeypatch.setitem(vibra.pipeline.plan.steps.STEPS, "chart-dispersion", remember)
    execute(plan, tmp_path, tmp_path)
    curves = seen["curves"]
    assert drawn == ["dispersion"]
    assert np.allclose(curves.omega[0], 2.0 * np.sqrt(8.0 / 2.0) * np.abs(np.sin(curves.q * 0.5 / 2.0)))
    assert curves.q[-1] == pytest.approx(np.pi / 0.5)
    assert np.allclose(curves.mode_omega, 2.0 * np.sqrt(8.0 / 2.0) * np.sin(curves.mode_wavenumbers * 0.5 / 2.0), rtol=1e-9)
    assert curves.n_sites == 12 and curves.ends == "fixed"
    with pytest.raises(ValueError):
        curves.q[0] = 1.0  # frozen result


def test_banded_solver_scene_runs(tmp_path: Path) -> None:
    # 'banded' (one of vibra.modes.SOLVERS) was missing from the schema; a scene asking for it
    # now runs, and matches the free chain's closed form omega_k = 2 Omega sin(k pi / 2N).
    scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 9},
                             "compute": {"solver": "banded"}}, source="banded.toml")
    result = execute(make_plan(scene), tmp_path, tmp_path)
    assert result.modes.solver == "banded"
    # compared as omega^2: a dense-type solver gets eigenvalues to about eps ||K~|| absolutely
    omega = result.modes.omega
    assert np.allclose(omega * np.abs(omega), (2.0 * np.sin(np.arange(9) * np.pi / 18.0)) ** 2, rtol=0, atol=1e-13)


def test_molecule_symmetry_is_computed_by_the_plan_and_drawn(tmp_path: Path) -> None:
    # Mutual exclusion for centrosymmetric CO2 (seed 003 Example 11), in the textbook labels of
    # D_inf_h (Herzberg; issue 12): the bend Pi_u and the asymmetric stretch Sigma_u+ are IR-active
    # and Raman-inactive, the symmetric stretch Sigma_g+ the reverse. The plan's symmetry step
    # computes it; the captions of the rendered images carry it.
    scene = Scene.from_dict({"kind": "molecule", "system": {"builder": "co2", "dims": 3},
                             "draw": {"modes": True, "window_size": SMALL}}, source="co2.toml")
    plan = make_plan(scene)
    assert plan.step_names == ("build", "modes", "symmetry", "structure", "render-modes")
    result = execute(plan, tmp_path, tmp_path)
    [structure] = [r for r in result.records if r.name == "structure"]
    assert structure.accuracy == "2 bonds"
    [symmetry] = [r for r in result.records if r.name == "symmetry"]
    assert "point group Dinfh" in (symmetry.accuracy or "")
    captions = dict(zip(result.outputs, result.captions))
    assert "Pi_u (Dinfh): IR active, Raman inactive" in captions["co2_mode5.png"]
    assert "degenerate" in captions["co2_mode5.png"]
    assert "Sigma_g+ (Dinfh): IR inactive, Raman active" in captions["co2_mode7.png"]
    assert "Sigma_u+ (Dinfh): IR active, Raman inactive" in captions["co2_mode8.png"]
    assert "IR active (point charges" in captions["co2_mode8.png"]


@pytest.mark.parametrize("builder, parameters, observed", [
    # Shimanouchi (1972) via NIST CCCBDB, the source the data module cites
    ("co2", {"dims": 3}, {"Pi_u": "nu2 667", "Sigma_g+": "nu1 1333", "Sigma_u+": "nu3 2349"}),
    ("h2o", {}, {"A1": "nu2 1595", "B2": "nu3 3756"}),
    ("h2o", {"isotopes": ["", "D", "D"]}, {"A1": "nu2 1178", "B2": "nu3 2788"}),
    ("molecule", {"name": "CH4"}, {"T2": "nu4 1306", "E": "nu2 1534", "A1": "nu1 2917"}),
])
def test_frequency_table_has_species_and_observed_fundamentals(tmp_path: Path, builder: str,
                                                               parameters: dict, observed: dict) -> None:
    scene = Scene.from_dict({"kind": "molecule", "system": {"builder": builder, **parameters}},
                            source="m.toml")
    result = execute(make_plan(scene), tmp_path, tmp_path)
    table = "\n".join(result.frequencies)
    assert "NSRDS-NBS 39" in table and "Shimanouchi" in table
    from vibra.pipeline.plan.tables import species_text

    for species, text in observed.items():  # the report's table is Unicode: Πu, ν2 (the CLI's may be ASCII)
        unicode = species_text(species), text.replace("nu", "ν")
        assert any(unicode[0] in line and unicode[1] in line for line in result.frequencies), (species, text, table)


# ---------------------------------------------------------------------- pages and 3-D views
class _Links(HTMLParser):
    """Every src and href of a page (and whether it loads anything from the network)."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.links += [value for name, value in attrs if name in ("src", "href") and value]


def page_links(page: Path) -> list[str]:
    parser = _Links()
    parser.feed(page.read_text(encoding="utf-8"))
    return parser.links


def test_chain_view_holds_the_closed_form_shapes(tmp_path: Path) -> None:
    # Fixed chain of 5 equal masses: mode j moves site s as sin(s j pi / 6) (Kneller, Mécanique
    # analytique, section 5.3); the view keeps that shape along x, its largest motion MAX_MOTION of a spring.
    from vibra.pipeline.plan.views import CHAIN_SPACING, MAX_MOTION, mode_view

    scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 5, "ends": "fixed"},
                             "draw": {"modes": True, "n_draw": 2, "window_size": SMALL}}, source="s.toml")
    system = build_system(scene)
    modes = system.modes()
    view = mode_view(scene, system, modes, [0, 1])
    assert view is not None and view["style"] == "chain" and view["bonds"] == [[0, 1], [1, 2], [2, 3], [3, 4]]
    x = np.array(view["positions"])[:, 0]
    assert np.allclose(np.diff(x), CHAIN_SPACING)
    sites = np.arange(1, 6)
    for j, mode in enumerate(view["modes"], start=1):
        vectors = np.array(mode["vectors"])
        assert np.allclose(vectors[:, 1:], 0.0)
        expected = np.sin(sites * j * np.pi / 6)
        expected *= MAX_MOTION * CHAIN_SPACING / np.abs(expected).max()
        assert np.allclose(np.abs(vectors[:, 0]), np.abs(expected), atol=1e-4)  # rounded to 4 decimals
        assert np.allclose(vectors[:, 0] * np.sign(vectors[0, 0]), expected, atol=1e-4)
        assert mode["label"].startswith(f"mode {j}: ")  # numbered from the lowest, as the table


def test_report_pages_navigate_offline_and_name_sources(tmp_path: Path) -> None:
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    write(scenes, "small.toml", CHAIN)
    write(scenes, "bad.toml", FAILING)
    (scenes / "water.toml").write_text((ROOT / "molecules" / "h2o.toml").read_text()
                                       + "window_size = [320, 200]\n")
    out = tmp_path / "out"
    report([scenes, ROOT / "molecules" / "co2-axial.toml"], out, progress=False, window_size=SMALL)
    pages = [out / "index.html", out / "references.html", *sorted((out / "scenes").glob("*.html"))]
    assert [p.name for p in pages[2:]] == ["bad.html", "co2-axial.html", "small.html", "water.html"]
    for page in pages:
        text = page.read_text(encoding="utf-8")
        assert "seed 0" not in text.lower(), page
        for link in page_links(page):
            assert "://" not in link and not link.startswith("//"), (page, link)  # offline: no URL
            target = (page.parent / link.split("#")[0]).resolve()
            assert target.is_file() and out.resolve() in target.parents, (page, link)
    index = (out / "index.html").read_text()
    links = page_links(out / "index.html")
    for name in ("small", "bad", "water", "co2-axial"):
        assert f"scenes/{name}.html" in links  # one click from the index, the figures on that page
    assert index.index(">Chains<") < index.index(">Molecules<") < index.index(">Generalised systems<")
    co2 = (out / "scenes" / "co2-axial.html").read_text()
    assert "Kneller, Mécanique analytique, example 11" in co2
    water = (out / "scenes" / "water.html").read_text()
    assert "<details><summary>How it was computed" in water and "<h2>Frequencies</h2>" in water
    assert "<figcaption>H2O:" not in water  # the caption does not repeat the title
    view = json.loads((out / "water_view.json").read_text())
    assert view["elements"] == ["O", "H", "H"] and sorted(map(sorted, view["bonds"])) == [[0, 1], [0, 2]]
    assert [m["label"] for m in view["modes"]][0].startswith("ν2: 159") and len(view["modes"]) == 3
    assert [m["label"].split("cm⁻¹, ")[1] for m in view["modes"]] == ["A1 (C2v)", "A1 (C2v)", "B2 (C2v)"]
    assert "not positive definite" in (out / "scenes" / "bad.html").read_text()
    references = (out / "references.html").read_text()
    from vibra.sources import SOURCES

    assert all(html.escape(s.full()) in references for s in SOURCES.values())
    vendored = out / "assets" / "3Dmol-min.js"
    assert vendored.stat().st_size > 100_000 and "BSD" in (out / "assets" / "3Dmol-LICENSE.txt").read_text()
    # A later run of one scene keeps the others' pages; a scene gone from the folder loses its page.
    (out / "water_mode6.png").unlink()
    report([scenes / "small.toml"], out, progress=False, window_size=SMALL)
    assert sorted(p.name for p in (out / "scenes").glob("*.html")) == ["bad.html", "co2-axial.html", "small.html"]


def test_a_file_where_the_pages_go_is_refused_before_any_work(tmp_path: Path) -> None:
    scene = write(tmp_path, "small.toml", CHAIN)
    for name in ("scenes", "assets"):
        out = tmp_path / f"out-{name}"
        out.mkdir()
        (out / name).write_text("mine")
        with pytest.raises(NotADirectoryError, match=f"{name} is not a folder; vibra writes its report pages"):
            report([scene], out, progress=False)
        assert sorted(p.name for p in out.iterdir()) == [name]  # nothing written
    out = tmp_path / "out-references"
    (out / "references.html").mkdir(parents=True)
    with pytest.raises(NotADirectoryError, match="references.html is a folder"):
        report([scene], out, progress=False)


# ---------------------------------------------------------------------- layers
def _vibra_modules() -> dict[str, Path]:
    """Dotted module name -> source file, for every module of the vibra package."""
    modules = {}
    for path in (ROOT / "vibra").rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _vibra_imports() -> dict[str, set[str]]:
    """module -> the vibra modules it imports anywhere (function bodies included), from the source;
    an ``if TYPE_CHECKING:`` block is no import at run time (annotations only), so not an edge."""
    import ast

    def runtime_nodes(tree: ast.AST) -> list[ast.AST]:
        found, stack = [], [tree]
        while stack:
            node = stack.pop()
            if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
                stack.extend(node.orelse)
                continue
            found.append(node)
            stack.extend(ast.iter_child_nodes(node))
        return found

    modules = _vibra_modules()
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        for node in runtime_nodes(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in modules else node.module
                           for a in node.names]
            else:
                continue
            for target in targets:
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target.startswith("vibra") and target != name:
                    graph[name].add(target)
    return graph


def test_no_import_cycles_and_no_upward_imports() -> None:
    # The layers, as the folders show them: the core (units, system, modes, the solvers); the
    # builders of systems; the analyses of results; the charts and renders that draw them; the
    # pipeline's scene -> plan -> report (and sweep); the command line on top. Nothing imports a
    # higher layer, not even inside a function.
    graph = _vibra_imports()

    def reachable(start: str) -> set[str]:
        seen, stack = set(), [start]
        while stack:
            for target in graph[stack.pop()]:
                if target not in seen:
                    seen.add(target)
                    stack.append(target)
        return seen

    in_cycle = sorted(name for name in graph if name in reachable(name))
    assert in_cycle == [], f"import cycles through {in_cycle}"

    stages = (("vibra.chains", "vibra.molecules", "vibra.networks", "vibra.mechanics", "vibra.crystals"),
              ("vibra.continuum", "vibra.response", "vibra.spectra", "vibra.crosscheck", "vibra.dynamics"),
              ("vibra.charts", "vibra.pipeline.render", "vibra.pipeline.render_geometry"), ("vibra.pipeline.scene",),
              ("vibra.pipeline.plan",),
              ("vibra.pipeline.report", "vibra.pipeline.sweep"), ("vibra.cli",))

    def layer(name: str) -> int:
        for rank, prefixes in enumerate(stages, start=1):
            if any(name == prefix or name.startswith(prefix + ".") for prefix in prefixes):
                return rank
        return 0  # the core: vibra._*, units, assembly, system, generalized, modes, solvers, cluster

    upward = sorted((name, target) for name, targets in graph.items() for target in targets
                    if name not in ("vibra", "vibra.__main__") and layer(target) > layer(name)
                    and not target.startswith(name + "."))
    assert upward == [], upward


def test_no_import_cycle_through_a_package_init() -> None:
    """`from vibra.solvers.standard import pardiso` at module level runs vibra/solvers/__init__ first: a
    module the package's __init__ imports must not import the package back (a cycle the
    submodule-level graph above does not see). Module-level imports only; the root package
    `vibra` is lazy (SUBMODULES load on access), so it is no edge."""
    import ast

    modules = _vibra_modules()
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        top = [statement for statement in ast.parse(path.read_text(encoding="utf-8")).body
               if not (isinstance(statement, ast.If) and isinstance(statement.test, ast.Name)
                       and statement.test.id == "TYPE_CHECKING")]  # (annotations only: not run)
        for node in (n for statement in top for n in ast.walk(statement)
                     if not isinstance(statement, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            graph[name].update(t for t in targets if t in modules and t not in ("vibra", name))

    def cycle_from(start: str) -> list[str] | None:
        paths = [[start]]
        seen = {start}
        while paths:
            path = paths.pop(0)
            for target in sorted(graph[path[-1]]):
                if target == start:
                    return path + [start]
                if target not in seen:
                    seen.add(target)
                    paths.append(path + [target])
        return None

    cycles = [cycle for cycle in map(cycle_from, sorted(graph)) if cycle]
    assert cycles == [], " ; ".join(" -> ".join(cycle) for cycle in cycles)


def test_limits_a_scene_raises_reach_the_solvers_guard(tmp_path, monkeypatch) -> None:
    """compute.memory_limit_gib / time_limit_s, which validate honours, are the limits of the solve too."""
    from vibra.system import System

    seen = []
    original = System.modes

    def spy(self, *args, **kwargs):
        seen.append((kwargs.get("max_memory"), kwargs.get("max_seconds")))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(System, "modes", spy)
    scene = tmp_path / "lim.toml"
    scene.write_text('kind = "chain"\nname = "lim"\n[system]\nbuilder = "linear_chain"\nn = 8\n'
                     "[compute]\nmemory_limit_gib = 3.0\ntime_limit_s = 900.0\n")
    outcome = run_scene(scene, tmp_path / "out")
    assert outcome.status == "ok", outcome.error
    assert (3.0 * 2**30, 900.0) in seen
