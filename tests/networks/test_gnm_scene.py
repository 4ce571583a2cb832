"""The ``gnm`` scene builder (issue 48): the anm builder's keys, scalar modes drawn as colours, B-factors.

Truth: ProDy's ``GNM`` (an independent implementation; in the ``test`` extra, skipped cleanly
without it) on the repository's networks/ubiquitin/1ubi.pdb: its Kirchhoff eigenvalues and its
``calcTempFactors`` B-factors against what the scene's plan computes. Tolerances: the two
eigenvalue solvers work on the same 76 x 76 integer Kirchhoff matrix (entries <= 14), so
eigenvalues agree to a few eps ||Gamma|| / lambda ~ 1e-13 relative (asserted 1e-9); the
B-factors are sums of u^2 / lambda over 20 modes scaled to the same sum, asserted to 1e-8.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers.images import check_png

from vibra.pipeline.plan import build_system, execute, make_plan
from vibra.pipeline.plan.analysis import network_fluctuations
from vibra.pipeline.plan.build import network_structure
from vibra.pipeline.scene import Scene, SceneError, load_scene

ROOT = Path(__file__).parents[2]
SCENE = ROOT / "networks" / "ubiquitin" / "ubiquitin-gnm.toml"
PDB = ROOT / "networks" / "ubiquitin" / "1ubi.pdb"


def _scene(tmp_path: Path, **system: object) -> Scene:
    (tmp_path / "1ubi.pdb").write_bytes(PDB.read_bytes())
    return Scene.from_dict({"kind": "network", "system": {"builder": "gnm", "pdb": "1ubi.pdb", **system},
                            "compute": {"n_modes": 21}}, source=tmp_path / "gnm.toml")


@pytest.fixture(scope="module")
def prody_gnm() -> tuple[object, object]:
    prody = pytest.importorskip("prody")
    prody.confProDy(verbosity="none")
    calphas = prody.parsePDB(str(PDB)).select("calpha")
    model = prody.GNM("1ubi")
    model.buildKirchhoff(calphas.getCoords(), cutoff=7.3, gamma=1.0)
    model.calcModes(n_modes=20)  # ProDy's default: the 20 slowest non-zero modes
    return model, calphas


def test_eigenvalues_and_b_factors_are_prodys(prody_gnm: tuple[object, object]) -> None:
    import prody

    model, calphas = prody_gnm
    scene = load_scene(SCENE)
    system = build_system(scene)
    assert system.n_dof == 76 and system.dim == 1
    modes = system.modes(scene.compute.n_modes, vectors=True)
    eigenvalues = np.asarray(modes.omega_squared)[1:]  # the zero mode (a uniform shift) first
    assert abs(modes.omega_squared[0]) < 1e-12
    np.testing.assert_allclose(eigenvalues, model.getEigvals(), rtol=1e-9)
    network = network_fluctuations(network_structure(scene), system, modes)
    assert network.fit is not None and network.fit.method == "sum"
    np.testing.assert_allclose(network.experimental, calphas.getBetas(), rtol=0, atol=0)  # the same file column
    np.testing.assert_allclose(network.fit.predicted, prody.calcTempFactors(model, calphas), rtol=1e-8)
    # the unscaled prediction: B = 8 pi^2 <u^2> for the scalar model (isotropic), not 8 pi^2 / 3 <u^2>
    sq = prody.calcSqFlucts(model)
    np.testing.assert_allclose(network.predicted / sq, 8 * np.pi**2 * np.ones(76), rtol=1e-8)


def test_gnm_takes_the_anm_builders_keys(tmp_path: Path) -> None:
    for keys in ({"residues": [1, 71]}, {"chains": "A"}, {"selection": "CA", "model": 1}):
        system = build_system(_scene(tmp_path, cutoff=7.3, gamma=1.0, **keys))
        assert system.n_dof == (71 if "residues" in keys else 76), keys
    with pytest.raises(SceneError, match=r"system\.masses: unknown key"):
        _scene(tmp_path, masses=1.0)
    with pytest.raises(SceneError, match=r"system\.chains: .*no atoms in chain B; the model holds chain A"):
        build_system(_scene(tmp_path, chains="B"))
    with pytest.raises(SceneError, match=r"system\.altloc: .*altloc is 'A'; the model's alternate locations are none"):
        build_system(_scene(tmp_path, altloc="A"))  # read and passed on, as for anm (1UBI has none)


def test_scene_renders_colours_profiles_and_b_factors(tmp_path: Path) -> None:
    scene = load_scene(SCENE)
    result = execute(make_plan(scene), tmp_path, tmp_path / "work")
    names = set(result.outputs)
    assert {"ubiquitin-gnm_modes.png", "ubiquitin-gnm_profiles.png", "ubiquitin-gnm_bfactors.png"} <= names
    assert not any(name.endswith("_view.json") for name in names)  # no 3-D arrows for scalar modes
    for name in ("ubiquitin-gnm_modes.png", "ubiquitin-gnm_profiles.png"):
        check_png(tmp_path / name)
    captions = dict(zip(result.outputs, result.captions))
    assert "mode 1 (" in captions["ubiquitin-gnm_modes.png"] and "hinges" in captions["ubiquitin-gnm_modes.png"]
