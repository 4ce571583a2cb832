"""`PySCFEngine`: Hartree-Fock and DFT from PySCF (optional extra ``vibra[pyscf]``) behind the
`vibra.molecules.engines.Engine` protocol.

What is analytic and what is not:

- energy, forces (analytic gradients) and the dipole moment (``mf.dip_moment``, nuclear and
  electronic parts, about the origin of the coordinates): PySCF's own;
- the Hessian: PySCF's analytic second derivatives (``mf.Hessian()``, RHF, UHF, RKS, UKS);
- the static polarisability: ``"analytic"``, coupled-perturbed (CPHF / CPKS) linear response
  with PySCF's own solver (`pyscf.scf.cphf`) and response functions (``mf.gen_response``, which
  include the exchange-correlation kernel for DFT), restricted closed-shell references only;
  or ``"finite field"``, central differences of the dipole in a uniform electric field +-F
  added to the core Hamiltonian (H' = +F . r for each electron), which works for every
  reference. ``"auto"`` takes the analytic response where it applies. The extension package
  ``pyscf.prop.polarizability`` is not used: it is not part of PySCF 2.x and no longer
  maintained; its RHF code computes the same CPHF response.

Every `compute` builds the molecule and runs the SCF from PySCF's default initial guess, so the
result does not depend on what ran before (the same numbers serially and on Dask workers). Its
convergence threshold then sets the noise that the finite differences divide by their step:
`noise` estimates it from ``conv_tol_grad`` (the orbital-gradient threshold), a bound on the
error of the density to first order, and so of the forces and the dipole.

Coordinates go to PySCF in bohr and results come back through scipy's CODATA constants
(Hartree in eV, the bohr in Angstrom), the constants of the rest of vibra.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any, Collection, Literal, Mapping

import numpy as np
from numpy.typing import NDArray
from scipy import constants

from vibra._core import validate as _validate
from vibra.molecules.engines.protocol import EngineResult

if TYPE_CHECKING:
    from pyscf.gto import Mole
    from pyscf.scf.hf import SCF

__all__ = ["PySCFEngine", "HARTREE_EV", "BOHR_ANGSTROM", "require_pyscf"]

#: The Hartree energy in eV (scipy.constants, CODATA).
HARTREE_EV = constants.physical_constants["Hartree energy in eV"][0]
#: The bohr radius in Angstrom (scipy.constants, CODATA).
BOHR_ANGSTROM = constants.physical_constants["Bohr radius"][0] / constants.angstrom

_POLARIZABILITY = ("auto", "analytic", "finite field")
_BASIS_WORDS = {"pvdz": "pVDZ", "pvtz": "pVTZ", "pvqz": "pVQZ", "pcvdz": "pCVDZ", "pcvtz": "pCVTZ",
                "svp": "SVP", "tzvp": "TZVP", "tzvpp": "TZVPP", "qzvp": "QZVP", "qzvpp": "QZVPP"}


def require_pyscf() -> ModuleType:
    """The `pyscf` module, or an ImportError that names the extra to install."""
    try:
        import pyscf
    except ImportError as error:
        raise ImportError("PySCF is not installed; install the extra: pip install 'vibra[pyscf]'") from error
    return pyscf


@dataclass(frozen=True)
class PySCFEngine:
    """Hartree-Fock or Kohn-Sham DFT from PySCF, in any basis it ships (module docstring).

    Parameters
    ----------
    method : str
        ``"hf"`` for Hartree-Fock, or an exchange-correlation functional PySCF knows
        (``"b3lyp"``, ``"pbe"``, ``"pbe0"``, ``"lda"``, ...) for DFT.
    basis : str
        A basis set name PySCF ships (``"sto-3g"``, ``"6-31g*"``, ``"cc-pvdz"``, ``"def2-svp"``).
    charge : int
        Total charge, in e.
    spin : int
        Number of unpaired electrons, 2S (0: restricted RHF / RKS; else UHF / UKS).
    polarizability : {"auto", "analytic", "finite field"}
        How the static polarisability is computed (module docstring).
    field : float
        Finite-field step F, in atomic units of field (E_h / (e a_0), 5.14e11 V/m).
    conv_tol : float
        SCF energy convergence threshold, in Hartree.
    conv_tol_grad : float, optional
        SCF orbital-gradient threshold (atomic units); the noise estimate of `noise`. Default
        1e-7 for a closed shell, 1e-6 for an open one (whose SCF in a field can stall between
        the two).
    grid_level : int
        DFT integration grid level (PySCF's ``grids.level``, 0 to 9).

    Raises
    ------
    ImportError
        PySCF is not installed (the message names ``vibra[pyscf]``).
    TypeError, ValueError
        A setting of the wrong kind or out of range (named).
    """

    method: str = "hf"
    basis: str = "sto-3g"
    charge: int = 0
    spin: int = 0
    polarizability: Literal["auto", "analytic", "finite field"] = "auto"
    field: float = 1e-3
    conv_tol: float = 1e-11
    conv_tol_grad: float | None = None
    grid_level: int = 3

    def __post_init__(self) -> None:
        for name in ("method", "basis"):
            value = getattr(self, name)
            if not isinstance(value, str) or not value.strip():
                raise TypeError(f"{name} must be a non-empty str, got {value!r}")
        for name in ("charge", "spin", "grid_level"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise TypeError(f"{name} must be an int, got {type(value).__name__}")
        if self.spin < 0:
            raise ValueError(f"spin is {self.spin}; expected the number of unpaired electrons, >= 0")
        _validate.choice(self.polarizability, "polarizability", _POLARIZABILITY)
        if self.polarizability == "analytic" and self.spin != 0:
            raise ValueError("polarizability='analytic' needs a restricted closed-shell reference (spin=0); "
                             "use 'finite field'")
        for name in ("field", "conv_tol", "conv_tol_grad"):
            if getattr(self, name) is not None:
                _validate.positive_scalar(getattr(self, name), name)
        require_pyscf()

    # ------------------------------------------------------------------ the protocol
    @property
    def level(self) -> str:
        """``"RHF/STO-3G"``, ``"UHF/6-31G*"``, ``"B3LYP/cc-pVDZ"``: method (functional) / basis."""
        if self.method.lower() == "hf":
            name = "RHF" if self.spin == 0 else "UHF"
        else:
            name = self.method.upper()
        return f"{name}/{_basis_label(self.basis)}"

    @property
    def capabilities(self) -> frozenset[str]:
        """Dipole, polarisability and analytic Hessian: all three."""
        return frozenset({"dipole", "polarizability", "hessian"})

    @property
    def restricted(self) -> bool:
        """Whether the reference is restricted closed-shell (RHF / RKS)."""
        return self.spin == 0

    @property
    def gradient_threshold(self) -> float:
        """The SCF orbital-gradient threshold in use: `conv_tol_grad`, or its default."""
        if self.conv_tol_grad is not None:
            return float(self.conv_tol_grad)
        return 1e-7 if self.restricted else 1e-6

    @property
    def polarizability_method(self) -> str:
        """How `compute` gets the polarisability, in words."""
        if self.polarizability == "analytic" or (self.polarizability == "auto" and self.restricted):
            return "analytic response (CPHF)" if self.method.lower() == "hf" else "analytic response (CPKS)"
        return f"finite field (+-{self.field:g} a.u. of field, central differences of the dipole)"

    @property
    def methods(self) -> Mapping[str, str]:
        """How each value is computed, in words."""
        return {"forces": "analytic gradient", "dipole": "SCF density (mf.dip_moment)",
                "polarizability": self.polarizability_method, "hessian": "analytic (pyscf.hessian)"}

    @property
    def noise(self) -> Mapping[str, float]:
        """Noise estimates from ``conv_tol_grad`` (module docstring): forces eV / Angstrom, dipole e
        Angstrom, polarisability Angstrom^3 (the analytic response: the same relative level; the
        finite field: the dipole noise over the field step)."""
        g = self.gradient_threshold
        alpha = g if not self.polarizability_method.startswith("finite") else g / float(self.field)
        return {"forces": g * HARTREE_EV / BOHR_ANGSTROM, "dipole": g * BOHR_ANGSTROM,
                "polarizability": alpha * BOHR_ANGSTROM**3}

    def compute(self, numbers: NDArray[np.int_], positions: NDArray[np.float64],
                properties: Collection[str] = ()) -> EngineResult:
        """Energy (eV), forces (eV / Angstrom) and, when asked, dipole (e Angstrom) and
        polarisability (Angstrom^3) at one geometry (Angstrom), from a fresh SCF.

        Raises
        ------
        ValueError
            An unknown property.
        RuntimeError
            The SCF (or the response) did not converge.
        """
        unknown = [name for name in properties if name not in ("dipole", "polarizability")]
        if unknown:
            raise ValueError(f"unknown property {unknown[0]!r}; expected 'dipole' or 'polarizability'")
        mf = self.scf(numbers, positions)
        gradient = mf.nuc_grad_method().kernel()
        forces = -np.asarray(gradient, dtype=float) * (HARTREE_EV / BOHR_ANGSTROM)
        dipole = _dipole(mf) * BOHR_ANGSTROM if "dipole" in properties else None
        alpha = None
        if "polarizability" in properties:
            alpha = (self._analytic_polarizability(mf) if self.polarizability_method.startswith("analytic")
                     else self._finite_field_polarizability(mf)) * BOHR_ANGSTROM**3
        return EngineResult(energy=float(mf.e_tot) * HARTREE_EV, forces=forces, dipole=dipole, polarizability=alpha)

    def hessian(self, numbers: NDArray[np.int_], positions: NDArray[np.float64]) -> NDArray[np.float64]:
        """PySCF's analytic Hessian at one geometry, (3 n_atoms, 3 n_atoms) in eV / Angstrom^2."""
        mf = self.scf(numbers, positions)
        blocks = np.asarray(mf.Hessian().kernel(), dtype=float)      # (n, n, 3, 3), E_h / a_0^2
        n = blocks.shape[0]
        return blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n) * (HARTREE_EV / BOHR_ANGSTROM**2)

    # ------------------------------------------------------------------ PySCF
    def molecule(self, numbers: NDArray[np.int_], positions: NDArray[np.float64]) -> Mole:
        """The PySCF ``Mole`` at `positions` (Angstrom, passed in bohr)."""
        from pyscf import gto

        bohr = np.asarray(positions, dtype=float) / BOHR_ANGSTROM
        atom = [(int(z), tuple(float(x) for x in r)) for z, r in zip(np.asarray(numbers), bohr)]
        try:
            return gto.M(atom=atom, basis=self.basis, charge=int(self.charge), spin=int(self.spin), unit="Bohr",
                         verbose=0)
        except (KeyError, RuntimeError, ValueError) as error:
            raise ValueError(f"PySCF cannot build the molecule with basis {self.basis!r}, charge {self.charge}, "
                             f"spin {self.spin}: {type(error).__name__}: {error}") from error

    def scf(self, numbers: NDArray[np.int_], positions: NDArray[np.float64]) -> SCF:
        """A converged PySCF mean-field object at one geometry (RuntimeError when it does not converge)."""
        mf = _converged(self._mean_field(self.molecule(numbers, positions)), None)
        if not mf.converged:
            raise RuntimeError(f"{self.level}: the SCF did not converge (DIIS, then second-order)")
        return mf

    def _mean_field(self, mol: Any) -> Any:
        from pyscf import dft, scf

        if self.method.lower() == "hf":
            mf = scf.RHF(mol) if self.restricted else scf.UHF(mol)
        else:
            mf = dft.RKS(mol) if self.restricted else dft.UKS(mol)
            mf.xc = self.method
            mf.grids.level = int(self.grid_level)
        mf.conv_tol = float(self.conv_tol)
        mf.conv_tol_grad = self.gradient_threshold
        mf.verbose = 0
        return mf

    def _analytic_polarizability(self, mf: Any) -> NDArray[np.float64]:
        """CPHF / CPKS static polarisability, (3, 3) in bohr^3 (restricted references)."""
        from pyscf.scf import cphf

        mol = mf.mol
        occupied = mf.mo_occ > 0
        coefficients, occupied_orbitals = mf.mo_coeff, mf.mo_coeff[:, occupied]
        with mol.with_common_orig(_charge_centre(mol)):
            dipole_integrals = mol.intor_symmetric("int1e_r", comp=3)
        h1 = np.einsum("xpq,pi,qj->xij", dipole_integrals, coefficients, occupied_orbitals)
        response = mf.gen_response(hermi=1)
        n_ao, n_mo = coefficients.shape
        n_occ = occupied_orbitals.shape[1]

        def induced(first_order: NDArray[np.float64]) -> NDArray[np.float64]:
            first_order = first_order.reshape(-1, n_mo, n_occ)
            densities = np.empty((len(first_order), n_ao, n_ao))
            for k, x in enumerate(first_order):
                density = coefficients @ (2.0 * x) @ occupied_orbitals.T
                densities[k] = density + density.T
            potential = response(densities)
            return np.einsum("xpq,pi,qj->xij", potential, coefficients, occupied_orbitals).reshape(-1, n_mo * n_occ)

        first, _ = cphf.solve(induced, mf.mo_energy, mf.mo_occ, h1, np.zeros_like(h1), max_cycle=100,
                              tol=min(1e-10, self.gradient_threshold**2))
        e2 = np.einsum("xpi,ypi->xy", h1, first)
        return np.asarray(-2.0 * (e2 + e2.T), dtype=float)        # -d2E/dF2; x2 for double occupancy

    def _finite_field_polarizability(self, mf: Any) -> NDArray[np.float64]:
        """alpha[:, b] = (mu(+F e_b) - mu(-F e_b)) / 2F, (3, 3) in bohr^3, symmetrised (alpha + alpha^T) / 2."""
        mol = mf.mol
        with mol.with_common_orig(_charge_centre(mol)):
            dipole_integrals = mol.intor_symmetric("int1e_r", comp=3)
        core = mf.get_hcore()
        start = mf.make_rdm1()
        alpha = np.empty((3, 3))
        for b in range(3):
            moments = []
            for sign in (1.0, -1.0):
                field_mf = self._mean_field(mol)
                perturbed = core + sign * float(self.field) * dipole_integrals[b]   # H' = +F r_b per electron
                field_mf.get_hcore = lambda *args, _h=perturbed: _h
                field_mf = _converged(field_mf, start)
                if not field_mf.converged:
                    raise RuntimeError(f"{self.level}: the SCF in a field of {sign * self.field:+g} a.u. along "
                                       f"{'xyz'[b]} did not converge")
                moments.append(_dipole(field_mf))
            alpha[:, b] = (moments[0] - moments[1]) / (2.0 * float(self.field))
        return (alpha + alpha.T) / 2.0


def _converged(mf: Any, start: Any) -> Any:
    """`mf` after its SCF from `start` (None: PySCF's initial guess); where DIIS does not converge
    (an open shell in a field), PySCF's second-order solver continues from where it stopped."""
    mf.kernel(start) if start is not None else mf.kernel()
    if mf.converged:
        return mf
    second = mf.newton()
    second.kernel(mf.make_rdm1())
    return second


def _dipole(mf: Any) -> NDArray[np.float64]:
    """The dipole moment about the origin, e bohr (nuclear minus electronic)."""
    return np.asarray(mf.dip_moment(unit="AU", verbose=0), dtype=float)


def _charge_centre(mol: Any) -> NDArray[np.float64]:
    charges = mol.atom_charges()
    return np.asarray(np.einsum("i,ix->x", charges, mol.atom_coords()) / charges.sum(), dtype=float)


def _basis_label(basis: str) -> str:
    """A basis name as papers write it: STO-3G, 6-31G*, cc-pVDZ, aug-cc-pVTZ, def2-SVP."""
    parts = basis.strip().split("-")
    out = []
    for part in parts:
        lower = part.lower()
        if lower in ("cc", "aug", "def2", "jun", "may"):
            out.append(lower)
        elif lower in _BASIS_WORDS:
            out.append(_BASIS_WORDS[lower])
        else:
            out.append(part.upper())
    return "-".join(out)
