"""Tests of vibra/cli.py: `vibra report`, `vibra validate`, `vibra modes`, exit codes, and
interrupted runs. The CLI runs in subprocesses, as a user runs it."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from ase.data import atomic_masses, atomic_numbers
from helpers.package import BUNDLED_FOLDERS
from PIL import Image

from vibra import molecules
from vibra.units import ASE

ROOT = Path(__file__).resolve().parent.parent
BROKEN = ROOT / "tests" / "broken_scenes"


def vibra(*args: str, **kwargs: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vibra", *args], capture_output=True, text=True,
                          cwd=ROOT, **kwargs)  # type: ignore[call-overload]


def complete_png(path: Path) -> np.ndarray:
    with Image.open(path) as handle:
        handle.load()  # raises on a truncated file
        return np.asarray(handle.convert("RGB"))


def test_help_is_fast_and_light() -> None:
    # light by what it imports, not by a time (a wall-clock bound failed on a loaded machine; the
    # start-up time is a benchmark's figure): pyvista alone would add ~1.5 s
    code = ("import sys; from vibra import cli; cli.build_parser(); "
            "print('pyvista' in sys.modules, 'matplotlib' in sys.modules)")
    pyvista, matplotlib = subprocess.run([sys.executable, "-c", code], capture_output=True,
                                         text=True, check=True).stdout.split()
    assert (pyvista, matplotlib) == ("False", "False")
    run = vibra("--help")
    assert run.returncode == 0 and "report" in run.stdout and "validate" in run.stdout


def test_no_command_prints_help() -> None:
    run = vibra()
    assert run.returncode == 2 and "usage: vibra" in run.stdout


def test_validate_bundled_scenes() -> None:
    run = vibra("validate", *BUNDLED_FOLDERS)
    assert run.returncode == 0, run.stdout
    assert f"{len(EXPECTED)} scenes, 0 invalid" in run.stdout


@pytest.mark.parametrize("name, message", [
    ("typo-key.toml", "system.stifness: unknown key; did you mean 'stiffness'?"),
    ("wrong-type.toml", "system.n: expected an integer, got a string"),
    ("negative-mass.toml", "system.mass: must be positive, got -1.0"),
    ("unknown-builder.toml", "unknown builder 'linear_chian'; did you mean 'linear_chain'?"),
    ("escape-path.toml", "name: '../escaped' is not a safe file name"),
])
def test_validate_broken_scene(name: str, message: str) -> None:
    run = vibra("validate", str(BROKEN / name))
    assert run.returncode == 1
    assert message in run.stdout and name in run.stdout


DRIFTED = {  # scenes that passed `vibra validate` and then failed in `vibra report` (issue 11)
    "bead.toml": ('kind = "chain"\n[system]\nbuilder = "beaded_string"\nn = 1\n',
                  "bead.toml: system.n: n is 1; a chain needs n >= 2"),
    "uneven.toml": ('kind = "chain"\n[system]\nbuilder = "linear_chain"\nn = 4\nmass = [1.0, 2.0, 1.0, 2.0]\n'
                    '[draw]\ndispersion = true\n',
                    "uneven.toml: draw.dispersion: needs a uniform chain, but system.mass is a list"),
}


@pytest.mark.parametrize("name", sorted(DRIFTED))
def test_validate_refuses_what_report_cannot_run(name: str, tmp_path: Path) -> None:
    text, message = DRIFTED[name]
    path = tmp_path / name
    path.write_text(text)
    run = vibra("validate", str(path))
    assert run.returncode == 1 and f"FAIL {tmp_path / message}" in run.stdout, run.stdout
    assert "Traceback" not in run.stdout + run.stderr
    out = tmp_path / "out"
    reported = vibra("report", str(path), "--out", str(out), "--quiet")
    assert reported.returncode == 1 and message in reported.stderr  # the same message, not a traceback
    assert not [p for p in out.iterdir() if p.suffix == ".png"]


def test_validate_accepts_the_banded_solver(tmp_path: Path) -> None:
    path = tmp_path / "banded.toml"
    path.write_text('kind = "chain"\n[system]\nbuilder = "linear_chain"\nn = 6\n[compute]\nsolver = "banded"\n')
    run = vibra("validate", str(path))
    assert run.returncode == 0, run.stdout
    modes = vibra("modes", str(path))
    assert modes.returncode == 0 and "solver banded" in modes.stdout, modes.stdout + modes.stderr


def test_validate_missing_file() -> None:
    run = vibra("validate", "no/such/scene.toml")
    assert run.returncode == 1 and "no/such/scene.toml: file not found" in run.stdout


def test_closed_output_pipe_is_not_a_traceback() -> None:
    # `vibra validate ... | head -1`: the reader is gone before vibra writes (closed at once,
    # while the interpreter is still starting), so the first print meets a broken pipe.
    process = subprocess.Popen([sys.executable, "-m", "vibra", "validate", "chains", "molecules"], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout is not None
    process.stdout.close()
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 1 and "Traceback" not in stderr, stderr


def test_modes_table_matches_seed_eq_157() -> None:
    run = vibra("modes", "molecules/co2-axial.toml", env={**os.environ, "PYTHONIOENCODING": "utf-8"})
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[1].split()[:3] == ["vibration", "wavenumber", "(cm⁻¹)"]
    rows = [line.split() for line in lines[2:4]]
    assert [row[0] for row in rows] == ["ν1", "ν3"]  # the vibrations only, Herzberg's numbers (the bend, ν2, is off-axis)
    assert [row[2] for row in rows] == ["Σg+", "Σu+"]  # their species in D∞h
    wavenumbers = np.array([float(row[1]) for row in rows])
    kappa = molecules.CO2_STRETCH
    m, M = atomic_masses[atomic_numbers["O"]], atomic_masses[atomic_numbers["C"]]
    expected = ASE.omega_to_cm1([np.sqrt(kappa / m), np.sqrt(kappa * (1 / m + 2 / M))])
    # The table prints 2 decimals: 1e-5 relative covers the rounding.
    assert np.allclose(wavenumbers, expected, rtol=1e-5, atol=1e-2)
    # the translation: set apart, as 0
    assert lines[4].startswith("rigid-body modes: 1 ") and "shown as 0 cm⁻¹" in lines[4]


def test_modes_of_methane_number_nu1_to_nu4_with_species_and_the_rigid_modes_apart() -> None:
    run = vibra("modes", "molecules/ch4.toml", env={**os.environ, "PYTHONIOENCODING": "utf-8"})
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert "species (Td)" in lines[1] and "omega [" not in run.stdout
    rows = [line.split() for line in lines[2:6]]
    assert [row[0] for row in rows] == [f"ν{k}" for k in range(1, 5)]  # 3N - 6 = 9 vibrations, 4 fundamentals
    assert [row[2] for row in rows] == ["A1", "E", "T2", "T2"]  # Herzberg's (and Shimanouchi's) order
    assert lines[6].startswith("rigid-body modes: 6 (translations and rotations), shown as 0 cm⁻¹")


def test_modes_in_ascii_when_the_terminal_cannot_show_greek() -> None:
    run = vibra("modes", "molecules/ch4.toml", env={**os.environ, "PYTHONIOENCODING": "ascii"})
    assert run.returncode == 0, run.stderr
    assert "nu1 " in run.stdout and "cm^-1" in run.stdout
    run.stdout.encode("ascii")  # nothing else slipped through


def test_modes_of_a_network_and_a_chain_carry_their_units() -> None:
    run = vibra("modes", "networks/ubiquitin/ubiquitin-anm.toml", env={**os.environ, "PYTHONIOENCODING": "utf-8"})
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[1].split()[:2] == ["mode", "omega"] and "(√(γ/m))" in lines[1]
    assert "time unit" not in run.stdout
    assert [line.split()[0] for line in lines[2:22]] == [str(k) for k in range(1, 21)]  # 26 computed, 6 rigid
    assert lines[22].startswith("rigid-body modes: 6")
    chain = vibra("modes", "chains/monatomic-free.toml")
    header = chain.stdout.splitlines()[1]
    assert "omega (rad/s)" in header and "f (Hz)" in header
    assert "rigid-body modes: 1 (rigid-body motion), shown as 0 rad/s" in chain.stdout


def test_validate_and_report_find_scenes_in_subfolders(tmp_path: Path) -> None:
    run = vibra("validate", "networks")
    assert run.returncode == 0 and "networks/ubiquitin/ubiquitin-anm.toml" in run.stdout, run.stdout + run.stderr
    nested = tmp_path / "a" / "b"
    nested.mkdir(parents=True)
    (tmp_path / ".hidden").mkdir()
    scene = 'kind = "chain"\n[system]\nbuilder = "linear_chain"\nn = 4\n'
    (nested / "deep.toml").write_text(scene)
    (tmp_path / "top.toml").write_text(scene)
    (tmp_path / ".hidden" / "skipped.toml").write_text("not a scene")
    from vibra.pipeline.scene import find_scene_files

    assert find_scene_files([tmp_path]) == [tmp_path / "top.toml", nested / "deep.toml"]
    out = tmp_path / "out"
    report = vibra("report", str(tmp_path / "a"), "--out", str(out), "--quiet")
    assert report.returncode == 0 and (out / "summary.json").exists(), report.stdout + report.stderr
    assert "deep" in (out / "summary.json").read_text()


def test_modes_on_invalid_scene() -> None:
    run = vibra("modes", str(BROKEN / "negative-mass.toml"))
    assert run.returncode == 1 and "system.mass: must be positive" in run.stderr


def test_bad_jobs_is_a_usage_error(tmp_path: Path) -> None:
    run = vibra("report", "chains", "--out", str(tmp_path), "--jobs", "0")
    assert run.returncode == 2 and "--jobs must be >= 1" in run.stderr


def test_report_with_broken_scenes_exits_nonzero_and_writes_nothing_for_them(tmp_path: Path) -> None:
    out = tmp_path / "out"
    run = vibra("report", str(BROKEN), "--out", str(out), "--quiet")
    assert run.returncode == 1
    n_broken = len(list(BROKEN.glob("*.toml")))
    assert n_broken > 1 and f"{n_broken} scenes, {n_broken} failed, 0 images" in run.stdout
    assert "did you mean 'stiffness'?" in run.stdout  # the final table says why
    assert sorted(p.name for p in out.iterdir()) == [".vibra", "assets", "index.html", "references.html", "scenes",
                                                     "summary.json"]
    assert sorted(p.name for p in (out / "scenes").iterdir()) == sorted(f"{p.stem}.html" for p in BROKEN.glob("*.toml"))
    assert [p.name for p in (out / ".vibra").iterdir()] == ["lock"]  # the folder's lock; no manifest
    assert not Path("/tmp/vibra-escaped_modes.png").exists()
    assert not (tmp_path / "escaped").exists()


#: Every image the bundled scenes must produce (from the scene files' [draw] tables).
EXPECTED = {
    "monatomic-free": ["modes", "spectrum", "dispersion"],
    "monatomic-fixed": ["modes", "spectrum", "dispersion"],
    "diatomic": ["modes", "spectrum", "dispersion"],
    "mass-defect": ["modes", "spectrum"],
    "continuum-limit": ["modes", "convergence"],
    "forced-damped": ["spectrum", "response"],
    "long-chain": ["modes", "spectrum"],
    "double-pendulum": ["modes", "spectrum"],
    "co2-axial": ["mode1", "mode2", "spectrum"],  # mode 0 is the translation: not drawn
    "co2": ["mode5", "mode7", "mode8", "spectrum"],  # mode5: the degenerate bend pair, side by side
    "h2o": ["mode6", "mode7", "mode8", "spectrum"],
    "ch4": ["mode6", "mode9", "mode11", "mode12", "spectrum"],  # T2 x3, E x2, A1, T2 x3: one image per set
    "d2o": ["mode6", "mode7", "mode8", "spectrum"],
    "h2o-hf": ["mode6", "mode7", "mode8", "spectrum", "experiment"],  # PySCF's RHF/6-31G* (a base dependency)
    "charged-particle": ["orbits", "response"],
    "ubiquitin-anm": ["modes", "spectrum", "bfactors", "correlations"],
    "ubiquitin-gnm": ["modes", "profiles", "spectrum", "bfactors", "correlations"],
    "glua3-ntd-anm": ["modes", "spectrum", "bfactors", "correlations"],
    "argon-fcc": ["bands", "thermal"],        # and argon-fcc_mode.gif (the supercell render)
    "silicon-diamond": ["bands", "thermal"],  # and silicon-diamond_mode.gif
    "nacl-polar": ["bands", "infrared"],      # phonopy's NaCl with its BORN file: LO-TO and the reststrahlen band
    "fput-alpha": ["mode_energies"],
    "isokinetic": ["energies"],
    "nose-hoover": ["histogram"],
}


@pytest.mark.slow
def test_report_bundled_scenes_end_to_end(tmp_path: Path) -> None:
    out = tmp_path / "plots"
    run = vibra("report", *BUNDLED_FOLDERS, "--out", str(out), "--jobs", "2", "--window-size", "320x200",
                env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    assert run.returncode == 0, run.stdout + run.stderr
    n = len(EXPECTED)
    assert f"{n} scenes, 0 failed" in run.stdout
    assert f"{n}/{n}" in run.stderr  # the progress bar
    summary = json.loads((out / "summary.json").read_text())
    assert {s["name"] for s in summary["scenes"]} == set(EXPECTED)
    for entry in summary["scenes"]:
        assert entry["status"] == "ok"
        expected = [f"{entry['name']}_{what}.png" for what in EXPECTED[entry["name"]]]
        assert [o for o in entry["outputs"] if o.endswith(".png")] == expected
        for name in expected:
            picture = complete_png(out / name)
            rendered = (name.endswith("_modes.png") or name[:-4].rsplit("_", 1)[-1].removeprefix("mode").isdigit()) \
                and entry["name"] not in ("double-pendulum", "charged-particle")  # pyvista
            if rendered:
                assert picture.shape == (200, 320, 3), name  # the --window-size asked for
            else:
                assert picture.shape[1] >= 600, name  # charts keep their legible default size
            assert picture.std() > 5.0, name  # not blank (see tests/pipeline/test_render.py)
    assert (out / "co2_crosscheck.txt").is_file() and (out / "co2_mode5.gif").is_file()
    assert (out / "monatomic-fixed_mode0.gif").is_file()
    assert (out / "argon-fcc_mode.gif").is_file() and (out / "silicon-diamond_mode.gif").is_file()
    pages = {name: (out / "scenes" / f"{name}.html").read_text() for name in EXPECTED}
    assert all(f"src='../{name}_{what}.png'" in pages[name] for name, whats in EXPECTED.items() for what in whats)
    index = (out / "index.html").read_text()
    assert all(f"href='scenes/{name}.html'" in index for name in EXPECTED)
    again = vibra("report", *BUNDLED_FOLDERS, "--out", str(out), "--window-size", "320x200")
    assert again.returncode == 0 and again.stdout.count("skipped") == n


def _all_outputs_complete(out: Path) -> int:
    """Check every visible file in `out` is complete; return the number of PNGs."""
    count = 0
    for path in out.iterdir():
        if path.name.startswith("."):
            continue  # hidden: work folders, manifests and in-flight temp files are not outputs
        if path.suffix == ".png":
            complete_png(path)
            count += 1
        elif path.suffix == ".json":
            json.loads(path.read_text())
    return count


@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGINT])
def test_killed_run_leaves_no_half_written_file(tmp_path: Path, how: signal.Signals) -> None:
    """Killed or interrupted once the first images are out: every visible output is complete.
    The bundled chains plus two more copies of the 10^6-site chain (~8 s each since the
    compiled bisection): the run is still busy when the signal arrives."""
    out = tmp_path / "out"
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    for scene in (ROOT / "chains").glob("*.toml"):
        shutil.copy(scene, scenes / scene.name)
    for copy in ("long-chain-2.toml", "long-chain-3.toml"):
        shutil.copy(ROOT / "chains" / "long-chain.toml", scenes / copy)
    # SIGINT as a terminal delivers it: a test run started in the background by a shell
    # (`pytest &`) ignores SIGINT, and its children inherit that, so Python would not turn it
    # into KeyboardInterrupt
    process = subprocess.Popen([sys.executable, "-m", "vibra", "report", str(scenes), "--out", str(out),
                                "--force", "--window-size", "320x200", "--quiet"], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not (out.is_dir() and list(out.glob("*.png"))):
        time.sleep(0.05)
    process.send_signal(how)
    _, stderr = process.communicate(timeout=60)
    if how == signal.SIGINT:
        assert process.returncode == 130, stderr
        assert "interrupted" in stderr
    else:
        assert process.returncode == -signal.SIGKILL
    assert _all_outputs_complete(out) >= 1
