"""The interactive 3-D view's data, pure Python (issue 46, item 5): `vibra._results.display`
(``modes.show(system)``, the report's view) and `vibra.crystals.animation` (``bands.show(crystal)``).

Truth from outside the code under test: phonopy's own modulation (`Phonopy.run_modulations`, the
complex displacement of every supercell atom for one phonon) for the crystal frames, vibra's
cell-phase `supercell_mode` (the other phase convention, another code path) for the Bloch phase,
the sign convention of omega for the imaginary flag, and sizes counted from the JSON.
"""

from __future__ import annotations

import dataclasses
import json
import re
import warnings

import numpy as np
import pytest

import vibra
from vibra import crystals, molecules
from vibra._results.display import MAX_NOTEBOOK_NUMBERS, MAX_SITES, View, system_view, viewer_html
from vibra.crystals.animation import MAX_ATOMS, MAX_REPEATS, band_view, frame_positions, repeats

#: The view data keeps the patterns (largest atom 1) to 5 decimals: each component within 5e-6,
#: a complex entry within 7.1e-6, times a unit phase; 2e-5 leaves room for the fit of the global factor.
PATTERN_ATOL = 2e-5


def _rock_salt() -> crystals.Crystal:
    return crystals.rock_salt(5.64, [22.99, 35.45], 1.0, units="ASE", shells=2)  # unlike masses: no degeneracy at generic q


def _view_at(crystal: crystals.Crystal, q: list[float]) -> tuple[dict, int, np.ndarray]:
    """The view data of a band ending at `q`, the index of its point there, and the ascending rank of each branch."""
    bands = crystal.band_structure([["GAMMA", "P"]], points={"GAMMA": [0, 0, 0], "P": q}, npoints=6)
    data = band_view(crystal, bands)
    last = len(bands.qpoints) - 1
    point = next(p for p, entry in enumerate(data["points"]) if entry["index"] == last)
    rank = np.empty(crystal.n_branches, dtype=int)
    rank[np.argsort(bands.omega[last], kind="stable")] = np.arange(crystal.n_branches)
    return data, point, rank


def _complex_field(data: dict, point: int, branch: int) -> tuple[np.ndarray, np.ndarray]:
    """The complex displacements A (frames 0 and a quarter period: Re A and Im A) and the rest positions."""
    frames, imaginary = frame_positions(data, point, branch)
    assert not imaginary
    entry, count = data["points"][point], data["frames"]
    n = entry["repeats"]
    cells = np.array([(a, b, c) for a in range(n[0]) for b in range(n[1]) for c in range(n[2])], dtype=float)
    rest = (cells[:, None, :] + np.asarray(data["fractional"])[None]).reshape(-1, 3) @ np.asarray(data["cell"])
    return (frames[0] - rest + 1j * (frames[count // 4] - rest)) / data["scale"], rest


@pytest.mark.parametrize(("q", "ascending"), [([0.5, 0.0, 0.5], 5), ([0.5, 0.5, 0.5], 5), ([0.3, 0.1, 0.2], 4),
                                               ([0.3, 0.1, 0.2], 0)], ids=["X-top", "L-top", "generic-4", "generic-0"])
def test_supercell_frames_are_phonopys_modulation(q: list[float], ascending: int) -> None:
    crystal = _rock_salt()
    data, point, rank = _view_at(crystal, q)
    branch = int(np.nonzero(rank == ascending)[0][0])
    field, rest = _complex_field(data, point, branch)
    n = data["points"][point]["repeats"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        modulation = crystal.to_phonopy().run_modulations(np.diag(n), [[q, ascending, 1.0, 0.0]])
    theirs, supercell = modulation.modulations[0], modulation.supercell
    big = np.diag(n) @ crystal.cell
    gap = (rest @ np.linalg.inv(big))[:, None, :] - (supercell.positions @ np.linalg.inv(big))[None, :, :]
    gap -= np.rint(gap)
    order = np.argmin(np.abs(gap).sum(axis=-1), axis=1)  # phonopy's atom at each of ours
    assert sorted(order.tolist()) == list(range(len(rest)))
    theirs = theirs[order]
    factor = np.vdot(theirs.ravel(), field.ravel()) / np.vdot(theirs.ravel(), theirs.ravel())  # amplitude and phase
    np.testing.assert_allclose(field, factor * theirs, rtol=0, atol=PATTERN_ATOL)
    # the Bloch phase of the lattice translation alone (the "cell" convention) would not match for a
    # q with a non-integer q . x_j (the Cl sublattice at x = (1/2, 1/2, 1/2)) where both sublattices move
    both = np.abs(field[0::2]).max() > 0.1 and np.abs(field[1::2]).max() > 0.1
    if both and not np.allclose(np.asarray(q) @ [0.5, 0.5, 0.5] % 1.0, 0.0):
        flipped = field * np.exp(-2j * np.pi * (np.asarray(q) @ crystal.fractional.T))[np.tile(np.arange(2), len(rest) // 2)][:, None]
        other = np.vdot(theirs.ravel(), flipped.ravel()) / np.vdot(theirs.ravel(), theirs.ravel())
        assert np.abs(flipped - other * theirs).max() > 0.1


def test_the_frames_match_the_cell_phase_supercell_mode() -> None:
    crystal = _rock_salt()
    q = [0.3, 0.1, 0.2]
    data, point, rank = _view_at(crystal, q)
    branch = int(np.nonzero(rank == 3)[0][0])
    field, _ = _complex_field(data, point, branch)
    mode = crystal.supercell_mode(q, 3, np.diag(data["points"][point]["repeats"]))  # cell by cell, atoms inside: ours
    factor = np.vdot(mode.amplitudes.ravel(), field.ravel()) / np.vdot(mode.amplitudes.ravel(), mode.amplitudes.ravel())
    np.testing.assert_allclose(field, factor * mode.amplitudes, rtol=0, atol=PATTERN_ATOL)


def test_an_imaginary_mode_is_flagged_and_grows_from_rest() -> None:
    stable = crystals.rock_salt(5.64, [22.99, 35.45], 1.0, units="ASE")
    fc = stable.require_force_constants()
    unstable = stable.with_force_constants(dataclasses.replace(fc, blocks=-fc.blocks))  # omega^2 -> -omega^2
    bands = unstable.band_structure(npoints=40)
    data = band_view(unstable, bands)
    assert "imaginary" in data["note"]
    point = next(p for p, e in enumerate(data["points"]) if e["index"] == data["bands"]["labels"][1][0])  # X
    values = data["bands"]["values"][data["points"][point]["index"]]
    assert min(values) < 0  # vibra's sign: omega^2 < 0 is reported as -|omega|
    frames, imaginary = frame_positions(data, point, int(np.argmin(values)))
    assert imaginary
    moved = np.linalg.norm((frames - frames[0]).reshape(len(frames), -1), axis=1)
    assert moved[0] == 0.0 and np.all(np.diff(moved) > 0)  # one static pattern, growing: s = t / (n - 1)
    pattern = frames[-1] - frames[0]
    np.testing.assert_allclose(frames[len(frames) // 2] - frames[0], pattern * (len(frames) // 2) / (len(frames) - 1),
                               atol=1e-12)
    _, real = frame_positions(data, point, int(np.argmax(values)))
    assert not real or max(values) < 0


def test_repeats_show_one_wavelength_within_the_caps() -> None:
    crystal = _rock_salt()
    assert repeats(crystal, [0.5, 0.0, 0.5]).tolist() == [2, 2, 2]           # at least 2 per axis
    assert repeats(crystal, [0.25, 0.0, -0.2]).tolist() == [4, 2, 5]         # ceil(1 / |q_i|)
    assert repeats(crystal, [0.01, 0.0, 0.0]).tolist() == [MAX_REPEATS, 2, 2]
    assert repeats(crystal, [1.25, 0.0, 0.0]).tolist() == [4, 2, 2]          # q reduced into the zone
    big = repeats(crystal, [0.01, 0.01, 0.01])
    assert big.prod() * crystal.n_atoms <= MAX_ATOMS


def test_band_view_caps_its_patterns_and_keeps_the_special_points() -> None:
    crystal = _rock_salt()
    bands = crystal.band_structure(npoints=300)
    whole = band_view(crystal, bands)
    capped = band_view(crystal, bands, max_numbers=20_000)
    assert len(whole["points"]) == 300 and len(capped["points"]) < 300
    numbers = sum(len(v) for e in capped["points"] for v in e["vectors"])
    labels = {k for k, _ in capped["bands"]["labels"]}
    assert labels <= {e["index"] for e in capped["points"]}
    assert numbers <= 20_000 + len(labels) * 72 and "every" in capped["note"]
    assert [t for _, t in whole["bands"]["labels"]] == ["Γ", "X", "U|K", "Γ", "L", "W", "X"]
    with pytest.raises(ValueError, match=r"unit is 'meV'; expected one of THz, cm\^-1"):
        band_view(crystal, bands, unit="meV")
    with pytest.raises(ValueError, match=r"bands have 6 branches; crystal 'fcc' has 3"):
        band_view(crystals.fcc(1.0, 1.0, 1.0), bands)


def test_show_gives_a_view_with_a_one_line_repr_and_unique_ids() -> None:
    water = molecules.molecule("water")
    modes = water.modes()
    view = modes.show(water)
    assert isinstance(view, View) and "\n" not in repr(view) and "\n" not in repr(modes)
    assert [m["label"].split(":")[0] for m in view.data["modes"]] == ["mode 6", "mode 7", "mode 8"]  # rigid ones left out
    assert view.data["elements"] == ["O", "H", "H"] and sorted(map(tuple, view.data["bonds"])) == [(0, 1), (0, 2)]
    first, second = view._repr_html_(), view._repr_html_()
    ids = re.findall(r"id='(vibra-view-[^']+)'", first + second)
    assert len(ids) == 2 and ids[0] != ids[1]
    assert first.count("<script>(function (define, exports, module)") == 1  # 3Dmol.js inlined once per output
    assert "src=" not in first and "http" not in first.split("view-data")[0].replace("https://3dmol", "")
    assert viewer_html(view.data, assets="../assets").count("../assets/") == 2  # the report links the same two


def test_a_large_network_embeds_a_capped_view_and_says_so() -> None:
    rng = np.random.default_rng(7)
    n_sites = 16_700  # 50,100 dofs
    walk = np.cumsum(rng.normal(size=(n_sites, 3)) * 2.2, axis=0)
    pairs = np.stack([np.arange(n_sites - 1), np.arange(1, n_sites)], axis=1)
    system = vibra.System.from_springs(walk, 1.0, pairs, 1.0)
    shapes = np.zeros((system.n_dof, 40))
    shapes[np.arange(40), np.arange(40)] = 1.0
    modes = vibra.Modes(omega=np.arange(1.0, 41.0), vectors=shapes, shapes=shapes, mass=np.ones(system.n_dof),
                        omega_error=np.zeros(40), residual=0.0, orthogonality=0.0, solver="dense")
    view = system_view(system, modes)
    numbers = sum(3 * len(m["vectors"]) for m in view.data["modes"])
    assert len(view.data["positions"]) <= MAX_SITES and numbers <= MAX_NOTEBOOK_NUMBERS
    assert "4th site shown (4175 of 16700)" in view.data["note"] and "modes embedded" in view.data["note"]
    size = len(view._repr_html_().encode())
    assert size < 1.2e6, size  # 3Dmol.js (~0.54 MB) and at most ~0.5 MB of data
    assert "modes embedded" in view._repr_html_()


def test_show_refuses_what_it_cannot_draw() -> None:
    chain = vibra.System.from_springs([0.0, 1.0, 2.0], 1.0, [[0, 1], [1, 2]], 1.0)
    other = vibra.System.from_springs([0.0, 1.0], 1.0, [[0, 1]], 1.0)
    with pytest.raises(ValueError, match=r"modes have 3 dofs; system 'system' has 2"):
        chain.modes().show(other)
    with pytest.raises(ValueError, match=r"indices\[0\] is 7; expected a mode index from 0 to 2"):
        chain.modes().show(chain, [7])
    with pytest.raises(ValueError, match="no shapes"):
        chain.modes(vectors=False).show(chain)
    with pytest.raises(TypeError, match="vibra.System with positions"):
        chain.modes().show("chain")
    with pytest.raises(ValueError, match=r"path must end in \.html"):
        chain.modes().show(chain).save("view.png")


def test_the_view_data_is_plain_json() -> None:
    crystal = _rock_salt()
    data = band_view(crystal, crystal.band_structure(npoints=20))
    assert json.loads(json.dumps(data, allow_nan=False)) == data


def test_a_polar_gamma_point_keeps_the_lo_to_split_of_its_segment() -> None:
    # each pattern at Gamma solves D(Gamma, direction of its segment) with the band's own omega^2:
    # D (sqrt(m) u) = omega^2 (sqrt(m) u), D from vibra.crystals.dynamical_matrices (phonopy's nac_q_direction)
    salt = crystals.rock_salt(5.64, [22.99, 35.45], 2.0, shells=2, units="ASE")
    polar = salt.with_nac(np.array([np.eye(3), -np.eye(3)]), 2.0 * np.eye(3))
    bands = polar.band_structure([["GAMMA", "X"]], npoints=12)
    data = band_view(polar, bands)
    entry = data["points"][0]
    assert entry["index"] == 0 and np.allclose(entry["q"], 0.0)
    matrix = crystals.dynamical_matrices(polar, [[0.0, 0.0, 0.0]], q_direction=bands.qpoints[-1])[0]
    weights = np.sqrt(np.repeat(polar.masses, 3))
    for branch in range(polar.n_branches):
        pairs = np.asarray(entry["vectors"][branch]).reshape(-1, 2)
        vector = (pairs[:, 0] + 1j * pairs[:, 1]) * weights
        vector /= np.linalg.norm(vector)
        value = np.sign(bands.omega[0, branch]) * bands.omega[0, branch] ** 2
        residual = np.linalg.norm(matrix @ vector - value * vector) / np.abs(np.linalg.eigvalsh(matrix)).max()
        assert residual < 1e-4, (branch, residual)  # the patterns are kept to 5 decimals (module PATTERN_ATOL)
    assert bands.frequencies_thz()[0, -1] - bands.frequencies_thz()[0, -2] > 0.5  # LO above TO: the split is there


def test_a_molecule_from_a_bare_hessian_is_drawn_with_its_bonds() -> None:
    """A molecule whose Hessian came without bond terms (an engine's, here the valence model's
    Hessian handed over as a matrix) is drawn with the bonds its covalent radii give: the same
    pairs as the bond-stretch terms of the model it came from (water: O-H twice, no H-H)."""
    water = molecules.h2o()
    bare = vibra.System.from_hessian(water.positions, water.masses, water.hessian().toarray(), units=water.units,
                                     name="water").with_symbols(water.symbols)
    data = bare.modes().show(bare).data
    assert sorted(map(tuple, data["bonds"])) == sorted(map(tuple, water.modes().show(water).data["bonds"]))
    assert sorted(map(tuple, data["bonds"])) == [(0, 1), (0, 2)]
