"""Elastic network models of proteins (ANM, GNM), their fluctuations and B-factors, from structure files.

- `models`: the `anm` and `gnm` builders, thermal fluctuations, predicted B-factors
- `pdb`: `from_pdb`, the PDB / mmCIF reader (Biopython) and its `Structure`

The names below are those of both, as ``vibra.networks.anm``, ``vibra.networks.from_pdb``.
"""

from __future__ import annotations

from vibra.networks.models import (
    BOLTZMANN_KCAL_PER_MOL, RIGID_RTOL, Fluctuations, anm, b_factor_correlation, contact_pairs,
    fluctuations, gnm, predicted_b_factors, square_fluctuations,
)
from vibra.networks.pdb import MAX_FILE_BYTES, Structure, StructureWarning, check_pdb_text, from_pdb

__all__ = [
    "Structure", "StructureWarning", "check_pdb_text", "Fluctuations", "contact_pairs", "anm", "gnm", "from_pdb",
    "fluctuations",
    "square_fluctuations", "predicted_b_factors", "b_factor_correlation", "BOLTZMANN_KCAL_PER_MOL",
    "RIGID_RTOL", "MAX_FILE_BYTES",
]
