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
tetrahedron, which is phonopy's full-mesh DOS.

Memory (``--memory``): the peak resident memory of each of those six calls, each in a fresh
process (``python bench_crystals.py --one CASE CALL``): the peak resident memory during the call
(``VmHWM``, reset just before it through ``/proc/self/clear_refs``, so an earlier transient peak of
the imports is not the figure, as ``getrusage(...).ru_maxrss`` would give) minus the resident
memory before it (``VmRSS``), after a setup of imports, the crystal, its phonopy object, the
q-points, and the same call on a tiny input (caches, numba's compiled kernels). Resident memory
counts every allocation (numpy, phonopy's C/Rust, numba), which tracemalloc would not. Writes results/crystals.json (times) and results/crystals_memory.json.
"""

from __future__ import annotations

import argparse
import gc
import json
import resource
import subprocess
import sys
from pathlib import Path

from _common import ROUNDS, THREADS, format_ratio, interleaved, ratio, write_json  # noqa: I001  (sets BLAS threads)

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


CALLS = ("vibra frequencies", "phonopy run_qpoints", "vibra band_structure", "phonopy run_band_structure",
         "vibra dos", "phonopy mesh + total_dos")


def _status_kib(field: str) -> int:
    """``VmRSS`` (resident now) or ``VmHWM`` (its peak) of this process, in KiB (Linux)."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise RuntimeError(f"no {field} in /proc/self/status")


def _reset_peak() -> None:
    """Reset this process's peak resident memory (VmHWM) to what it holds now (Linux >= 4.0)."""
    with open("/proc/self/clear_refs", "w") as clear:
        clear.write("5")


def _call(call: str, crystal: Crystal, phonon: object, q_points: np.ndarray, segments: list, mesh: int,
          omega_points: np.ndarray, npoints: int) -> None:
    if call == "vibra frequencies":
        crystal.frequencies(q_points)
    elif call == "phonopy run_qpoints":
        phonon.run_qpoints(q_points)
    elif call == "vibra band_structure":
        crystal.band_structure(npoints=npoints)
    elif call == "phonopy run_band_structure":
        phonon.run_band_structure(segments, with_eigenvectors=True, with_group_velocities=True,
                                  is_band_connection=True)
    elif call == "vibra dos":
        crystal.dos(mesh, omega=omega_points)
    elif call == "phonopy mesh + total_dos":
        phonon.run_mesh([mesh] * 3, is_gamma_center=True)
        phonon.run_total_dos(use_tetrahedron_method=True)
    else:
        raise SystemExit(f"unknown call {call!r}")


def one_call(label: str, call: str, mesh: int, inputs: str) -> dict:
    """Peak memory (KiB above the setup) of one call, in this (fresh) process.

    Setup: the crystal, its phonopy object, the q-points and frequency points (read from
    `inputs`, computed by the parent so that no large temporary raises the baseline), and the
    same call once on a tiny input (2 q-points, a 2^3 mesh: imports, numba's compiled kernels,
    phonopy's caches), so that the peak counts the call's own arrays.
    """
    crystal = cases()[label]
    phonon = crystal.to_phonopy()
    data = np.load(inputs)
    q_points, bounds, omega_points = data["q"], data["segments"], data["omega"]
    segments = [q_points[a:b + 1] for a, b in bounds]
    _call(call, crystal, phonon, q_points[:2], [q_points[:2]], 2, omega_points, 20)
    gc.collect()
    base = _status_kib("VmRSS")
    _reset_peak()
    _call(call, crystal, phonon, q_points, segments, mesh, omega_points, len(q_points))
    peak = _status_kib("VmHWM")
    ru_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # the whole run's, for comparison
    return {"crystal": label, "call": call, "peak_above_setup_mib": (peak - base) / 1024,
            "setup_mib": base / 1024, "ru_maxrss_whole_run_mib": ru_peak / 1024}


def run_memory(mesh: int) -> dict:
    """Each call of each case in a fresh process; the peak resident memory above its setup."""
    import os
    import tempfile

    rows = []
    to_thz = get_physical_units().DefaultToTHz
    for label, crystal in cases().items():
        bands = crystal.band_structure(npoints=2000)
        phonon = crystal.to_phonopy()
        phonon.run_mesh([8] * 3, is_gamma_center=True)   # phonopy's frequency points span the same range
        phonon.run_total_dos(use_tetrahedron_method=True)
        inputs = Path(tempfile.mkdtemp()) / "inputs.npz"
        np.savez(inputs, q=bands.qpoints, segments=np.array(bands.segments),
                 omega=phonon.total_dos.frequency_points / to_thz)
        for call in CALLS:
            out = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--one", label, call, "--mesh",
                                  str(mesh), "--inputs", str(inputs)], check=True, capture_output=True, text=True,
                                 env={**os.environ, "VIBRA_BENCH_THREADS": THREADS})
            row = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"  {label}: {call}: {row['peak_above_setup_mib']:.1f} MiB above setup "
                  f"({row['setup_mib']:.0f} MiB)", flush=True)
            rows.append(row)
    return {"rows": rows, "mesh": mesh, "method": "ru_maxrss after the call minus after the setup, fresh process"}


def run_chunks(mesh: int) -> dict:
    """Speed of the memory bounds: each call chunked (the defaults) against unbounded (one chunk), interleaved."""
    import importlib

    bands_module = importlib.import_module("vibra.crystals.bands")  # (vibra.crystals.dos is also a function's name)
    dos_module = importlib.import_module("vibra.crystals.dos")
    dynamical = importlib.import_module("vibra.crystals.dynamical")
    factor = importlib.import_module("vibra.crystals.factor")

    bounded = {"CHUNK_ENTRIES": dynamical.CHUNK_ENTRIES, "PATH_CHUNK": bands_module.PATH_CHUNK,
               "TETRAHEDRA_CHUNK": dos_module.TETRAHEDRA_CHUNK, "factor.CHUNK_ENTRIES": factor.CHUNK_ENTRIES}

    def setting(chunked: bool) -> None:
        big = 1 << 40
        dynamical.CHUNK_ENTRIES = bounded["CHUNK_ENTRIES"] if chunked else big
        factor.CHUNK_ENTRIES = bounded["factor.CHUNK_ENTRIES"] if chunked else big
        bands_module.PATH_CHUNK = bounded["PATH_CHUNK"] if chunked else big
        dos_module.TETRAHEDRA_CHUNK = bounded["TETRAHEDRA_CHUNK"] if chunked else big

    def timed(chunked: bool, work: object) -> object:
        def call() -> object:
            setting(chunked)
            try:
                return work()
            finally:
                setting(True)
        return call

    rows = []
    for label, crystal in cases().items():
        q = crystal.band_structure(npoints=2000).qpoints
        work = {"frequencies": lambda: crystal.frequencies(q), "band_structure": lambda: crystal.band_structure(npoints=2000),
                f"dos({mesh})": lambda: crystal.dos(mesh)}
        methods = {f"{name} {kind}": timed(kind == "chunked", call) for name, call in work.items()
                   for kind in ("chunked", "unbounded")}
        timings = interleaved(methods)
        row = {"crystal": label, **{name: ratio(timings[f"{name} chunked"], timings[f"{name} unbounded"])
                                    for name in work}, "times_s": {k: t.summary() for k, t in timings.items()}}
        print("  " + label + ": " + ", ".join(f"{name} chunked/unbounded {format_ratio(row[name])}" for name in work),
              flush=True)
        rows.append(row)
    return {"rows": rows, "bounds": bounded}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 12^3 mesh and one round (smoke run, results/quick/)")
    parser.add_argument("--memory", action="store_true", help="peak memory of each call, each in a fresh process")
    parser.add_argument("--chunks", action="store_true", help="time the memory bounds against unbounded chunks")
    parser.add_argument("--one", nargs=2, metavar=("CASE", "CALL"), help=argparse.SUPPRESS)
    parser.add_argument("--mesh", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--inputs", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    mesh = args.mesh or (12 if args.quick else 40)
    if args.one:
        print(json.dumps(one_call(args.one[0], args.one[1], mesh, args.inputs)))
        return
    if args.chunks:
        write_json("crystals_chunks", run_chunks(mesh))
        return
    if args.memory:
        write_json("crystals_memory", run_memory(mesh), 1)
        return
    payload = run(mesh)
    payload["peers"] = {"phonopy": "phonopy (installed version) on the same force constants, default settings, "
                                   "Gamma-centred mesh, tetrahedron DOS"}
    write_json("crystals", payload, ROUNDS)


if __name__ == "__main__":
    main()
