"""Crystals against phonopy on the same force constants: bands on 2,000 q-points, DOS on a 40^3 mesh.

    python benchmarks/bench_crystals.py [--quick]

Issue 30 ("Speed"): for a 1-atom (fcc), a 2-atom (diamond, primitive) and an 8-atom cell
(diamond, conventional cube), by the protocol of STYLE.md (one process, a warm-up round,
interleaved rounds, BLAS threads pinned by _common):

- frequencies at the 2,000 q-points of SeeK-path's path: `Crystal.frequencies` against
  phonopy's `run_qpoints` (values only, its default Rust/C D(q) and numpy eigh);
- the band structure with eigenvectors, connected branches and group velocities:
  `Crystal.band_structure(npoints=2000)` against phonopy's `run_band_structure(...,
  with_eigenvectors=True, with_group_velocities=True, is_band_connection=True)` on the same
  q-points;
- the total DOS by the linear tetrahedron method on a Gamma-centred 40^3 mesh reduced by
  symmetry: `Crystal.dos(40)` against phonopy's `run_mesh(40, is_gamma_center=True)` +
  `run_total_dos(use_tetrahedron_method=True)`, at phonopy's own frequency points.

Accuracy beside each: the largest relative difference of the frequencies away from Gamma (in
phonopy's units: our omega times its DefaultToTHz), and of the DOS (over its maximum) against
phonopy's default (symmetry-reduced) DOS and against its full-mesh DOS (is_mesh_symmetry=False):
phonopy sums the 24 tetrahedra around irreducible points only, which is not the full-mesh sum
when the cut along one main diagonal breaks the point group (the 8-atom cube: 10% apart at
12^3); vibra spreads the irreducible frequencies over the whole grid and sums every
tetrahedron, which is phonopy's full-mesh DOS. Memory is not measured here. Writes
results/crystals.json.
"""

from __future__ import annotations

import argparse

from _common import ROUNDS, format_ratio, interleaved, ratio, write_json  # noqa: I001  (sets BLAS threads)

import numpy as np
from ase.build import bulk
from phonopy.physical_units import get_physical_units

from vibra import crystals
from vibra.crystals import Crystal


def cases() -> dict[str, Crystal]:
    conventional = crystals.springs(Crystal.from_ase(bulk("Si", "diamond", a=5.43, cubic=True)), shells=2,
                                    stiffness=[10.0, 2.0], transverse=[1.0, 0.5])
    return {
        "fcc (1 atom)": crystals.fcc(5.26, 39.948, 0.0325, units="ASE"),
        "diamond (2 atoms)": crystals.diamond(5.43, 28.0855, [10.0, 2.0], shells=2, transverse=[1.0, 0.5],
                                              units="ASE"),
        "diamond conventional (8 atoms)": conventional,
    }


def run(mesh: int) -> dict:
    to_thz = get_physical_units().DefaultToTHz
    rows = []
    for label, crystal in cases().items():
        print(label, flush=True)
        phonon = crystal.to_phonopy()
        bands = crystal.band_structure(npoints=2000)
        q = bands.qpoints
        paths = [q[a:b + 1] for a, b in bands.segments]

        def phonopy_qpoints() -> np.ndarray:
            phonon.run_qpoints(q)
            return phonon.qpoints.frequencies

        def phonopy_bands() -> object:
            phonon.run_band_structure(paths, with_eigenvectors=True, with_group_velocities=True,
                                      is_band_connection=True)
            return phonon.band_structure

        phonon.run_mesh([mesh] * 3, is_gamma_center=True)
        phonon.run_total_dos(use_tetrahedron_method=True)
        points = phonon.total_dos.frequency_points

        def phonopy_dos() -> np.ndarray:
            phonon.run_mesh([mesh] * 3, is_gamma_center=True)
            phonon.run_total_dos(use_tetrahedron_method=True)
            return phonon.total_dos.dos

        omega_points = points / to_thz  # phonopy's THz are our omega times its DefaultToTHz
        timings = interleaved({
            "vibra frequencies": lambda: crystal.frequencies(q),
            "phonopy run_qpoints": phonopy_qpoints,
            "vibra band_structure": lambda: crystal.band_structure(npoints=2000),
            "phonopy run_band_structure": phonopy_bands,
            f"vibra dos({mesh})": lambda: crystal.dos(mesh, omega=omega_points),
            f"phonopy mesh + total_dos ({mesh}^3)": phonopy_dos,
        })
        reference = timings["phonopy run_qpoints"].result
        ours = timings["vibra frequencies"].result * to_thz
        away = np.abs(reference) > 1e-3 * np.abs(reference).max()
        dos_ref = timings[f"phonopy mesh + total_dos ({mesh}^3)"].result
        dos_ours = timings[f"vibra dos({mesh})"].result.dos / to_thz
        phonon.run_mesh([mesh] * 3, is_gamma_center=True, is_mesh_symmetry=False)
        phonon.run_total_dos(use_tetrahedron_method=True)
        dos_full = phonon.total_dos.dos
        row = {
            "crystal": label, "n_atoms": crystal.n_atoms, "n_q": int(len(q)), "mesh": mesh,
            "supercell": phonon.supercell_matrix.diagonal().tolist(),
            "frequencies_vs_phonopy": ratio(timings["vibra frequencies"], timings["phonopy run_qpoints"]),
            "bands_vs_phonopy": ratio(timings["vibra band_structure"], timings["phonopy run_band_structure"]),
            "dos_vs_phonopy": ratio(timings[f"vibra dos({mesh})"], timings[f"phonopy mesh + total_dos ({mesh}^3)"]),
            "frequency_rel_diff_max": float(np.max(np.abs(ours[away] - reference[away]) / np.abs(reference[away]))),
            "dos_diff_over_max": float(np.abs(dos_ours - dos_ref).max() / dos_ref.max()),
            "dos_diff_over_max_vs_phonopy_full_mesh": float(np.abs(dos_ours - dos_full).max() / dos_full.max()),
            "times_s": {k: t.summary() for k, t in timings.items()},
        }
        print(f"  frequencies {format_ratio(row['frequencies_vs_phonopy'])}, bands {format_ratio(row['bands_vs_phonopy'])}, "
              f"dos {format_ratio(row['dos_vs_phonopy'])}; max rel diff {row['frequency_rel_diff_max']:.1e}, "
              f"dos {row['dos_diff_over_max']:.1e} (phonopy reduced), {row['dos_diff_over_max_vs_phonopy_full_mesh']:.1e} "
              "(phonopy full mesh)", flush=True)
        rows.append(row)
    return {"rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 12^3 mesh and one round (smoke run, results/quick/)")
    args = parser.parse_args()
    payload = run(12 if args.quick else 40)
    payload["peers"] = {"phonopy": "phonopy (installed version) on the same force constants, default settings, "
                                   "Gamma-centred mesh, tetrahedron DOS"}
    write_json("crystals", payload, ROUNDS)


if __name__ == "__main__":
    main()
