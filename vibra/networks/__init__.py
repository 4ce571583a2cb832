"""Elastic network models of proteins (ANM, GNM), their fluctuations and B-factors, from structure files.

- `models`: the `anm` and `gnm` builders, thermal fluctuations, predicted B-factors
- `pdb`: `from_pdb`, the PDB / mmCIF reader (Biopython) and its `Structure`
- `assemblies`: the biological-assembly records (REMARK 350 BIOMT, mmCIF) `from_pdb(assembly=...)` applies
- `analysis`: cross-correlations, fitted B-factors, collectivity, hinges, perturbation response,
  the NMWiz export (ProDy's conventions, no dense 3N x 3N covariance)

The names below are those of both, as ``vibra.networks.anm``, ``vibra.networks.from_pdb``.
"""

from __future__ import annotations

from vibra.networks.models import (
    BOLTZMANN_KCAL_PER_MOL, RIGID_RTOL, Fluctuations, anm, b_factor_correlation, contact_pairs,
    fluctuations, gnm, predicted_b_factors, square_fluctuations,
)
from vibra.networks.pdb import MAX_FILE_BYTES, Structure, StructureWarning, check_pdb_text, from_pdb
from vibra.networks.analysis import (
    BFACTOR_METHODS, BFactorFit, DeformationOverlap, PerturbationResponse, collectivity, cross_correlations,
    deformation_overlap, fit_bfactors, hinges, perturbation_response, superpose, write_nmd,
)

__all__ = [
    "Structure", "StructureWarning", "check_pdb_text", "Fluctuations", "contact_pairs", "anm", "gnm", "from_pdb",
    "fluctuations",
    "square_fluctuations", "predicted_b_factors", "b_factor_correlation", "BOLTZMANN_KCAL_PER_MOL",
    "RIGID_RTOL", "MAX_FILE_BYTES", "BFACTOR_METHODS", "BFactorFit", "PerturbationResponse", "collectivity",
    "cross_correlations",
    "fit_bfactors", "hinges", "perturbation_response", "write_nmd", "DeformationOverlap", "deformation_overlap",
    "superpose",
]
