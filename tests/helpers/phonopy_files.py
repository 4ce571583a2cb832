"""phonopy's own files for a vibra crystal, written by phonopy (shared by the crystal-file and CLI tests)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def write_force_sets(crystal: Any, folder: Path) -> dict[str, Any]:
    """Write ``structure.yaml`` and ``FORCE_CONSTANTS`` (vibra's writers), then phonopy's
    displacement dataset at 0.01 Å with forces -Phi u from phonopy's own force constants (exact for
    springs) as ``FORCE_SETS`` and ``phonopy_disp.yaml`` (phonopy's writers). Returns the dataset."""
    from phonopy.file_IO import write_FORCE_SETS

    from vibra import crystals

    crystals.write_phonopy(crystal, folder / "structure.yaml", force_constants=False)
    crystals.write_force_constants(crystal, folder / "FORCE_CONSTANTS")
    phonon = crystal.to_phonopy()
    fc = np.array(phonon.force_constants)
    phonon.generate_displacements(distance=0.01)
    dataset = phonon.dataset
    for entry in dataset["first_atoms"]:
        u = np.zeros((len(phonon.supercell), 3))
        u[entry["number"]] = entry["displacement"]
        entry["forces"] = -np.einsum("ijab,jb->ia", fc, u)
    write_FORCE_SETS(dataset, filename=str(folder / "FORCE_SETS"))
    phonon.save(str(folder / "phonopy_disp.yaml"), settings={"force_sets": False})
    return dataset
