"""Tests of vibra.molecules.molecule (any molecule by name or Atoms) and of isotope labels in the
builders. Truth comes from ASE (its molecule collection, its `Vibrations` finite differences
of the force field's own forces), the seed's axial CO2 closed form (eq. 157) and the
Teller-Redlich product rule (an exact invariant of isotopic substitution on one K)."""

from __future__ import annotations

import tempfile
import warnings

import numpy as np
import pytest
from ase.build import molecule as ase_molecule
from ase.data import atomic_masses, atomic_numbers
from ase.vibrations import Vibrations

from vibra import molecules as mol
from vibra.molecules.calculator import ValenceForceField
from vibra.units import ASE

M_O = atomic_masses[atomic_numbers["O"]]
M_C13 = 13.00335483507   # NIST AME: 13C


def _moments(positions: np.ndarray, masses: np.ndarray) -> np.ndarray:
    centred = positions - masses @ positions / masses.sum()
    inertia = np.einsum("i,ij,ik->jk", masses, centred, centred)
    return np.linalg.eigvalsh(np.trace(inertia) * np.eye(3) - inertia)


def _teller_redlich(light: mol.System, heavy: mol.System, n_rotations: int) -> tuple[float, float]:
    """(prod omega_heavy / omega_light over the vibrations, the product rule's right-hand side).

    prod_k (omega'_k / omega_k) = sqrt(prod_a (m_a / m'_a)^3 (M' / M)^3 prod_rot (I' / I)),
    over all vibrations of one molecule (Wilson, Decius & Cross, "Molecular Vibrations", 8-5)."""
    w = mol.vibrational_analysis(light).vibration_wavenumbers_cm1()
    w_heavy = mol.vibrational_analysis(heavy).vibration_wavenumbers_cm1()
    m, m_heavy = np.asarray(light.masses), np.asarray(heavy.masses)
    moments = _moments(np.asarray(light.positions), m)[-n_rotations:]
    moments_heavy = _moments(np.asarray(heavy.positions), m_heavy)[-n_rotations:]
    rhs = np.sqrt(np.prod((m / m_heavy) ** 3) * (m_heavy.sum() / m.sum()) ** 3 * np.prod(moments_heavy / moments))
    return float(np.prod(w_heavy / w)), float(rhs)


# ----------------------------------------------------------------- the equilibrium
@pytest.mark.parametrize("name", ["CH4", "NH3", "C6H6", "H2CCHCN", "H2CO", "2-butyne", "C3H4_D2d", "ClF3"])
def test_molecule_is_an_equilibrium_and_k_is_its_hessian(name: str) -> None:
    """The returned geometry is a zero-force point of the valence force field (V = 0: every
    term at its reference), and K equals ASE's finite-difference Hessian of that field's
    forces there. H2CCHCN has a 179.3 degree angle (a linear bend): it is relaxed first.
    C6H6 and H2CCHCN with one torsion constant for all, the others with the typed defaults:
    out-of-plane impropers (H2CO; ClF3's T-shaped chlorine, two of them) and torsions about
    the straight chains of 2-butyne and allene."""
    options = {"torsion": 0.1} if name in ("C6H6", "H2CCHCN") else {}
    system = mol.molecule(name, **options)
    atoms = ase_molecule(name)
    assert system.name == name and system.n_sites == len(atoms)
    np.testing.assert_allclose(system.masses, atoms.get_masses(), rtol=0, atol=0)
    atoms.set_positions(np.asarray(system.positions))
    model = mol.valence_model(atoms, **options)
    energy, forces = model.energy_and_forces(atoms.get_positions())
    assert np.abs(forces).max() < mol.EQUILIBRIUM_FORCE and energy < 1e-14
    if name != "H2CCHCN":   # exact construction: the input geometry itself
        np.testing.assert_array_equal(system.positions, ase_molecule(name).get_positions())
    atoms.calc = ValenceForceField(model)
    with tempfile.TemporaryDirectory() as cache:
        vib = Vibrations(atoms, name=f"{cache}/vib", delta=0.002, nfree=4)
        vib.run()
        reference = vib.get_vibrations().get_hessian_2d()
    K = system.hessian().toarray()
    assert np.abs(K - reference).max() < 1e-6 * np.abs(reference).max()


def test_molecule_from_atoms_keeps_atom_order_and_hill_name() -> None:
    atoms = ase_molecule("CH3OH")
    atoms.rotate(37, "x")
    atoms = atoms[[3, 0, 5, 1, 4, 2]]
    system = mol.molecule(atoms, torsion=0.1)
    np.testing.assert_array_equal(system.positions, atoms.get_positions())
    assert system.name == "CH4O"
    assert mol.vibrational_analysis(system).n_vibrations == 12


def test_molecule_defaults_equal_valence_model_defaults() -> None:
    atoms = ase_molecule("NH3")
    direct = mol.from_atoms(atoms, mol.valence_model(atoms, stretch=40.0))
    assert np.abs((mol.molecule("NH3", stretch=40.0).hessian() - direct.hessian()).toarray()).max() == 0.0


def test_molecule_names_cover_ase_collection() -> None:
    from ase.collections import g2

    names = mol.molecule_names()
    assert set(g2.names) <= set(names) and "biphenyl" in names and list(names) == sorted(names)


# ----------------------------------------------------------------- isotopes
def test_cd4_obeys_the_teller_redlich_product_rule() -> None:
    light = mol.molecule("CH4")
    heavy = mol.molecule("CH4", isotopes=[None, "D", "D", "D", "D"])
    lhs, rhs = _teller_redlich(light, heavy, 3)
    assert lhs == pytest.approx(rhs, rel=1e-10)
    assert mol.molecule("CH4", isotopes={1: "D", 2: "D", 3: "D", 4: "D"}).masses.tolist() == heavy.masses.tolist()
    assert heavy.masses[1] == mol.ISOTOPE_MASSES["D"]


def test_builders_take_isotope_labels() -> None:
    lhs, rhs = _teller_redlich(mol.h2o(), mol.h2o(isotopes=[None, "D", "D"]), 3)
    assert lhs == pytest.approx(rhs, rel=1e-10)
    lhs, rhs = _teller_redlich(mol.co2(), mol.co2(isotopes={0: "18O", 1: "13C", 2: "18O"}), 2)
    assert lhs == pytest.approx(rhs, rel=1e-10)
    # seed 003 eq. 157 with m_C = 13C: omega_3 = sqrt(kappa (1/m_O + 2/m_C))
    axial = mol.co2(dims=1, isotopes=[None, "13C", None]).modes()
    expected = ASE.omega_to_cm1(np.sqrt(mol.CO2_STRETCH * (1 / M_O + 2 / M_C13)))
    assert ASE.omega_to_cm1(axial.omega[-1]) == pytest.approx(expected, rel=1e-12)


def test_molecule_masses_option() -> None:
    masses = ase_molecule("H2O").get_masses() * 1.5
    np.testing.assert_array_equal(mol.molecule("H2O", masses=masses).masses, masses)
    np.testing.assert_array_equal(mol.molecule_atoms("H2O", masses=masses).get_masses(), masses)


# ----------------------------------------------------------------- bad input
def test_unknown_molecule_name_names_it_with_close_matches() -> None:
    with pytest.raises(ValueError, match=r"'Ch4'.*close matches: CH4"):
        mol.molecule("Ch4")
    with pytest.raises(ValueError, match=r"'caffeine' is not in ASE's molecule collection"):
        mol.molecule("caffeine")  # ('methane' is an everyday name now: COMMON_NAMES)
    with pytest.raises(TypeError, match="name_or_atoms must be"):
        mol.molecule(5)  # type: ignore[arg-type]


def test_unknown_isotope_label_lists_the_valid_ones() -> None:
    with pytest.raises(ValueError, match=r"isotopes\[1\] is '4H', not an isotope label.*valid labels: .*13C.*D"):
        mol.molecule("CH4", isotopes=[None, "4H", None, None, None])
    with pytest.raises(ValueError, match=r"isotopes\[0\] is '13C' \(C\) but atom 0 is 'O'"):
        mol.h2o(isotopes={0: "13C"})
    with pytest.raises(ValueError, match=r"isotopes must give 3 labels"):
        mol.co2(isotopes=["18O"])
    with pytest.raises(ValueError, match=r"isotopes\[7\]: atom index out of range"):
        mol.h2o(isotopes={7: "D"})
    with pytest.raises(TypeError, match=r"isotopes\[1\] must be an isotope label"):
        mol.h2o(isotopes=[None, 2.014, None])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="not both"):
        mol.molecule("H2O", isotopes=[None, "D", "D"], masses=[16.0, 2.0, 2.0])


def test_single_atom_and_unknown_keyword_are_refused() -> None:
    with pytest.raises(ValueError, match="single atom"):
        mol.molecule("Na")
    with pytest.raises(TypeError, match="stiffness"):
        mol.molecule("H2O", stiffness=3.0)


def test_planar_molecule_without_torsions_warns_once_naming_the_keywords() -> None:
    """Ethylene holds its twist and folds by default; with torsions and out-of-plane terms
    removed, one SoftModeWarning, when built, says what to pass (issue 48: it was printed twice,
    once more by the analysis, and named no keyword)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert mol.vibrational_analysis(mol.molecule("C2H4")).vibration_wavenumbers_cm1().min() > 500.0
        assert not caught
        mol.vibrational_analysis(mol.molecule("C2H4", torsion=None, out_of_plane=None))
    assert [w.category for w in caught] == [mol.SoftModeWarning]
    message = str(caught[0].message)
    assert "C2H4: 3 motion(s) have no restoring force" in message
    assert 'pass torsion="typed" (the default)' in message and 'pass out_of_plane="typed"' in message


def test_everyday_names_are_understood_and_suggested() -> None:
    """'water', 'ethanol' (any case) are ASE's H2O and CH3CH2OH, same geometry; a misspelt one
    is refused with the everyday name and its formula among the close matches (issue 32: they
    were refused with no suggestion)."""
    import numpy as np
    import pytest

    from vibra import molecules

    for common, formula in (("water", "H2O"), ("Ethanol", "CH3CH2OH"), ("carbon dioxide", "CO2")):
        np.testing.assert_array_equal(molecules.molecule_atoms(common).get_positions(),
                                      molecules.molecule_atoms(formula).get_positions())
    assert molecules.molecule("water").name == "water"
    with pytest.raises(ValueError, match=r"close matches: .*water \(H2O\)"):
        molecules.molecule("watr")
