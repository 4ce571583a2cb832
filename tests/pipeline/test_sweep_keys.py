"""What a sweep computes for each class of key (`vibra.pipeline.sweep.applies`), and one value of a
list swept by index (`vibra.pipeline.sweep.tables`): issue 48, item 5.

Truth comes from closed forms: the receptance of one damped oscillator, |x(w)| = 1 / |k - m w^2 +
i w c|, and the two frequencies of a two-mass chain, the roots of det(K - w^2 M) = 0.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from vibra import cli
from vibra.pipeline.scene import SceneError
from vibra.pipeline.sweep import ensemble, grid, parse_vary, sweep, vary

ROOT = Path(__file__).resolve().parents[2]
FORCED = ROOT / "chains" / "forced-damped.toml"
FPUT = ROOT / "dynamics" / "fput-alpha.toml"
NOSE_HOOVER = ROOT / "dynamics" / "nose-hoover.toml"

MASS, SPRING = 2.0, 50.0  # one site tied to its rest position: omega_0 = 5 rad/s
ONE = {"kind": "chain", "name": "one", "units": "SI",
       "system": {"builder": "springs", "positions": [0.0], "masses": MASS, "springs": [], "stiffness": 1.0,
                  "anchors": [0], "anchor_stiffness": SPRING},
       "compute": {"response": {"omega_min": 1.0, "omega_max": 9.0, "n_points": 801}}}


def receptance(omegas: np.ndarray, c: float) -> np.ndarray:
    """|x(w)| of m x'' + c x' + k x = exp(i w t), in m/N."""
    return 1.0 / np.abs(SPRING - MASS * omegas**2 + 1j * omegas * c)


# ---------------------------------------------------------------------- response keys
@pytest.mark.parametrize("key, damping", [("compute.response.alpha", lambda a: a * MASS),    # C = alpha M
                                          ("compute.response.beta", lambda b: b * SPRING)])  # C = beta K
def test_a_damping_sweep_tabulates_the_response_peak_of_the_closed_form(key, damping) -> None:
    values = (0.02, 0.1, 0.5)
    table = sweep(ONE, {key: values})
    omegas = np.linspace(1.0, 9.0, 801)
    for row, value in zip(table.rows, values):
        exact = receptance(omegas, damping(value))
        derived = dict(row.derived)
        assert derived["peak_receptance (m/N)"] == pytest.approx(exact.max(), rel=1e-9)
        assert derived["peak_omega (rad/s)"] == pytest.approx(omegas[np.argmax(exact)], rel=1e-12)
        assert row.omega == pytest.approx([5.0], rel=1e-12)  # damping moves no natural frequency
    peaks = table.column("peak_receptance (m/N)")
    assert np.all(np.diff(peaks) < 0)  # more damping, a lower peak: no two rows alike


def test_the_forced_damped_scene_swept_over_its_damping_gives_different_rows(tmp_path: Path, capsys) -> None:
    code = cli.main(["sweep", str(FORCED), "--vary", "compute.response.alpha=0.1:0.5:3", "--out", str(tmp_path),
                     "--quiet"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "warning" not in err  # the rows differ
    rows = list(csv.DictReader((tmp_path / "forced-damped_sweep.csv").open()))
    peaks = [float(row["peak_receptance (m/N)"]) for row in rows]
    assert len(peaks) == 3 and peaks[0] > peaks[1] > peaks[2]
    assert len({row["omega_0"] for row in rows}) == 1  # the frequencies stay


def test_a_system_sweep_of_a_response_scene_has_the_response_columns_too() -> None:
    damped = {**ONE, "compute": {"response": {**ONE["compute"]["response"], "alpha": 0.2}}}
    table = sweep(damped, {"system.anchor_stiffness": [SPRING, 2 * SPRING]})  # omega_0 = 5, then sqrt(50)
    assert table.rows[1].omega == pytest.approx([np.sqrt(2 * SPRING / MASS)], rel=1e-12)
    omegas = np.linspace(1.0, 9.0, 801)
    for row, k in zip(table.rows, (SPRING, 2 * SPRING)):
        exact = 1.0 / np.abs(k - MASS * omegas**2 + 1j * omegas * 0.2 * MASS)
        assert dict(row.derived)["peak_receptance (m/N)"] == pytest.approx(exact.max(), rel=1e-9)
        assert dict(row.derived)["peak_omega (rad/s)"] == pytest.approx(omegas[np.argmax(exact)], rel=1e-12)


def test_a_scene_without_a_response_has_no_response_columns() -> None:
    table = sweep(ROOT / "chains" / "mass-defect.toml", vary("system.defect_mass", 0.2, 0.6, 2))
    assert all(not any(name.startswith("peak_") for name, _ in row.derived) for row in table.rows)


# ---------------------------------------------------------------------- keys refused up front
@pytest.mark.parametrize("scene, key, low, high, match", [
    (FPUT, "compute.dt", 0.05, 0.1, r"fput-alpha\.toml: compute\.dt: changes only a dynamics scene's run: .*"
     r"integrates no trajectory.*run the scene once per value of compute\.dt"),
    (FPUT, "compute.energy", 0.05, 0.1, r"compute\.energy: changes only a dynamics scene's run"),
    (FPUT, "system.alpha", 0.1, 0.3, r"system\.alpha: is an anharmonic term: it changes only the trajectory"),
    (FPUT, "system.beta", 0.1, 0.3, r"system\.beta: is an anharmonic term"),
    (NOSE_HOOVER, "compute.temperature", 0.5, 2.0, r"compute\.temperature: changes only a dynamics scene's run"),
    (NOSE_HOOVER, "compute.x0[0]", 0.5, 2.0, r"compute\.x0\[0\]: changes only a dynamics scene's run"),
    (FORCED, "draw.n_draw", 1, 3, r"draw\.n_draw: changes no solve: a sweep tabulates the normal modes .* the peak "
     r"of its forced response"),
    (FORCED, "compute.memory_limit_gib", 1, 3, r"compute\.memory_limit_gib: changes no solve"),
])
def test_a_key_that_changes_nothing_a_sweep_computes_is_refused_before_any_solve(scene, key, low, high,
                                                                                  match) -> None:
    solved: list[int] = []
    with pytest.raises(SceneError, match=match):
        sweep(scene, vary(key, low, high, 3), progress=lambda done, total, label: solved.append(done))
    assert solved == []


def test_a_dynamics_scene_swept_over_its_harmonic_system_still_runs() -> None:
    table = sweep(FPUT, vary("system.stiffness", 1.0, 4.0, 2))
    assert table.rows[1].omega == pytest.approx(2.0 * table.rows[0].omega, rel=1e-12)  # omega ~ sqrt(k)


def test_an_ensemble_drawing_a_dynamics_key_is_refused() -> None:
    with pytest.raises(SceneError, match=r"compute\.dt: changes only a dynamics scene's run"):
        sweep(FPUT, ensemble(1, 2, draw=lambda rng: {"compute.dt": float(rng.uniform(0.05, 0.1))}))


def test_the_command_line_refuses_a_dynamics_key_in_one_line(tmp_path: Path, capsys) -> None:
    code = cli.main(["sweep", str(FPUT), "--vary", "compute.dt=0.05:0.1:3", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == cli.EXIT_FAILED
    assert err.count("\n") == 1 and "compute.dt: changes only a dynamics scene's run" in err, err
    assert not (tmp_path / "o").exists()


# ---------------------------------------------------------------------- one value of a list
def two_masses(m0: float, m1: float, k: tuple[float, float, float]) -> np.ndarray:
    """The two omegas of masses m0, m1 between fixed walls, springs k0 | k1 | k2: roots of
    m0 m1 l^2 - (m0 (k1 + k2) + m1 (k0 + k1)) l + ((k0 + k1)(k1 + k2) - k1^2) = 0, l = omega^2."""
    k0, k1, k2 = k
    a, b, c = m0 * m1, -(m0 * (k1 + k2) + m1 * (k0 + k1)), (k0 + k1) * (k1 + k2) - k1**2
    root = np.sqrt(b * b - 4 * a * c)
    return np.sqrt(np.array([(-b - root) / (2 * a), (-b + root) / (2 * a)]))


CHAIN = {"kind": "chain", "name": "pair", "units": "SI",
         "system": {"builder": "linear_chain", "n": 2, "mass": [1.0, 1.5], "stiffness": [3.0, 2.0, 4.0],
                    "ends": "fixed"}}


def test_one_spring_of_a_list_swept_gives_the_closed_form_frequencies() -> None:
    values = (0.5, 1.0, 2.0, 4.0)
    table = sweep(CHAIN, vary("system.stiffness[1]", 0.5, 4.0, 4, spacing="log"))
    assert table.keys == ("system.stiffness[1]",)
    for row, k1 in zip(table.rows, values):
        assert dict(row.parameters)["system.stiffness[1]"] == pytest.approx(k1)
        assert row.omega == pytest.approx(two_masses(1.0, 1.5, (3.0, k1, 4.0)), rel=1e-12)


def test_a_grid_of_two_list_values() -> None:
    table = sweep(CHAIN, grid({"system.mass[0]": [1.0, 3.0], "system.stiffness[2]": [1.0, 5.0]}))
    for row in table.rows:
        p = dict(row.parameters)
        exact = two_masses(p["system.mass[0]"], 1.5, (3.0, 2.0, p["system.stiffness[2]"]))
        assert row.omega == pytest.approx(exact, rel=1e-12)


def test_one_value_of_a_default_list() -> None:
    scene = {"kind": "chain", "name": "cells", "system": {"builder": "diatomic_chain", "n_cells": 1,
                                                          "ends": "periodic"}}
    table = sweep(scene, {"system.masses[1]": [2.0, 4.0]})  # the builder's masses = (1, 2)
    for row, m1 in zip(table.rows, (2.0, 4.0)):  # one periodic cell: 0 and sqrt(2 k (1/m0 + 1/m1)), k = 1
        assert row.omega == pytest.approx([0.0, np.sqrt(2.0 * (1.0 + 1.0 / m1))], abs=1e-12)


def test_the_command_line_sweeps_one_value_of_a_list(tmp_path: Path, capsys) -> None:
    scene = tmp_path / "pair.toml"
    scene.write_text('kind = "chain"\nunits = "SI"\n[system]\nbuilder = "linear_chain"\nn = 2\nmass = [1.0, 1.5]\n'
                     'stiffness = [3.0, 2.0, 4.0]\nends = "fixed"\n')
    assert parse_vary("system.stiffness[1]=1:2:5").key == "system.stiffness[1]"
    code = cli.main(["sweep", str(scene), "--vary", "system.stiffness[1]=1:2:5", "--out", str(tmp_path / "o"),
                     "--quiet"])
    assert code == 0, capsys.readouterr().err
    rows = list(csv.DictReader((tmp_path / "o" / "pair_sweep.csv").open()))
    assert [float(row["system.stiffness[1]"]) for row in rows] == [1.0, 1.25, 1.5, 1.75, 2.0]
    for row in rows:
        k1 = float(row["system.stiffness[1]"])
        assert [float(row["omega_0"]), float(row["omega_1"])] == pytest.approx(two_masses(1.0, 1.5, (3.0, k1, 4.0)))


@pytest.mark.parametrize("target, key, match", [
    (CHAIN, "system.stiffness[3]",
     r"pair: system\.stiffness\[3\]: index 3 is out of range: system\.stiffness has 3 values \(indices 0 to 2\)"),
    (CHAIN, "system.mass[7]", r"system\.mass\[7\]: index 7 is out of range: system\.mass has 2 values"),
    (FORCED, "system.stiffness[1]", r"forced-damped\.toml: system\.stiffness\[1\]: system\.stiffness is 100\.0, "
     r"a number, not a list: \[1\] picks one value of a list; give system\.stiffness as a list"),
    (FORCED, "system.mass[0]", r"system\.mass\[0\]: system\.mass is 1\.0, a number, not a list"),
    ({"kind": "chain", "name": "bare", "system": {"builder": "linear_chain", "n": 3}}, "system.mass[0]",
     r"bare: system\.mass\[0\]: system\.mass is 1\.0 \(its default: the scene does not give it\), a number, not "
     r"a list"),
    (FORCED, "system.stifness[1]", r"system\.stifness\[1\]: unknown key; did you mean 'stiffness'\?"),
    (FORCED, "system.masses[0]", r"system\.masses\[0\]: unknown key; did you mean 'mass'\?"),
    (FORCED, "system.stifness", r"system\.stifness: unknown key; did you mean 'stiffness'\?"),
    (FORCED, "system.frozen_sites[0]", r"system\.frozen_sites is not given in the scene \(and has no default\)"),
    ({**CHAIN, "system": {**CHAIN["system"], "frozen_sites": []}}, "system.frozen_sites[0]",
     r"system\.frozen_sites\[0\]: index 0 is out of range: system\.frozen_sites is an empty list"),
    (FORCED, "compute.band[0]", r"compute\.band\[0\]: compute\.band is not given in the scene, so it has no values"),
    (FORCED, "system.stiffness[1]x", r"system\.stiffness\[1\]x: a swept key must be a dotted path .* such as "
     r"system\.stiffness\[1\]"),
    (FORCED, "system.stiffness[-1]", r"a swept key must be a dotted path"),
    (FORCED, "system[0].n", r"a swept key must be a dotted path"),
])
def test_a_bad_list_value_key_is_refused_in_one_line(target, key, match) -> None:
    with pytest.raises(SceneError, match=match) as info:
        sweep(target, vary(key, 1.0, 2.0, 2))
    assert "\n" not in str(info.value)


def test_a_list_swept_whole_and_by_one_value_is_refused() -> None:
    with pytest.raises(SceneError, match=r"system\.stiffness\[0\]: system\.stiffness is swept too"):
        sweep(CHAIN, grid({"system.stiffness": [1.0], "system.stiffness[0]": [1.0, 2.0]}))


def test_a_bad_list_value_is_named_with_its_index() -> None:
    with pytest.raises(SceneError, match=r"system\.stiffness: \[1\] must be positive, got -1\.0"):
        sweep(CHAIN, {"system.stiffness[1]": [1.0, -1.0]})
