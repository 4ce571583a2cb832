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
``--memory --real``: the same for phonopy's NaCl and ZnO with Gonze-Lee's correction (frequencies,
bands, DOS and thermal properties on a 20^3 mesh; results/crystals_memory_real.json).

Real force sets (``--real``, issue 42; ``--real --quick``: 200 q, an 8^3 mesh, ZnO and SnO2, a
4^3 Al supercell, one round, under a minute): phonopy's own NaCl, MgO, ZnO and SnO2 examples
(tests/data/phonopy: FORCE_SETS, BORN, phonopy_disp.yaml) loaded in both codes on the primitive
cell phonopy finds ("auto"), phonopy's force-constant symmetrisation as phonopy.load does it:

- frequencies at 2,000 seeded random q without the correction, with Gonze-Lee's and with Wang's
  (`Crystal.frequencies` against `run_qpoints`, phonopy's ``nac_params["method"]``);
- with Gonze-Lee: the band structure (eigenvectors, connected branches, group velocities) on the
  2,000 q-points of vibra's path (phonopy's ``path_connections`` from its breaks), the tetrahedron
  DOS on a Gamma-centred 20^3 mesh, thermal properties at 100 temperatures on that mesh (phonopy:
  ``exclude_gamma_acoustic=True``, the zero modes left out as vibra leaves them out);
- set-up by finite differences on ASE's own phonon tests (Al with EMT on 7x7x7, delta 0.05; ZnS
  zincblende with Lennard-Jones on 3x3x3, delta 0.005): `from_ase` (symmetry "auto"), the same
  with phonopy's symmetry search forced on (symmetry=True), against ASE's ``Phonons.run()`` +
  ``read(acoustic=True)``, each round in a fresh cache folder; frequencies compared on the
  commensurate mesh (exact there up to the finite differences) and on ASE's band path.

phonopy 4.10 runs its Rust backend (phonors, rayon threads) and its OpenMP C extension:
RAYON_NUM_THREADS, OMP_NUM_THREADS and OPENBLAS_NUM_THREADS are set to one (VIBRA_BENCH_THREADS)
at the top of this file, before any import, and recorded with phonopy's own report of its
threads in results/crystals_real.json.
"""

from __future__ import annotations

import os

# phonopy 4.10's default backend is Rust (phonors, rayon threads) with an OpenMP C extension beside
# it: both pinned like BLAS (one thread unless VIBRA_BENCH_THREADS), before anything imports them.
for _variable in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ[_variable] = os.environ.get("VIBRA_BENCH_THREADS", "1")

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
from vibra.crystals.dynamical import brillouin_qpoints


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
#: ... and for the real force sets with the LO-TO correction (``--memory --real``), thermal too.
REAL_CALLS = (*CALLS, "vibra thermal", "phonopy mesh + thermal")
#: The real cases of ``--memory --real``: a 2-atom and a 4-atom cell, Gonze-Lee.
REAL_MEMORY_CASES = ("real:NaCl:gonze", "real:ZnO:gonze")


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
    elif call == "vibra thermal":
        crystal.thermal_properties(np.linspace(10.0, 1000.0, 100), mesh=[mesh] * 3)
    elif call == "phonopy mesh + thermal":
        phonon.run_mesh([mesh] * 3, is_gamma_center=True)
        phonon.run_thermal_properties(temperatures=np.linspace(10.0, 1000.0, 100))
    else:
        raise SystemExit(f"unknown call {call!r}")


def one_call(label: str, call: str, mesh: int, inputs: str) -> dict:
    """Peak memory (KiB above the setup) of one call, in this (fresh) process.

    Setup: the crystal, its phonopy object, the q-points and frequency points (read from
    `inputs`, computed by the parent so that no large temporary raises the baseline), and the
    same call once on a tiny input (2 q-points, a 2^3 mesh: imports, numba's compiled kernels,
    phonopy's caches), so that the peak counts the call's own arrays.
    """
    crystal, phonon = _memory_case(label)
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


def _memory_case(label: str) -> tuple[Crystal, object]:
    """(crystal, phonopy object) of a memory case: a spring model of `cases`, or ``real:NAME:NAC``
    (phonopy's force set NAME with its Born charges, `_load`)."""
    if label.startswith("real:"):
        _, name, nac = label.split(":")
        return _load(name, nac)
    crystal = cases()[label]
    return crystal, crystal.to_phonopy()


def run_memory(mesh: int, real: bool = False) -> dict:
    """Each call of each case in a fresh process; the peak resident memory above its setup."""
    import os
    import tempfile

    rows = []
    to_thz = get_physical_units().DefaultToTHz
    labels = REAL_MEMORY_CASES if real else tuple(cases())
    for label in labels:
        crystal, phonon = _memory_case(label)
        bands = crystal.band_structure(npoints=2000)
        phonon.run_mesh([8] * 3, is_gamma_center=True)   # phonopy's frequency points span the same range
        phonon.run_total_dos(use_tetrahedron_method=True)
        inputs = Path(tempfile.mkdtemp()) / "inputs.npz"
        np.savez(inputs, q=bands.qpoints, segments=np.array(bands.segments),
                 omega=phonon.total_dos.frequency_points / to_thz)
        for call in REAL_CALLS if real else CALLS:
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


# ---------------------------------------------------------------------- issue 42: real force sets
DATA = Path(__file__).resolve().parent.parent / "tests" / "data" / "phonopy"
REAL = ("NaCl", "MgO", "ZnO", "SnO2")


def _backend() -> dict:
    """phonopy's backend and thread settings as this process sees them (for the JSON)."""
    from importlib import metadata

    import phonopy
    from phonopy import _lang

    info = {"phonopy": phonopy.__version__, "ase": __import__("ase").__version__,
            "threads": {v: os.environ.get(v) for v in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS",
                                                        "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                                                        "NUMBA_NUM_THREADS")}}
    try:
        info["phonors"] = metadata.version("phonors")
    except metadata.PackageNotFoundError:      # pragma: no cover
        info["phonors"] = None
    for name in ("have_c_ext", "have_phonors", "c_use_openmp", "c_omp_max_threads", "rust_rayon_max_threads"):
        function = getattr(_lang, name, None)
        info[name] = function() if function is not None else None
    return info


def _rel_away(ours: np.ndarray, reference: np.ndarray) -> float:
    """Largest |ours - ref| / |ref| where |ref| > 1e-3 of its largest (away from Gamma's zeros)."""
    away = np.abs(reference) > 1e-3 * np.abs(reference).max()
    return float(np.max(np.abs(ours[away] - reference[away]) / np.abs(reference[away])))


def _load(name: str, nac: str | None) -> tuple[Crystal, object]:
    """The same files in both codes, primitive cell found by symmetry in both ("auto")."""
    import warnings

    import phonopy

    folder = DATA / name
    yaml, force_sets, born = folder / "phonopy_disp.yaml", folder / "FORCE_SETS", folder / "BORN"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # phonopy 4's notice that "auto" is its new default
        phonon = phonopy.load(str(yaml), force_sets_filename=str(force_sets), primitive_matrix="auto",
                              born_filename=str(born) if nac else None, is_nac=bool(nac), log_level=0)
    if nac:
        phonon.nac_params = {**phonon.nac_params, "method": nac}
    crystal = crystals.read_phonopy(yaml, force_sets=force_sets, primitive="auto",
                                    born=born if nac else None, nac=nac)
    return crystal, phonon


def _failure(function: object) -> str | None:
    """None if `function()` runs, else its exception in one line (a vibra path under repair: recorded, not timed)."""
    try:
        function()
    except Exception as error:  # noqa: BLE001 - recorded in the JSON
        return f"{type(error).__name__}: {str(error)[:200]}"
    return None


def run_real(n_q: int, n_path: int, mesh: int, n_temperatures: int, names: tuple[str, ...]) -> list[dict]:
    """Frequencies (no NAC, Gonze-Lee, Wang), bands, DOS and thermal properties (Gonze-Lee) per crystal."""
    to_thz = get_physical_units().DefaultToTHz
    cube = np.random.default_rng(42).random((n_q, 3)) - 0.5       # the same seeded q for every crystal
    temperatures = np.linspace(10.0, 1000.0, n_temperatures)
    rows = []
    for name in names:
        print(name, flush=True)
        plain, phonon_plain = _load(name, None)
        gonze, phonon_gonze = _load(name, "gonze")
        wang, phonon_wang = _load(name, "wang")
        # ... moved into the first Brillouin zone, where phonopy evaluates the correction as vibra does
        # (outside it phonopy's truncated Gonze-Lee sum and Wang's q-hat term are not periodic in q)
        q = brillouin_qpoints(cube, plain.reciprocal)[0]

        def phonopy_qpoints(phonon: object) -> object:
            def call() -> np.ndarray:
                phonon.run_qpoints(q)
                return phonon.qpoints.frequencies
            return call

        bands = gonze.band_structure(npoints=n_path)
        path_q = bands.qpoints
        paths = [path_q[a:b + 1] for a, b in bands.segments]
        starts = [int(a) for a, _ in bands.segments]
        connections = [k + 1 < len(starts) and starts[k + 1] not in bands.breaks for k in range(len(starts))]

        def phonopy_bands() -> object:
            phonon_gonze.run_band_structure(paths, with_eigenvectors=True, with_group_velocities=True,
                                            is_band_connection=True, path_connections=connections)
            return phonon_gonze.band_structure

        phonon_gonze.run_mesh([mesh] * 3, is_gamma_center=True)
        phonon_gonze.run_total_dos(use_tetrahedron_method=True)
        omega_points = phonon_gonze.total_dos.frequency_points / to_thz

        def phonopy_dos() -> np.ndarray:
            phonon_gonze.run_mesh([mesh] * 3, is_gamma_center=True)
            phonon_gonze.run_total_dos(use_tetrahedron_method=True)
            return phonon_gonze.total_dos.dos

        def phonopy_thermal() -> dict:
            # exclude_gamma_acoustic: the three zero modes at Gamma left out, as vibra leaves out every
            # mode not certainly positive (phonopy's default keeps them and warns: they add ~1e-3 of F)
            phonon_gonze.run_mesh([mesh] * 3, is_gamma_center=True)
            phonon_gonze.run_thermal_properties(temperatures=temperatures, exclude_gamma_acoustic=True)
            tp = phonon_gonze.thermal_properties
            return {"heat_capacity": tp.heat_capacity, "entropy": tp.entropy, "free_energy": tp.free_energy}

        failures = {"Wang": _failure(lambda: wang.frequencies(q[:1]))}
        if failures["Wang"]:
            print(f"  vibra's Wang correction fails, not timed: {failures['Wang']}", flush=True)
        wang_pair = {} if failures["Wang"] else {"vibra frequencies (Wang)": lambda: wang.frequencies(q)}
        timings = interleaved({
            "vibra frequencies (no NAC)": lambda: plain.frequencies(q),
            "phonopy run_qpoints (no NAC)": phonopy_qpoints(phonon_plain),
            "vibra frequencies (Gonze)": lambda: gonze.frequencies(q),
            "phonopy run_qpoints (Gonze)": phonopy_qpoints(phonon_gonze),
            **wang_pair,
            "phonopy run_qpoints (Wang)": phonopy_qpoints(phonon_wang),
            "vibra band_structure (Gonze)": lambda: gonze.band_structure(npoints=n_path),
            "phonopy run_band_structure (Gonze)": phonopy_bands,
            f"vibra dos({mesh}) (Gonze)": lambda: gonze.dos(mesh, omega=omega_points),
            f"phonopy mesh + total_dos ({mesh}^3, Gonze)": phonopy_dos,
            f"vibra thermal_properties ({mesh}^3, Gonze)": lambda: gonze.thermal_properties(temperatures, mesh=mesh),
            f"phonopy mesh + thermal_properties ({mesh}^3, Gonze)": phonopy_thermal,
        })
        result = {k: t.result for k, t in timings.items()}

        def pair(kind: str) -> dict:
            theirs = timings[f"phonopy run_qpoints ({kind})"]
            if failures.get(kind):
                return {"error": failures[kind], "phonopy_s": theirs.summary()}
            ours = timings[f"vibra frequencies ({kind})"]
            return {**ratio(ours, theirs), "rel_diff_max": _rel_away(ours.result * to_thz, theirs.result)}

        frequencies = {"no NAC": pair("no NAC"), "Gonze": pair("Gonze"), "Wang": pair("Wang")}
        theirs_bands = result["phonopy run_band_structure (Gonze)"]
        ours_bands = np.sort(result["vibra band_structure (Gonze)"].omega, axis=1) * to_thz
        reference_bands = np.sort(np.concatenate(theirs_bands.frequencies), axis=1)
        dos_ref = result[f"phonopy mesh + total_dos ({mesh}^3, Gonze)"]
        dos_ours = result[f"vibra dos({mesh}) (Gonze)"].dos / to_thz
        phonon_gonze.run_mesh([mesh] * 3, is_gamma_center=True, is_mesh_symmetry=False)
        phonon_gonze.run_total_dos(use_tetrahedron_method=True)
        dos_full = phonon_gonze.total_dos.dos
        thermal_ref = result[f"phonopy mesh + thermal_properties ({mesh}^3, Gonze)"]
        thermal_ours = result[f"vibra thermal_properties ({mesh}^3, Gonze)"]
        thermal = {}
        for key, ours in (("heat_capacity", thermal_ours.heat_capacity_j_k_mol()),
                          ("entropy", thermal_ours.entropy_j_k_mol()),
                          ("free_energy", thermal_ours.free_energy_kj_mol())):
            reference = np.asarray(thermal_ref[key])
            thermal[key + "_diff_over_max"] = float(np.abs(ours - reference).max() / np.abs(reference).max())
        row = {
            "crystal": name, "n_atoms": gonze.n_atoms, "n_q": int(n_q), "n_path": int(len(path_q)), "mesh": mesh,
            "n_temperatures": int(n_temperatures),
            "supercell": np.asarray(phonon_gonze.supercell_matrix).diagonal().tolist(),
            "frequencies": frequencies,
            "bands_vs_phonopy": ratio(timings["vibra band_structure (Gonze)"],
                                      timings["phonopy run_band_structure (Gonze)"]),
            "bands_rel_diff_max": _rel_away(ours_bands, reference_bands),
            "dos_vs_phonopy": ratio(timings[f"vibra dos({mesh}) (Gonze)"],
                                    timings[f"phonopy mesh + total_dos ({mesh}^3, Gonze)"]),
            "dos_diff_over_max": float(np.abs(dos_ours - dos_ref).max() / dos_ref.max()),
            "dos_diff_over_max_vs_phonopy_full_mesh": float(np.abs(dos_ours - dos_full).max() / dos_full.max()),
            "thermal_vs_phonopy": ratio(timings[f"vibra thermal_properties ({mesh}^3, Gonze)"],
                                        timings[f"phonopy mesh + thermal_properties ({mesh}^3, Gonze)"]),
            "thermal": thermal,
            "times_s": {k: t.summary() for k, t in timings.items()},
        }
        text = ", ".join(f"{kind} {format_ratio(v) if 'of_min' in v else 'vibra failed: ' + v['error'][:60]}"
                         f"{' (%.1e)' % v['rel_diff_max'] if 'rel_diff_max' in v else ''}"
                         for kind, v in frequencies.items())
        print(f"  frequencies: {text}", flush=True)
        print(f"  bands {format_ratio(row['bands_vs_phonopy'])} ({row['bands_rel_diff_max']:.1e}), "
              f"dos {format_ratio(row['dos_vs_phonopy'])} ({row['dos_diff_over_max']:.1e}; full mesh "
              f"{row['dos_diff_over_max_vs_phonopy_full_mesh']:.1e}), "
              f"thermal {format_ratio(row['thermal_vs_phonopy'])} "
              f"({', '.join(f'{k} {v:.1e}' for k, v in thermal.items())})", flush=True)
        rows.append(row)
    return rows


def _ase_cases(n_al: int) -> dict[str, dict]:
    """ASE's own phonon tests (ase/test/test_phonons.py): Al with EMT, ZnS zincblende with Lennard-Jones."""
    from ase.calculators.emt import EMT
    from ase.calculators.lj import LennardJones

    epsilon_zn, sigma_zn, epsilon_s, sigma_s = 0.1915460, 2.1737900, 4.3692700, 1.8708900
    epsilon, sigma = np.sqrt(epsilon_zn * epsilon_s), (sigma_zn + sigma_s) / 2
    d0 = 2 ** (1 / 6) * sigma
    return {
        f"Al fcc, EMT, {n_al}x{n_al}x{n_al}, delta 0.05 (test_get_band_structure_with_modes)": {
            "atoms": bulk("Al", "fcc", a=4.05), "calculator": EMT, "supercell": (n_al,) * 3, "delta": 0.05,
            "path": "GXULGK"},
        "ZnS zincblende, Lennard-Jones, 3x3x3, delta 0.005 (test_partial_dos)": {
            "atoms": bulk("ZnS", "zincblende", a=d0 * np.sqrt(2)),
            "calculator": lambda: LennardJones(sigma=sigma, epsilon=epsilon, rc=d0 * (1 + np.sqrt(2)) / 2),
            "supercell": (3, 3, 3), "delta": 0.005, "path": None},
    }


def run_from_ase(n_al: int, n_path: int) -> list[dict]:
    """vibra from_ase (symmetry "auto", then symmetry=True) against ASE Phonons run + read(acoustic=True)."""
    import shutil
    import tempfile

    from ase import units
    from ase.phonons import Phonons

    to_ev = units._hbar * 1e10 / np.sqrt(units._e * units._amu)    # ASE's own sqrt(eV/A^2/amu) -> eV
    rows = []
    for label, case in _ase_cases(n_al).items():
        print(label, flush=True)
        atoms, make, supercell, delta = case["atoms"], case["calculator"], case["supercell"], case["delta"]
        scratch = Path(tempfile.mkdtemp(prefix="bench_crystals_ase_"))

        def ase_phonons() -> Phonons:
            folder = Path(tempfile.mkdtemp(dir=scratch))            # a fresh, empty cache every round
            phonons = Phonons(atoms, make(), supercell=supercell, delta=delta, name=str(folder / "phonon"))
            phonons.run()
            phonons.read(acoustic=True)
            return phonons

        def vibra_auto() -> Crystal:
            return crystals.from_ase(atoms, make(), supercell=supercell, delta=delta)

        def vibra_symmetry() -> Crystal:
            return crystals.finite_difference_force_constants(
                atoms, make(), supercell=supercell, delta=delta, estimate_error=False, force_noise=None,
                symmetry=True).crystal

        try:
            timings = interleaved({"vibra from_ase (symmetry auto)": vibra_auto,
                                   "ASE Phonons run + read(acoustic=True)": ase_phonons,
                                   "vibra from_ase (symmetry=True)": vibra_symmetry})
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
        phonons = timings["ASE Phonons run + read(acoustic=True)"].result
        grid = np.stack(np.meshgrid(*[np.arange(n) / n for n in supercell], indexing="ij"), -1).reshape(-1, 3)
        path = atoms.cell.bandpath(case["path"], npoints=n_path)   # None: ASE's default path of the lattice
        accuracy = {}
        for key in ("vibra from_ase (symmetry auto)", "vibra from_ase (symmetry=True)"):
            crystal = timings[key].result
            accuracy[key] = {
                "commensurate_rel_diff_max": _rel_away(np.sort(crystal.frequencies(grid), axis=1) * to_ev,
                                                       np.sort(phonons.band_structure(grid, verbose=False), axis=1)),
                "bandpath_rel_diff_max": _rel_away(np.sort(crystal.frequencies(path.kpts), axis=1) * to_ev,
                                                   np.sort(phonons.band_structure(path.kpts, verbose=False), axis=1)),
            }
        row = {
            "case": label, "supercell": list(supercell), "delta": delta, "n_commensurate_q": int(len(grid)),
            "bandpath": path.path, "n_bandpath": int(len(path.kpts)),
            "auto_vs_ase": ratio(timings["vibra from_ase (symmetry auto)"],
                                 timings["ASE Phonons run + read(acoustic=True)"]),
            "symmetry_vs_ase": ratio(timings["vibra from_ase (symmetry=True)"],
                                     timings["ASE Phonons run + read(acoustic=True)"]),
            "accuracy": accuracy,
            "times_s": {k: t.summary() for k, t in timings.items()},
        }
        print(f"  from_ase/ASE {format_ratio(row['auto_vs_ase'])}, "
              f"symmetry=True/ASE {format_ratio(row['symmetry_vs_ase'])}; "
              + "; ".join(f"{k}: commensurate {v['commensurate_rel_diff_max']:.1e}, "
                          f"path {v['bandpath_rel_diff_max']:.1e}"
                          for k, v in accuracy.items()), flush=True)
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a 12^3 mesh and one round (smoke run, results/quick/)")
    parser.add_argument("--memory", action="store_true", help="peak memory of each call, each in a fresh process")
    parser.add_argument("--chunks", action="store_true", help="time the memory bounds against unbounded chunks")
    parser.add_argument("--real", action="store_true",
                        help="issue 42: phonopy's NaCl, MgO, ZnO, SnO2 force sets (with and without LO-TO) and "
                             "ASE's phonon tests (results/crystals_real.json)")
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
        if args.real:  # the corrected paths on phonopy's force sets (a 20^3 mesh, as --real times them)
            write_json("crystals_memory_real", run_memory(args.mesh or 20, real=True), 1)
        else:
            write_json("crystals_memory", run_memory(mesh), 1)
        return
    if args.real:
        sizes = (dict(n_q=200, n_path=200, mesh=8, n_temperatures=20, names=("ZnO", "SnO2")) if args.quick else
                 dict(n_q=2000, n_path=2000, mesh=20, n_temperatures=100, names=REAL))
        load = os.getloadavg()[0]
        print(f"load average at start: {load:.2f} (1 min), threads {_backend()['threads']}", flush=True)
        payload = {"load_average_at_start": load, "backend": _backend(),
                   "sizes": {**sizes, "names": list(sizes["names"])},
                   "crystals": run_real(**sizes),
                   "from_ase": run_from_ase(4 if args.quick else 7, 100)}
        payload["load_average_at_end"] = os.getloadavg()[0]
        payload["peers"] = {
            "phonopy": "phonopy.load(phonopy_disp.yaml, force_sets_filename=FORCE_SETS, primitive_matrix='auto', "
                       "born_filename=BORN or None, is_nac=..., log_level=0) (symmetrize_fc=True, its default); "
                       "nac_params['method'] 'gonze' or 'wang'; its default backend: Rust (phonors) with "
                       "RAYON_NUM_THREADS=1 and the C extension with OMP_NUM_THREADS=1; run_qpoints (values "
                       "only), run_band_structure(with_eigenvectors=True, with_group_velocities=True, "
                       "is_band_connection=True, path_connections from vibra's breaks) on vibra's q-points, "
                       "run_mesh(mesh, is_gamma_center=True) + run_total_dos(use_tetrahedron_method=True) at "
                       "phonopy's frequency points, run_mesh + run_thermal_properties(temperatures=..., "
                       "exclude_gamma_acoustic=True)",
            "vibra": "read_phonopy(yaml, force_sets=..., primitive='auto', born=..., nac=...) (symmetrize='auto': "
                     "phonopy's symmetrize_force_constants as phonopy.load); frequencies (accuracy='high'), "
                     "band_structure(npoints), dos(mesh, omega=phonopy's points), thermal_properties(T, mesh)",
            "ase": "ase.phonons.Phonons(atoms, calculator, supercell, delta, name=<fresh temporary folder>) "
                   ".run() + .read(acoustic=True) (every atom +-x, +-y, +-z; ASE's own test cases)",
            "vibra_from_ase": "vibra.crystals.from_ase(atoms, calculator, supercell, delta) (symmetry 'auto'); "
                              "symmetry=True: finite_difference_force_constants(..., estimate_error=False, "
                              "force_noise=None, symmetry=True).crystal, what from_ase does with phonopy's "
                              "symmetry search forced on",
        }
        write_json("crystals_real", payload, ROUNDS)
        return
    payload = run(mesh)
    payload["peers"] = {"phonopy": "phonopy (installed version) on the same force constants, default settings, "
                                   "Gamma-centred mesh, tetrahedron DOS"}
    write_json("crystals", payload, ROUNDS)


if __name__ == "__main__":
    main()
