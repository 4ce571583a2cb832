"""Tests of vibra/pipeline/render.py: off-screen pyvista images of chains and molecules.

Rendering must work here (it is the package's main job): these tests fail, never skip,
when it breaks. Images are small (320 x 200) to keep the tests fast.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vibra.pipeline.plan import build_system
from vibra.pipeline.plan.analysis import molecule_symmetry, symmetry_hints
from vibra.pipeline.render import MAX_CHAIN_SITES, MoleculeStructure, SceneRenderer, chain_sites, write_gif, write_png
from vibra.pipeline.scene import Scene

SIZE = (320, 200)
# A rendered image is "not blank" when its pixel standard deviation exceeds this: a uniform
# background gives 0, a single tiny glyph about 1; the smallest real render here gives > 10.
MIN_STD = 5.0


def image(path: Path) -> np.ndarray:
    with Image.open(path) as handle:
        handle.load()  # a truncated PNG raises here
        return np.asarray(handle.convert("RGB"))


def scene(data: dict[str, object]) -> Scene:
    return Scene.from_dict({**data, "draw": {"modes": True, "window_size": list(SIZE)}}, source="t.toml")


@pytest.fixture(scope="module")
def renderer() -> SceneRenderer:
    r = SceneRenderer(SIZE)
    yield r
    r.close()


def test_chain_image_size_content_and_caption(renderer: SceneRenderer, tmp_path: Path) -> None:
    sc = scene({"kind": "chain", "name": "c", "system": {"builder": "linear_chain", "n": 6, "ends": "fixed"}})
    system = build_system(sc)
    modes = system.modes()
    [(name, caption)] = renderer.render_modes(sc, system, modes, [0, 1], tmp_path)
    pixels = image(tmp_path / name)
    assert name == "c_modes.png"
    assert pixels.shape == (SIZE[1], SIZE[0], 3)
    assert pixels.std() > MIN_STD
    assert "axial" in caption and "decimated" not in caption


def test_reused_plotter_renders_each_image_anew(renderer: SceneRenderer, tmp_path: Path) -> None:
    # Regression: a reused plotter must not return the previous screenshot.
    sc = scene({"kind": "molecule", "name": "w", "system": {"builder": "h2o"}})
    system = build_system(sc)
    modes = system.modes()
    outputs = renderer.render_modes(sc, system, modes, [6, 7, 8], tmp_path)
    pictures = [image(tmp_path / name) for name, _ in outputs]
    assert len(pictures) == 3
    for a in range(3):
        for b in range(a + 1, 3):
            assert np.abs(pictures[a].astype(int) - pictures[b].astype(int)).sum() > 0


def test_degenerate_bend_side_by_side(renderer: SceneRenderer, tmp_path: Path) -> None:
    sc = scene({"kind": "molecule", "name": "co2", "system": {"builder": "co2", "dims": 3}})
    system = build_system(sc)
    modes = system.modes()
    structure = MoleculeStructure(("O", "C", "O"), ((0, 1), (1, 2)))
    hints = symmetry_hints(system, modes, [5, 6, 7, 8], structure.symbols, structure.bonds)
    outputs = renderer.render_modes(sc, system, modes, [5, 6, 7, 8], tmp_path, structure=structure, hints=hints)
    names = [name for name, _ in outputs]
    assert names == ["co2_mode5.png", "co2_mode7.png", "co2_mode8.png"]  # the bend pair is one image
    assert "degenerate, x2, side by side" in outputs[0][1]
    # mutual exclusion (centrosymmetric CO2, D_inf_h): symmetric stretch Sigma_g+ Raman only, bend Pi_u
    # and asymmetric stretch Sigma_u+ IR only; the renderer draws the texts it is given (vibra.pipeline.plan.analysis)
    assert "Sigma_g+ (Dinfh): IR inactive, Raman active" in outputs[1][1]
    assert "Pi_u (Dinfh): IR active, Raman inactive" in outputs[0][1]
    assert "Sigma_u+ (Dinfh): IR active, Raman inactive" in outputs[2][1]
    assert "cm⁻¹" in outputs[0][1]
    for name in names:
        assert image(tmp_path / name).std() > MIN_STD


def test_long_chain_is_decimated(renderer: SceneRenderer, tmp_path: Path) -> None:
    sc = scene({"kind": "chain", "name": "long", "system": {"builder": "linear_chain", "n": 500, "ends": "fixed"}})
    system = build_system(sc)
    modes = system.modes(3)
    [(name, caption)] = renderer.render_modes(sc, system, modes, [0], tmp_path)
    assert "one site in 13 shown (39 of 500, evenly spaced)" in caption  # ceil(500 / 41) = 13
    assert image(tmp_path / name).std() > MIN_STD


@pytest.mark.parametrize("n", [41, 42, 64, 500, 10**6])
def test_decimated_chain_sites_are_evenly_spaced(n: int) -> None:
    # Regression: rounding linspace(0, n - 1, 41) drew 64 sites as uneven pairs.
    sites = chain_sites(np.ones(n))
    steps = np.diff(sites)
    assert sites[0] == 0 and len(sites) <= MAX_CHAIN_SITES
    assert np.all(steps == steps[0]) if len(steps) else n == 1
    assert len(sites) == n or steps[0] == -(-n // MAX_CHAIN_SITES)  # the smallest stride that fits


def test_decimated_diatomic_chain_keeps_both_masses() -> None:
    masses = np.tile([1.0, 3.0], 64)  # 128 sites: stride ceil(128 / 41) = 4 would show only m1
    sites = chain_sites(masses)
    assert len(sites) <= MAX_CHAIN_SITES and np.all(np.diff(sites) == sites[1] - sites[0])
    assert set(masses[sites]) == {1.0, 3.0}


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from point p to the segment [a, b]."""
    t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


@pytest.mark.parametrize("builder, dims", [("co2", 1), ("co2", 3), ("h2o", 3)])
def test_molecule_arrows_stay_clear_of_the_bonds(builder: str, dims: int) -> None:
    # Regression: the asymmetric stretch's arrows ran inside the bond tubes and neighbouring
    # atoms, hidden. Invariant from geometry: every point of every arrow lies outside every
    # bond tube (radius 0.1 bond length, as drawn) and outside every other atom's sphere.
    from ase.data import covalent_radii

    from ase.data import atomic_numbers

    from vibra.molecules import bonds_from_distances, symbols_from_masses
    from vibra.pipeline.render_geometry import arrow_start as _arrow_start
    from vibra.pipeline.render_geometry import displacements3 as _displacements3
    from vibra.pipeline.render_geometry import positions3 as _positions3

    system_table = {"builder": builder, **({"dims": dims} if builder == "co2" else {})}
    sc = scene({"kind": "molecule", "name": "m", "system": system_table})
    system = build_system(sc)
    modes = system.modes()
    positions = _positions3(system)
    symbols = symbols_from_masses(system.masses)
    numbers = [atomic_numbers[s] for s in symbols]
    bonds = bonds_from_distances(positions, symbols)
    reference = min(np.linalg.norm(positions[i] - positions[j]) for i, j in bonds)
    radii = 0.35 * covalent_radii[numbers] + 0.1  # as drawn by SceneRenderer
    checked = 0
    for k in np.flatnonzero(~modes.zero_modes(1e-6)):
        displacement = _displacements3(system, modes.shapes[:, k])
        displacement *= 0.8 * reference / np.linalg.norm(displacement, axis=1).max()
        for i in range(len(positions)):
            vector = displacement[i]
            if np.linalg.norm(vector) < 1e-3 * reference:
                continue
            start = _arrow_start(positions, bonds, i, vector, float(radii[i]))
            for t in np.linspace(0.0, 1.0, 21):
                point = start + t * vector
                for a, b in bonds:
                    assert _segment_distance(point, positions[a], positions[b]) > 0.1 * reference, (k, i, t)
                for j in range(len(positions)):
                    if j != i:
                        assert np.linalg.norm(point - positions[j]) > radii[j], (k, i, j, t)
            checked += 1
    assert checked >= 4


def test_beaded_string_arrows_are_transverse(renderer: SceneRenderer, tmp_path: Path) -> None:
    sc = scene({"kind": "chain", "name": "s", "system": {"builder": "beaded_string", "n": 5}})
    system = build_system(sc)
    [(name, caption)] = renderer.render_modes(sc, system, system.modes(), [0], tmp_path)
    assert "transverse" in caption
    assert image(tmp_path / name).std() > MIN_STD


def test_gif_of_a_mode(renderer: SceneRenderer, tmp_path: Path) -> None:
    sc = scene({"kind": "chain", "name": "g", "system": {"builder": "linear_chain", "n": 4, "ends": "fixed"}})
    system = build_system(sc)
    name, caption = renderer.render_gif(sc, system, system.modes(), 0, tmp_path, tmp_path)
    with Image.open(tmp_path / name) as gif:
        assert gif.n_frames == 16 and gif.size == SIZE
    assert "animation of mode 0" in caption


def test_render_needs_shapes(renderer: SceneRenderer, tmp_path: Path) -> None:
    sc = scene({"kind": "chain", "name": "c", "system": {"builder": "linear_chain", "n": 4}})
    system = build_system(sc)
    with pytest.raises(ValueError, match=r"render_modes needs mode shapes; the modes were computed with vectors=False"):
        renderer.render_modes(sc, system, system.modes(vectors=False), [1], tmp_path)


def test_species_parity_by_construction() -> None:
    # O-C-O on x (the seed's axial model, lifted to 3-D): the symmetric stretch is g (Sigma_g+), the
    # asymmetric stretch u (Sigma_u+); a bent molecule (C2v) has no inversion centre, no g/u label.
    from vibra import molecules

    symmetry = molecule_symmetry(molecules.co2(dims=1), molecules.co2(dims=1).modes())
    assert symmetry is not None and symmetry.group == "Dinfh"
    assert symmetry.species == ("", "Sigma_g+", "Sigma_u+")
    assert symmetry.ir_active[1:] == (False, True) and symmetry.raman_active[1:] == (True, False)
    water = molecules.h2o()
    bent = molecule_symmetry(water, water.modes())
    assert bent is not None and bent.group == "C2v"
    assert not any(label.endswith(("g", "u")) for label in bent.species if label)


def test_atomic_writers_leave_no_temp_files(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    frames = [rng.integers(0, 255, (40, 60, 3), dtype=np.uint8) for _ in range(3)]
    write_png(frames[0], tmp_path / "a.png")
    write_gif(frames, tmp_path / "a.gif")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif", "a.png"]
    assert np.array_equal(image(tmp_path / "a.png"), frames[0])  # PNG is lossless


def test_import_vibra_does_not_import_pyvista() -> None:
    code = ("import sys, vibra, vibra.pipeline.scene, vibra.pipeline.plan, vibra.pipeline.report, vibra.cli; "
            "print('pyvista' in sys.modules, 'vtk' in sys.modules, 'phonopy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False", "False"]


# ---------------------------------------------------------------------- views, labels, notes (issue 32)
def _smallest_projected_gap(positions: np.ndarray, direction: np.ndarray) -> float:
    d = direction / np.linalg.norm(direction)
    gaps = [positions[i] - positions[j] for i in range(len(positions)) for j in range(i)]
    return min(float(np.linalg.norm(g - (g @ d) * d)) for g in gaps)


@pytest.mark.parametrize("name", ["CH4", "H2O", "NH3", "C6H6"])
def test_the_chosen_view_hides_no_atom(name: str) -> None:
    # Truth: ASE's geometries; the projected gap is computed here directly, against the old fixed
    # view (elevation 30, azimuth 35) and a dense independent scan of directions.
    from ase.build import molecule as ase_molecule

    from vibra.pipeline.render_geometry import view_direction

    positions = ase_molecule(name).get_positions()
    direction, up = view_direction(positions)
    assert abs(float(direction @ up)) < 1e-12 and abs(float(np.linalg.norm(up)) - 1.0) < 1e-12
    chosen = _smallest_projected_gap(positions, direction)
    rng = np.random.default_rng(0)
    scan = rng.normal(size=(3000, 3))
    best = max(_smallest_projected_gap(positions, d) for d in scan)
    assert chosen >= 0.9 * best  # within 10% of the best of 3000 random directions
    assert chosen > 0.35  # Angstrom: no two atoms (radii 0.2-0.35) overlap on the screen


def test_the_chosen_view_of_a_linear_molecule_shows_its_bend() -> None:
    from vibra.pipeline.render_geometry import view_direction

    positions = np.array([[0.0, 0.0, -1.16], [0.0, 0.0, 0.0], [0.0, 0.0, 1.16]])
    bend = np.array([[1.0, 0.0, 0.0], [-2.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    direction, _ = view_direction(positions, [bend])
    assert abs(direction[2]) < 0.1 and abs(direction[0]) < 0.1  # across the axis and across the bend


def test_labels_are_set_in_unicode_with_matplotlib(tmp_path: Path) -> None:
    from vibra.charts.renders import ColourBar, annotate_render

    blank = np.full((200, 400, 3), 255, dtype=np.uint8)
    labelled = annotate_render(blank, grid=(1, 2), titles=["ν1: 667.0 cm⁻¹", "Πu (D∞h)"], note="10⁶ sites drawn as 41 beads",
                               colour_bar=ColourBar("share (dimensionless)"))
    assert labelled.shape == blank.shape and labelled.dtype == np.uint8
    inked = labelled.min(axis=2) < 128
    assert inked[:30, :200].any() and inked[:30, 200:].any()  # each panel's title in its upper left
    assert inked[-20:, :150].any()                            # the note along the bottom
    assert (np.ptp(labelled[150:195, 280:390].astype(int), axis=2) > 60).any()  # the coloured bar
    with pytest.raises(ValueError, match="titles has 3 entries"):
        annotate_render(blank, grid=(1, 2), titles=["a", "b", "c"])
    with pytest.raises(ValueError, match=r"image must be \(height, width, 3 or 4\) uint8"):
        annotate_render(blank.astype(float))


def test_a_subsampled_chain_says_so_in_the_image(renderer: SceneRenderer, tmp_path: Path) -> None:
    sc = scene({"kind": "chain", "name": "long", "system": {"builder": "linear_chain", "n": 1000, "ends": "fixed"}})
    system = build_system(sc)
    [(name, caption)] = renderer.render_modes(sc, system, system.modes(3), [0], tmp_path)
    assert f"{len(chain_sites(system.masses))} of 1000" in caption
    pixels = image(tmp_path / name)
    assert (pixels[-18:, :300].min(axis=2) < 128).any()  # the note "1,000 sites drawn as 40 beads"


def test_a_short_arrow_keeps_a_visible_head() -> None:
    # the smallest drawn motion stays visible: the head's width does not shrink with the length
    import pyvista as pv

    from vibra.pipeline.render import _arrow

    widths = []
    for length in (0.05, 0.5, 2.0):
        arrow = _arrow(pv, np.zeros(3), np.array([length, 0.0, 0.0]), 0.02)
        x0, x1, y0, y1, _, _ = arrow.bounds
        assert x1 - x0 == pytest.approx(length, rel=1e-6)  # the length stays proportional to the motion
        widths.append(y1 - y0)
    assert widths[0] == pytest.approx(widths[2], rel=0.05) and widths[0] > 0.09  # 2.6 x 0.02 each side
