"""Dynamics scenes (issue 33, item 3): schema, one-line refusals, the plan and the values it charts.

Truth: closed forms (FPUT's initial displacement x_i = a sin(pi i / N); the stable step 2 / omega_max
of velocity Verlet with omega_max = 2 sin(n pi / (2 (n + 1))) for a fixed chain; the isokinetic
friction -(K x).v / (n_dof k_B T) of the course's oscillator; the Boltzmann width sqrt(k_B T / k)),
the library's own results computed here independently of the pipeline (what a chart draws must be
what `vibra.dynamics` returns), Tuck and Menzel's recurrence law, and the images' size and variance.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

import vibra.charts.dynamics as charts
from vibra import dynamics
from vibra.pipeline.plan import execute, make_plan, validate
from vibra.pipeline.plan import cost_summary
from vibra.pipeline.scene import Scene, SceneError, load_scene
from vibra.pipeline.scene.limits import MAX_DYNAMICS_STEPS

ROOT = Path(__file__).resolve().parents[2]
SCENES = sorted((ROOT / "dynamics").glob("*.toml"))


def fput_scene(**changes: object) -> dict:
    data: dict[str, Any] = {"kind": "dynamics", "system": {"builder": "fput", "n": 7, "alpha": 0.25},
                            "compute": {"dt": 0.1, "n_steps": 2000, "mode": 1, "energy": 0.05},
                            "draw": {"mode_energies": True, "n_modes_drawn": 3}}
    for section, values in changes.items():
        data[section] = {**data.get(section, {}), **values} if isinstance(values, dict) else values
        data[section] = {k: v for k, v in data[section].items() if v is not None} if isinstance(values, dict) \
            else data[section]
    return data


def oscillator_scene(**changes: object) -> dict:
    data: dict[str, Any] = {
        "kind": "dynamics",
        "system": {"builder": "springs", "positions": [0.0], "masses": 1.0, "springs": [], "stiffness": 1.0,
                   "anchors": [0], "anchor_stiffness": 1.0},
        "compute": {"dt": 0.05, "n_steps": 1000, "thermostat": "nose-hoover", "temperature": 1.0,
                    "x0": [0.0], "v0": [1.0]},
        "draw": {"histogram": True}}
    for section, values in changes.items():
        data[section] = {**data.get(section, {}), **values} if isinstance(values, dict) else values
        data[section] = {k: v for k, v in data[section].items() if v is not None} if isinstance(values, dict) \
            else data[section]
    return data


def run_scene(scene: Scene, tmp_path: Path) -> Any:
    work = tmp_path / "work"
    work.mkdir(exist_ok=True)
    return execute(make_plan(scene), tmp_path, work)


def capture(monkeypatch: pytest.MonkeyPatch, name: str) -> list[tuple[tuple, dict]]:
    """Record the arguments of chart function `name` (the chart is still drawn)."""
    calls: list[tuple[tuple, dict]] = []
    original = getattr(charts, name)

    def spy(*args: Any, **kwargs: Any) -> Any:
        calls.append((args, kwargs))
        return original(*args, **kwargs)

    monkeypatch.setattr(charts, name, spy)
    return calls


def assert_chart(path: Path) -> None:
    with Image.open(path) as image:
        picture = np.asarray(image.convert("RGB"))
    assert picture.shape[1] >= 600 and picture.std() > 5.0       # a chart, not blank


@pytest.mark.parametrize("path", SCENES, ids=[p.stem for p in SCENES])
def test_bundled_dynamics_scenes_validate(path: Path) -> None:
    scene = load_scene(path)
    system = validate(scene)
    cost = cost_summary(scene, system)
    assert scene.kind == "dynamics" and ("; 1 run of" in cost or "; 2 runs of" in cost) and "estimated ~" in cost


def test_fput_scene_charts_the_librarys_mode_energies_and_the_recurrence(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    calls = capture(monkeypatch, "plot_mode_energies")
    scene = load_scene(ROOT / "dynamics" / "fput-alpha.toml")
    result = run_scene(scene, tmp_path)
    assert result.outputs == ("fput-alpha_mode_energies.png",)
    assert_chart(tmp_path / result.outputs[0])
    (t, energies), options = calls[0]
    # the same run through the library alone, from FPUT's closed-form start x_i = sin(pi i / 32)
    system, forces = dynamics.fput(31, alpha=0.25)
    modes = system.modes()
    x0 = np.sin(np.pi * np.arange(1, 32) / 32)
    assert 0.5 * modes.omega[0] ** 2 * x0 @ x0 == pytest.approx(0.0770, rel=1e-3)   # the scene's energy
    start = np.sqrt(2 * 0.0770) / modes.omega[0] * modes.shapes[:, 0]
    np.testing.assert_allclose(np.abs(start), np.abs(x0) * np.sqrt(0.0770 / (0.5 * modes.omega[0] ** 2 * x0 @ x0)),
                               rtol=1e-10)
    run = dynamics.integrate(system, start, np.zeros(31), 0.1, 130000, forces=forces, record_every=50)
    np.testing.assert_allclose(t, run.t, rtol=0, atol=0)
    np.testing.assert_allclose(energies, run.mode_energies(modes)[:, :5], rtol=1e-12, atol=1e-15)
    assert options["total"] == pytest.approx(0.0770, rel=1e-12)
    # the recurrence the caption states: Tuck and Menzel, T_R ~= 0.38 N^(3/2) (a alpha)^(-1/2) T_1, within 12 %
    record = result.records[2]
    recurrence = float(record.accuracy.split("t = ")[1].split(" ")[0])
    period = 2 * np.pi / modes.omega[0]
    assert recurrence / period == pytest.approx(0.38 * 32**1.5 / np.sqrt(0.25), rel=0.12)
    assert "98." in record.accuracy or "97." in record.accuracy or "99." in record.accuracy


def test_isokinetic_scene_charts_mu_beside_the_courses_closed_form(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    calls = capture(monkeypatch, "plot_energies")
    scene = load_scene(ROOT / "dynamics" / "isokinetic.toml")
    result = run_scene(scene, tmp_path)
    assert result.outputs == ("isokinetic_energies.png",)
    assert_chart(tmp_path / result.outputs[0])
    (run, label), options = calls[0]
    assert label == "mu"
    reference = run.thermostat_state[:, 0]
    x, v = run.positions, run.velocities
    mu = -3.0 * np.sum(x * v, axis=1) / (3 * 0.5)               # -K (r . r') / (3 k_B T), K = 3, k_B T = 0.5
    np.testing.assert_allclose(options["reference"], mu, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(reference, mu, rtol=1e-9, atol=1e-9)
    assert options["target_kinetic"] == pytest.approx(1.5 * 0.5)   # 3 k_B T / 2
    np.testing.assert_allclose(run.kinetic, 0.75, rtol=1e-13)
    library = dynamics.integrate(validate(scene), [1.0, 0.0, 0.0], [0.0, 1.0, 0.3], 0.01, 4000,
                                 thermostat=dynamics.Isokinetic(0.5), record_every=2)
    np.testing.assert_array_equal(run.positions, library.positions)


def test_nose_hoover_scene_histograms_against_the_boltzmann_gaussian(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    calls = capture(monkeypatch, "plot_position_histograms")
    scene = load_scene(ROOT / "dynamics" / "nose-hoover.toml")
    result = run_scene(scene, tmp_path)
    assert result.outputs == ("nose-hoover_histogram.png",)
    assert_chart(tmp_path / result.outputs[0])
    (samples, labels, sigma, distances), _ = calls[0]
    assert sigma == pytest.approx(1.0, rel=1e-12)                 # sqrt(k_B T / k) = 1
    assert labels == ("one Nosé-Hoover thermostat", "Nosé-Hoover chain of 4")
    for chain, values in zip((1, 4), samples):
        run = dynamics.integrate(validate(scene), [0.0], [1.0], 0.05, 2_000_000,
                                 thermostat=dynamics.NoseHoover(1.0, 1.0, chain=chain), record_every=200)
        np.testing.assert_array_equal(values, run.positions[1:, 0])
    # one thermostat is not ergodic on an oscillator, a chain is (tests/dynamics/test_dynamics.py measures the spread)
    assert distances[0] > 0.026 and distances[1] < 0.0102


def test_report_groups_dynamics_and_shows_the_modes_and_what_the_run_conserved(tmp_path: Path) -> None:
    from vibra.pipeline.report import report

    out = tmp_path / "out"
    [outcome] = report([ROOT / "dynamics" / "isokinetic.toml"], out, progress=False).outcomes
    assert outcome.status == "ok", outcome.error
    index = (out / "index.html").read_text(encoding="utf-8")
    assert "<h2 id='dynamics'>Dynamics</h2>" in index and "Other scenes" not in index
    assert "1 scene, 1 figure." in index and "scene(s)" not in index
    page = (out / "scenes" / "isokinetic.html").read_text(encoding="utf-8")
    table = page.split("<h2>Normal modes the run starts from</h2>")[1].split("<pre>")[1].split("</pre>")[0]
    header, *rows = table.splitlines()
    assert rows[-1] == "modes numbered from the lowest non-rigid one (mode 1)"  # said once, below the rows
    rows = rows[:-1]
    assert "omega (√(k/m))" in header
    # the isotropic oscillator's three modes, omega = sqrt(k / m) = sqrt(3 / 2)
    assert [float(row.split()[1]) for row in rows] == pytest.approx([np.sqrt(1.5)] * 3, rel=1e-9)
    conserved = page.split("<h2>What the run conserved</h2><p>")[1].split("</p>")[0]
    assert conserved.startswith("Largest relative change of the kinetic energy: ")
    run = dynamics.integrate(validate(load_scene(ROOT / "dynamics" / "isokinetic.toml")), [1.0, 0.0, 0.0],
                             [0.0, 1.0, 0.3], 0.01, 4000, thermostat=dynamics.Isokinetic(0.5), record_every=2)
    assert conserved.endswith(f": {run.conserved_drift():.2e}.")


def test_plan_steps_follow_the_draw_table() -> None:
    scene = Scene.from_dict(oscillator_scene(compute={"chain": [1, 2, 3]}, draw={"energies": True}), source="o.toml")
    assert make_plan(scene).step_names == ("build", "dynamics-run", "chart-energies", "chart-histogram")
    assert scene.dynamics.chains == (1, 2, 3) and scene.dynamics.n_runs == 3
    assert scene.dynamics.record_every == 1                     # n_steps // 2000 records, at least 1


@pytest.mark.parametrize("data, message", [
    (fput_scene(compute={"dt": 1.2}), r"x\.toml: compute\.dt: is 1\.2, unstable for the highest normal frequency "
     r"omega_max = 1\.96157 rad / time unit: verlet is stable for dt < 2 / omega_max = 1\.01959"),
    (fput_scene(compute={"dt": 0.85, "integrator": "yoshida4"}), r"compute\.dt: is 0\.85, .* yoshida4 is stable for "
     r"dt < 1\.573 / omega_max = 0\.80211"),
    (fput_scene(compute={"n_steps": MAX_DYNAMICS_STEPS + 1}), r"compute\.n_steps: must be 1 <= value <= 100000000"),
    (fput_scene(system={"n": 2000}, compute={"n_steps": 100_000_000, "record_every": 1_000_000}),
     r"compute\.n_steps: is 100000000: 1 run of 2000 dofs would take "
     r"about .* s, more than the limit of 600 s"),
    (fput_scene(compute={"n_steps": 50_000_000, "record_every": 1, "time_limit_s": 1e6, "memory_limit_gib": 1.0}),
     r"compute\.record_every: the recorded states would need about .* GiB, more than the limit of 1 GiB"),
    (fput_scene(compute={"dt": 0.0}), r"compute\.dt: must be positive, got 0\.0"),
    (fput_scene(compute={"dt": None}), r"compute\.dt: is required"),
    (fput_scene(compute={"thermostat": "berendsen"}), r"compute\.thermostat: is 'berendsen'; expected one of 'none', "
     r"'isokinetic', 'nose-hoover'"),
    (fput_scene(compute={"temperature": 1.0}), r"compute\.temperature: applies with a thermostat only"),
    (fput_scene(compute={"mode": 8}), r"compute\.mode: is 8; the system has 7 modes"),
    (fput_scene(compute={"mode": 1, "x0": [0.0] * 7}), r"compute\.mode: give the initial state as mode"),
    (fput_scene(compute={"mode": None, "energy": None}), r"compute: has no initial state"),
    (fput_scene(system={"ends": "periodic"}), r"compute\.mode: is 1, a rigid mode \(omega = 0\)"),
    (fput_scene(compute={"mode": None, "energy": None, "x0": [0.1] * 6}), r"compute\.x0: needs 7 values \(one per "
     r"degree of freedom\), got 6"),
    (fput_scene(draw={"n_modes_drawn": 9}), r"draw\.n_modes_drawn: is 9; the system has 7 modes"),
    (fput_scene(draw={"mode_energies": False}), r"draw: a dynamics scene draws nothing"),
    (fput_scene(draw={"histogram": True}), r"draw\.histogram: compares positions with the Boltzmann distribution"),
    (fput_scene(compute={"thermostat": "nose-hoover", "temperature": 1.0}, draw={"histogram": True}),
     r"draw\.histogram: compares with the Gaussian Boltzmann distribution of a harmonic system; this FPUT chain"),
    (fput_scene(compute={"steps": 10}), r"compute\.steps: unknown key; did you mean 'n_steps'\?"),
    (oscillator_scene(compute={"temperature": 0.0}), r"compute\.temperature: must be positive, got 0\.0"),
    (oscillator_scene(compute={"temperature": float("nan")}), r"compute\.temperature: expected a finite number, got nan"),
    (oscillator_scene(compute={"temperature": None}), r"compute\.temperature: is required with thermostat = "
     r"'nose-hoover'"),
    (oscillator_scene(compute={"chain": 0}), r"compute\.chain: must be 1 <= value <= 64, got 0"),
    (oscillator_scene(compute={"integrator": "blanes-moan"}), r"compute\.integrator: 'blanes-moan' splits two flows"),
    (oscillator_scene(compute={"thermostat": "isokinetic", "v0": [0.0]}), r"compute\.v0: is zero or missing; the "
     r"isokinetic constraint needs a nonzero initial velocity"),
    (oscillator_scene(compute={"thermostat": "isokinetic", "chain": 2}), r"compute\.chain: applies to the "
     r"Nosé-Hoover thermostat only"),
    (oscillator_scene(draw={"histogram_dof": 1}), r"draw\.histogram_dof: is 1; degrees of freedom run from 0 to 0"),
    (oscillator_scene(system={"positions": [0.0, 1.0], "springs": [[0, 1]], "anchors": None,
                              "anchor_stiffness": None}, compute={"x0": [0.0, 0.0], "v0": [1.0, 0.0]}),
     r"draw\.histogram: the system has a rigid mode \(omega = 0\)"),
    ({**oscillator_scene(), "system": {"builder": "co2"}}, r"system\.builder: builder 'co2' does not make a "
     r"'dynamics' scene \(for 'dynamics': linear_chain, springs, fput\)"),
])
def test_bad_dynamics_scene_names_the_key(data: dict, message: str) -> None:
    with pytest.raises(SceneError, match=message) as error:
        validate(Scene.from_dict(data, source="x.toml"))
    assert "\n" not in str(error.value)


def test_vibra_validate_refuses_an_unstable_step_in_one_line(tmp_path: Path) -> None:
    text = (ROOT / "dynamics" / "fput-alpha.toml").read_text().replace("dt = 0.1 ", "dt = 1.5 ")
    (tmp_path / "fast.toml").write_text(text)
    run = subprocess.run([sys.executable, "-m", "vibra", "validate", str(tmp_path / "fast.toml")],
                         capture_output=True, text=True, cwd=ROOT)
    assert run.returncode != 0 and "Traceback" not in run.stderr
    lines = [line for line in (run.stdout + run.stderr).splitlines() if "compute.dt" in line]
    assert len(lines) == 1 and f"is stable for dt < 2 / omega_max = {1 / np.sin(31 * np.pi / 64):.6g}" in lines[0], run.stderr
    ok = subprocess.run([sys.executable, "-m", "vibra", "validate", "dynamics"], capture_output=True, text=True,
                        cwd=ROOT)
    assert ok.returncode == 0, ok.stderr
    line = next(text for text in ok.stdout.splitlines() if "fput-alpha" in text)
    assert "31 dofs; 1 run of 130000 verlet steps of dt = 0.1" in line and "estimated ~" in line


# Issue 16's property for the new kind: a dynamics scene that validation accepts runs, or fails with
# a SceneError at a key (a diverging anharmonic run), never with another exception.
SIZE = st.floats(-12, 12).map(lambda e: float(10.0 ** e))  # numbers in 1e-12 .. 1e12, log-uniform


@st.composite
def dynamics_scenes(draw: Any) -> dict:
    builder = draw(st.sampled_from(["fput", "linear_chain", "springs"]))
    ends = draw(st.sampled_from(["free", "fixed", "periodic"]))
    n = draw(st.integers(2, 5))
    if builder == "fput":
        system = {"n": n, "alpha": draw(st.one_of(st.just(0.0), SIZE)), "beta": draw(st.one_of(st.just(0.0), SIZE)),
                  "ends": ends, "mass": draw(SIZE), "stiffness": draw(SIZE)}
    elif builder == "linear_chain":
        system = {"n": n, "ends": ends, "mass": draw(SIZE), "stiffness": draw(SIZE)}
    else:
        system = {"positions": [float(i) for i in range(n)], "masses": draw(SIZE), "springs": [[0, 1]],
                  "stiffness": draw(SIZE), "anchors": [0], "anchor_stiffness": draw(SIZE)}
    thermostat = draw(st.sampled_from(["none", "isokinetic", "nose-hoover"]))
    compute: dict[str, Any] = {"dt": draw(SIZE), "n_steps": draw(st.integers(1, 300)), "thermostat": thermostat,
               "integrator": draw(st.sampled_from(["verlet", "yoshida4"]))}
    if thermostat != "none":
        compute["temperature"] = draw(SIZE)
    if thermostat == "nose-hoover":
        compute["tau"] = draw(SIZE)
        compute["chain"] = draw(st.one_of(st.integers(1, 4), st.lists(st.integers(1, 4), min_size=1, max_size=2)))
    if thermostat != "isokinetic" and draw(st.booleans()):
        compute.update(mode=draw(st.integers(1, n)), energy=draw(SIZE))
    else:
        compute["x0"] = [draw(st.floats(-1e3, 1e3)) for _ in range(n)]
        compute["v0"] = [draw(st.floats(-1e3, 1e3)) for _ in range(n)]
    dr = {"mode_energies": draw(st.booleans()), "energies": draw(st.booleans()), "histogram": draw(st.booleans()),
          "n_modes_drawn": draw(st.integers(1, n))}
    return {"kind": "dynamics", "system": {"builder": builder, **system}, "compute": compute, "draw": dr}


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
@given(dynamics_scenes())
def test_an_accepted_dynamics_scene_runs_or_names_a_key(data: dict) -> None:
    try:
        scene = Scene.from_dict(data, source="g.toml")
        validate(scene)
    except SceneError:
        return
    with tempfile.TemporaryDirectory() as folder:
        try:
            execute(make_plan(scene), Path(folder), Path(folder))
        except SceneError as error:
            assert error.key, error


def test_histogram_width_is_the_boltzmann_variance_of_one_chain_site(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    # a fixed chain of n sites: (K^-1)_ii = i (n + 1 - i) / ((n + 1) k), i 1-based; sigma^2 = k_B T (K^-1)_ii
    calls = capture(monkeypatch, "plot_position_histograms")
    data = {"kind": "dynamics", "system": {"builder": "linear_chain", "n": 4, "stiffness": 2.0, "ends": "fixed"},
            "compute": {"dt": 0.05, "n_steps": 2000, "thermostat": "nose-hoover", "temperature": 0.5,
                        "chain": 4, "x0": [0.1, 0.0, 0.0, 0.0], "v0": [0.0, 0.0, 0.0, 0.0]},
            "draw": {"histogram": True, "histogram_dof": 1}}
    run_scene(Scene.from_dict(data, source=str(tmp_path / "sites.toml")), tmp_path)
    (_, labels, sigma, _), _ = calls[0]
    assert labels == ("Nosé-Hoover chain of 4",)
    assert sigma**2 == pytest.approx(0.5 * 2 * 3 / (5 * 2.0), rel=1e-12)


@pytest.mark.parametrize("compute, key", [({"temperature": 1e-310}, "compute.temperature"),
                                          ({"tau": 1e-200}, "compute.tau")])
def test_validate_refuses_a_thermostat_scale_the_run_would_refuse(compute: dict, key: str) -> None:
    """vibra validate runs the run's own check of k_B T and the Nosé-Hoover masses (review of issue 44):
    it said ok, and the report then failed."""
    import tomllib

    data = tomllib.loads((ROOT / "dynamics" / "nose-hoover.toml").read_text())
    data["compute"].update(compute)
    with pytest.raises(SceneError, match=rf"{key}: .*(outside the normal floats|leave the normal floats)"):
        validate(Scene.from_dict(data, source=str(ROOT / "dynamics" / "nose-hoover.toml")))
