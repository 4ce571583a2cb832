"""Gyroscopic (issue 15) and elastic-network (issue 14) scenes: validation, plans, renders.

Truth from outside the code under test: the charged particle's closed form
omega = sqrt(omega0^2 + omega_c^2/4) -+ omega_c/2 (seed 003, example 4) and the sense of the
cyclotron motion from F = q v x B; ProDy's ANM on the same PDB file for the B-factor
correlation.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vibra.pipeline.plan import build_system, execute, make_plan, validate
from vibra.pipeline.scene import Scene, SceneError, load_scene

ROOT = Path(__file__).resolve().parents[2]
UBIQUITIN = ROOT / "networks" / "ubiquitin"
SMALL = [320, 200]
MIN_STD = 5.0  # a blank image has std 0 (see tests/pipeline/test_render.py)


def picture(path: Path) -> np.ndarray:
    with Image.open(path) as handle:
        handle.load()
        return np.asarray(handle.convert("RGB"))


def gyroscopic(**system: object) -> dict[str, object]:
    return {"kind": "generalized", "system": {"builder": "charged_particle", **system}, "draw": {"modes": True}}


# ---------------------------------------------------------------------- gyroscopic
def test_charged_particle_table_matches_the_closed_form(tmp_path: Path) -> None:
    m, omega0, q, b = 2.0, 3.0, 0.5, 4.0
    scene = Scene.from_dict(gyroscopic(mass=m, omega0=omega0, charge=q, field=b), source="cp.toml")
    result = execute(make_plan(scene), tmp_path, tmp_path)
    omega_c = q * b / m
    centre = math.sqrt(omega0**2 + omega_c**2 / 4)
    assert np.allclose(result.modes.natural_frequency, [centre - omega_c / 2, centre + omega_c / 2], rtol=1e-13)
    rows = [line.split() for line in result.frequencies[1:3]]
    assert [float(r[1]) for r in rows] == pytest.approx([centre - omega_c / 2, centre + omega_c / 2], rel=1e-9)
    assert all(r[-1] == "stable" for r in rows)
    [modes_step] = [r for r in result.records if r.name == "modes"]
    assert modes_step.solver == "skew-symmetric" and "stable" in (modes_step.accuracy or "")
    assert result.outputs == ("cp_orbits.png",)
    image = picture(tmp_path / "cp_orbits.png")
    assert image.shape[1] >= 600 and image.std() > MIN_STD


def test_charged_particle_orbits_turn_as_the_lorentz_force_says() -> None:
    # F = q v x B with B along +z and q > 0: free cyclotron motion turns clockwise seen from +z.
    # The faster mode (omega0' + omega_c/2) turns with it, the slower one against it.
    from vibra.charts.orbits import rotation_sense
    from vibra.pipeline.plan import build_system

    for sign, faster in ((1.0, "clockwise"), (-1.0, "counter-clockwise")):
        scene = Scene.from_dict(gyroscopic(field=sign * 1.0), source="cp.toml")
        modes = build_system(scene).modes()
        other = "counter-clockwise" if faster == "clockwise" else "clockwise"
        assert rotation_sense(modes.shapes[:, 1]) == faster
        assert rotation_sense(modes.shapes[:, 0]) == other


def test_bundled_charged_particle_scene_and_modes_command() -> None:
    scene = load_scene(ROOT / "chains" / "charged-particle.toml")
    validate(scene)
    run = subprocess.run([sys.executable, "-m", "vibra", "modes", str(ROOT / "chains" / "charged-particle.toml")],
                         capture_output=True, text=True, cwd=ROOT, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert run.returncode == 0, run.stderr
    golden = (math.sqrt(5) - 1) / 2
    assert f"{golden:.10g}" in run.stdout and f"{golden + 1:.10g}" in run.stdout
    assert "skew-symmetric" in run.stdout and "damping ratio" in run.stdout


def test_charged_particle_response_peaks_at_the_split_frequencies(tmp_path: Path) -> None:
    """The scene's forced response takes G: x0(w) from the 2x2 closed form, peaks at the split pair.

    Closed form (F = q v x B, B along z, drive f along x, C = alpha m):
    [[k - m w^2 + i w c, -i w q B], [i w q B, k - m w^2 + i w c]] (x, y) = (1, 0), up to G's sign,
    which |x0| does not see: |x0| = |a| / |a^2 - (w q B)^2| with a = k - m w^2 + i w c.
    """
    m, omega0, q, b, alpha = 1.0, 1.0, 1.0, 1.0, 0.05
    spec = {**gyroscopic(mass=m, omega0=omega0, charge=q, field=b),
            "compute": {"response": {"omega_min": 0.05, "omega_max": 2.5, "n_points": 500, "alpha": alpha,
                                     "force_site": 0, "method": "direct"}},
            "draw": {"modes": True, "response": True}}
    from vibra import response
    from vibra.pipeline.plan import build_system
    from vibra.pipeline.plan.checks import response_request

    scene = Scene.from_dict(spec, source="cp.toml")
    K, M, C, G, omegas, force, method, n_modes = response_request(scene, build_system(scene))
    assert G is not None and np.allclose(G, -np.asarray(G).T)
    w = np.linspace(0.05, 2.5, 500)
    a = m * omega0**2 - m * w**2 + 1j * w * alpha * m
    expected = np.abs(a) / np.abs(a**2 - (w * q * b) ** 2)
    amplitude = np.abs(response.frequency_response(K, M, C, omegas, force, method=method, G=G).response[:, 0])
    np.testing.assert_allclose(amplitude, expected, rtol=1e-12)
    golden = (math.sqrt(5) - 1) / 2
    peaks = [int(np.argmax(np.where(w < 1.0, amplitude, 0))), int(np.argmax(np.where(w > 1.0, amplitude, 0)))]
    assert abs(w[peaks[0]] - golden) < 0.02 and abs(w[peaks[1]] - (golden + 1)) < 0.02
    result = execute(make_plan(scene), tmp_path, tmp_path)
    assert "cp_response.png" in result.outputs
    assert picture(tmp_path / "cp_response.png").std() > MIN_STD


@pytest.mark.parametrize("extra, message", [
    ({"compute": {"n_modes": 1}}, r"compute\.n_modes: a gyroscopic system is solved for all its modes"),
    ({"compute": {"band": [0.0, 1.0]}}, r"compute\.band: a gyroscopic system is solved for all its modes"),
    ({"draw": {"spectrum": True}}, r"draw\.spectrum: a gyroscopic scene draws its mode orbits"),
    ({"draw": {"gif": True}}, r"draw\.gif: animates chains and molecules"),
    ({"system": {"builder": "charged_particle", "mass": -1.0}}, r"system\.mass: must be positive"),
    ({"system": {"builder": "charged_particle", "field": "strong"}}, r"system\.field: expected a number"),
    ({"kind": "chain"}, r"builder 'charged_particle' does not make a 'chain' scene"),
])
def test_gyroscopic_scene_refusals(extra: dict[str, object], message: str) -> None:
    with pytest.raises(SceneError, match=message):
        Scene.from_dict({**gyroscopic(), **extra}, source="cp.toml")


# ---------------------------------------------------------------------- networks
def network_scene(folder: Path, pdb: str = "1ubi.pdb", extra: str = "") -> Path:
    path = folder / "anm.toml"
    path.write_text(f'kind = "network"\n[system]\nbuilder = "anm"\npdb = "{pdb}"\n{extra}')
    return path


def test_network_scene_b_factor_correlation_matches_prody(tmp_path: Path) -> None:
    prody = pytest.importorskip("prody")
    prody.confProDy(verbosity="none")
    scene = load_scene(UBIQUITIN / "ubiquitin-anm.toml")  # residues 1-71: the tail 72-76 left out (issue 48)
    result = execute(make_plan(scene), tmp_path, tmp_path)
    [step] = [r for r in result.records if r.name == "fluctuations"]
    mine = float((step.accuracy or "").split("r = ")[1].split()[0])
    structure = prody.parsePDB(str(UBIQUITIN / "1ubi.pdb")).select("calpha and resnum 1 to 71")
    anm = prody.ANM("1ubi")
    anm.buildHessian(structure, cutoff=15.0, gamma=1.0)
    anm.calcModes(n_modes=20)
    reference = np.corrcoef(prody.calcSqFlucts(anm), structure.getBetas())[0, 1]
    assert mine == pytest.approx(reference, abs=1e-3)  # the step prints r to 3 decimals
    assert result.outputs == ("ubiquitin-anm_modes.png", "ubiquitin-anm_view.json", "ubiquitin-anm_spectrum.png",
                              "ubiquitin-anm_bfactors.png", "ubiquitin-anm_correlations.png")
    [caption] = [c for c in result.captions if "B-factors per residue" in c]
    assert f"r = {reference:.3f}" in caption and "ProDy's calcTempFactors" in caption
    assert "on one log axis" in caption  # the 20 slowest modes put the loops two decades above the rest


def test_network_charts_draw_prodys_fitted_b_factors_and_cross_correlations() -> None:
    # Truth: ProDy on the same atoms (calcTempFactors, calcCrossCorr); the chart's numbers are
    # those of the analysis step, fitted as ProDy does (issue 48: one convention).
    prody = pytest.importorskip("prody")
    prody.confProDy(verbosity="none")
    from vibra.pipeline.plan.analysis import network_fluctuations
    from vibra.pipeline.plan.build import network_structure

    scene = load_scene(UBIQUITIN / "ubiquitin-anm.toml")
    system = build_system(scene)
    network = network_fluctuations(network_structure(scene), system, system.modes(26))
    structure = prody.parsePDB(str(UBIQUITIN / "1ubi.pdb")).select("calpha and resnum 1 to 71")
    anm = prody.ANM("1ubi")
    anm.buildHessian(structure, cutoff=15.0, gamma=1.0)
    anm.calcModes(n_modes=20)
    flucts, betas = prody.calcSqFlucts(anm), structure.getBetas()
    np.testing.assert_allclose(network.fit.predicted, prody.calcTempFactors(anm, structure), rtol=1e-6)
    assert network.fit.correlation == pytest.approx(np.corrcoef(flucts, betas)[0, 1], abs=1e-9)
    np.testing.assert_allclose(network.cross_correlations, prody.calcCrossCorr(anm), atol=1e-6)


def test_network_render_is_sized_and_not_blank(tmp_path: Path) -> None:
    shutil.copy(UBIQUITIN / "1ubi.pdb", tmp_path / "1ubi.pdb")
    scene = load_scene(network_scene(tmp_path, extra="[compute]\nn_modes = 9\n[draw]\nmodes = true\nn_draw = 2\n"
                                     f"window_size = {SMALL}\nbfactors = true\n"))
    (tmp_path / "out").mkdir()
    execute(make_plan(scene), tmp_path / "out", tmp_path)
    modes_png = picture(tmp_path / "out" / "anm_modes.png")
    assert modes_png.shape == (SMALL[1], SMALL[0], 3) and modes_png.std() > MIN_STD
    # the colour bar of the tube's colours (viridis, dark purple to yellow) along the bottom right
    height, width = SMALL[1], SMALL[0]
    strip = modes_png[height - 42:height - 18, int(0.7 * width):int(0.95 * width)].astype(int)
    assert (strip[..., 0] > 200).any() and (strip[..., 2] < 80).any()  # yellow at the top end
    assert ((strip[..., 2] - strip[..., 1]) > 30).any()  # purple at the bottom end
    chart = picture(tmp_path / "out" / "anm_bfactors.png")
    assert chart.shape[1] >= 600 and chart.std() > MIN_STD


def test_network_arrows_are_decimated_for_large_structures() -> None:
    from vibra.pipeline.render import MAX_NETWORK_ARROWS, network_arrow_step

    for n in (10, 76, 100, 101, 1500, 16716):
        step = network_arrow_step(n)
        assert len(range(0, n, step)) <= MAX_NETWORK_ARROWS
        assert step == 1 or len(range(0, n, step - 1)) > MAX_NETWORK_ARROWS  # the smallest step that fits


@pytest.mark.parametrize("pdb, extra, message", [
    ("../1ubi.pdb", "", r"system\.pdb: '\.\./1ubi\.pdb' leads outside the scene's folder"),
    ("missing.pdb", "", r"system\.pdb: 'missing\.pdb': file not found"),
    ("1ubi.pdb", "cutoff = 0.0\n", r"system\.cutoff: must be positive"),
    ("1ubi.pdb", "[draw]\ngif = true\n", r"draw\.gif"),
])
def test_network_scene_refusals(tmp_path: Path, pdb: str, extra: str, message: str) -> None:
    (tmp_path / "scenes").mkdir()
    shutil.copy(UBIQUITIN / "1ubi.pdb", tmp_path / "1ubi.pdb")
    shutil.copy(UBIQUITIN / "1ubi.pdb", tmp_path / "scenes" / "1ubi.pdb")
    with pytest.raises(SceneError, match=message):
        load_scene(network_scene(tmp_path / "scenes", pdb, extra))


def test_network_pdb_symlink_leaving_the_folder_is_refused(tmp_path: Path) -> None:
    (tmp_path / "scenes").mkdir()
    shutil.copy(UBIQUITIN / "1ubi.pdb", tmp_path / "1ubi.pdb")
    os.symlink(tmp_path / "1ubi.pdb", tmp_path / "scenes" / "link.pdb")
    with pytest.raises(SceneError, match=r"system\.pdb: 'link\.pdb' leads outside the scene's folder"):
        load_scene(network_scene(tmp_path / "scenes", "link.pdb"))


def test_network_pdb_without_c_alpha_atoms_is_one_scene_error(tmp_path: Path) -> None:
    (tmp_path / "water.pdb").write_text(
        "HETATM    1  O   HOH A   1       0.000   0.000   0.000  1.00 10.00           O\n"
        "HETATM    2  O   HOH A   2       3.000   0.000   0.000  1.00 10.00           O\nEND\n")
    with pytest.raises(SceneError, match=r"system\.pdb: "):
        validate(load_scene(network_scene(tmp_path, "water.pdb")))


def test_bfactors_need_a_network_scene() -> None:
    with pytest.raises(SceneError, match=r"draw\.bfactors: compares predicted and crystallographic B-factors"):
        Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 4},
                         "draw": {"bfactors": True}}, source="c.toml")
