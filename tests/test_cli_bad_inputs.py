"""Bad inputs on the command line (issue 16): every one refused in one line, never a traceback or a hang.

The rule (STYLE.md): each failure is one line, ``file: key.path: what is wrong; what is
expected``, and a non-zero exit. Scene cases run ``vibra validate`` in this process (fast);
cases that could hang or need real processes (a FIFO, /dev/zero, two reports at once, a kill)
run ``vibra`` in a subprocess with a timeout. The library's bad inputs are in
``tests/_core/test_bad_inputs.py``. Truth: the rule itself and the issue's list of cases.
"""

from __future__ import annotations

import json
import os
import re
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from helpers.phonopy_files import write_force_sets
from vibra import cli

ROOT = Path(__file__).resolve().parent.parent

CHAIN = 'kind = "chain"\n[system]\nbuilder = "linear_chain"\nn = 4\n'


def chain(system: str = "", compute: str = "", draw: str = "", top: str = "") -> str:
    """A small valid chain scene with lines added to its tables."""
    text = f'kind = "chain"\n{top}[system]\nbuilder = "linear_chain"\nn = 4\n{system}'
    if compute:
        text += f"[compute]\n{compute}"
    if draw:
        text += f"[draw]\n{draw}"
    return text


def scene(kind: str, builder: str, system: str = "", compute: str = "", draw: str = "") -> str:
    text = f'kind = "{kind}"\n[system]\nbuilder = "{builder}"\n{system}'
    if compute:
        text += f"[compute]\n{compute}"
    if draw:
        text += f"[draw]\n{draw}"
    return text


RESPONSE = "[compute.response]\nomega_min = 0.1\nomega_max = 2.0\n"
MATRICES = 'kind = "generalized"\n[system]\nbuilder = "matrices"\n'
SPRINGS = 'kind = "chain"\n[system]\nbuilder = "springs"\n'


def run_cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def one_line_failure(text: str) -> str:
    """The first FAIL line of a validate run of one scene (a FAIL line per problem of its keys, each one
    line: every other line is the summary), and no traceback."""
    lines = [line for line in text.splitlines() if line.startswith("FAIL ")]
    assert lines and all(line.startswith(("FAIL ", "ok   ")) or re.fullmatch(r"\d+ scenes?, \d+ invalid", line)
                         for line in text.splitlines()), text
    assert "1 scene, 1 invalid" in text, text
    assert "Traceback" not in text
    return lines[0]


#: (case id, scene text, key path in the message, fragment of the message). The issue's cases
#: ("Validation does not predict the run") are marked with "issue:".
SCENES = [
    # ---- the file itself
    ("empty-file", "", "kind", "is required"),
    ("bom-then-invalid", "\ufeffkind = ", "", "invalid TOML"),
    ("invalid-toml-unclosed", "kind = [\n", "", "invalid TOML"),
    ("invalid-toml-duplicate", 'kind = "chain"\nkind = "chain"\n', "", "invalid TOML"),
    ("invalid-toml-bare-word", "kind = chain\n", "", "invalid TOML"),
    ("nul-bytes", "kind = \"chain\"\x00\n", "", "invalid TOML"),
    ("nested-2000-lists", "a = " + "[" * 2000 + "]" * 2000 + "\n", "", "nested too deeply"),
    ("nested-2000-tables", "a = " + "{b = " * 2000 + "1" + "}" * 2000 + "\n", "", "nested too deeply"),
    ("nested-12-lists", chain(system="x = " + "[" * 12 + "]" * 12 + "\n"), "system.x", "nested more than 8"),
    ("top-level-unknown", 'kind = "chain"\ncolour = "red"\n[system]\nbuilder = "linear_chain"\nn = 4\n',
     "colour", "unknown key"),
    ("huge-key-name", 'kind = "chain"\n' + "k" * 5000 + ' = 1\n[system]\nbuilder = "linear_chain"\nn = 4\n',
     "kkkk", "unknown key"),
    # ---- top-level values
    ("kind-missing", '[system]\nbuilder = "linear_chain"\nn = 4\n', "kind", "is required"),
    ("kind-unknown", 'kind = "liquid"\n[system]\nbuilder = "linear_chain"\nn = 4\n', "kind", "expected one of"),
    ("kind-number", 'kind = 3\n[system]\nbuilder = "linear_chain"\nn = 4\n', "kind", "expected one of"),
    ("units-unknown", chain(top='units = "cgs"\n'), "units", "expected one of"),
    ("name-unsafe", chain(top='name = "../x"\n'), "name", "not a safe file name"),
    ("name-absolute", chain(top='name = "/tmp/x"\n'), "name", "not a safe file name"),
    ("name-too-long", chain(top=f'name = "{"a" * 100}"\n'), "name", "not a safe file name"),
    ("name-number", chain(top="name = 3\n"), "name", "expected a string"),
    ("system-missing", 'kind = "chain"\n', "system", "is required"),
    ("system-not-table", 'kind = "chain"\nsystem = 3\n', "system", "expected a table"),
    ("compute-not-table", 'kind = "chain"\ncompute = 3\n[system]\nbuilder = "linear_chain"\nn = 4\n', "compute",
     "expected a table"),
    ("builder-missing", 'kind = "chain"\n[system]\nn = 4\n', "system.builder", "is required"),
    ("builder-unknown", 'kind = "chain"\n[system]\nbuilder = "linear_chian"\nn = 4\n', "system.builder",
     "did you mean 'linear_chain'"),
    ("builder-number", 'kind = "chain"\n[system]\nbuilder = 1\n', "system.builder", "expected a string"),
    ("builder-wrong-kind", 'kind = "molecule"\n[system]\nbuilder = "linear_chain"\nn = 4\n', "system.builder",
     "does not make a 'molecule' scene"),
    # ---- system sizes: issue cases and memory
    ("issue:n-1e9", 'kind = "chain"\n[system]\nbuilder = "linear_chain"\nn = 1000000000\n', "system.n",
     "would need about"),
    ("issue:n-1e20", 'kind = "chain"\n[system]\nbuilder = "linear_chain"\nn = 100000000000000000000\n',
     "system.n", "would need about"),
    ("n-1e9-beaded", scene("chain", "beaded_string", "n = 1000000000\n"), "system.n", "would need about"),
    ("n-cells-1e12", scene("chain", "diatomic_chain", "n_cells = 1000000000000\nmasses = [1.0, 2.0]\n"),
     "system.n_cells", "would need about"),
    ("shapes-of-1e6", chain(system="", compute="shapes = true\n").replace("n = 4", "n = 1000000"),
     "compute.n_modes", "mode shapes"),
    ("response-points-memory", chain(compute="[compute.response]\nomega_min = 0.1\nomega_max = 2.0\n"
                                     "n_points = 100000\n").replace("n = 4", "n = 100000"),
     "compute.response.n_points", "would need about"),
    ("all-modes-of-1e7", chain().replace("n = 4", "n = 10000000"), "compute.n_modes",
     "about 2e+06 s, more than the limit of 600 s"),  # (dqds and a certificate per value: 2e-8 N^2)
    ("time-limit-negative", chain(compute="time_limit_s = 0.0\n"), "compute.time_limit_s", "must be positive"),
    ("memory-limit-tiny", chain(compute="memory_limit_gib = 1e-9\n"), "system.n", "compute.memory_limit_gib"),
    ("memory-limit-negative", chain(compute="memory_limit_gib = -1.0\n"), "compute.memory_limit_gib",
     "must be positive"),
    ("n-zero", chain().replace("n = 4", "n = 0"), "system.n", "must be >= 2"),
    ("n-negative", chain().replace("n = 4", "n = -3"), "system.n", "must be >= 2"),
    ("n-float", chain().replace("n = 4", "n = 4.5"), "system.n", "expected an integer"),
    ("n-string", chain().replace("n = 4", 'n = "4"'), "system.n", "expected an integer"),
    ("n-bool", chain().replace("n = 4", "n = true"), "system.n", "expected an integer"),
    # ---- system values
    ("mass-zero", chain("mass = 0.0\n"), "system.mass", "must be positive"),
    ("mass-negative", chain("mass = -1.0\n"), "system.mass", "must be positive"),
    ("mass-nan", chain("mass = nan\n"), "system.mass", "finite"),
    ("mass-inf", chain("mass = inf\n"), "system.mass", "finite"),
    ("mass-empty-list", chain("mass = []\n"), "system.mass", "at least 1"),
    ("mass-list-length", chain("mass = [1.0, 2.0]\n"), "system.mass", "needs 4 values"),
    ("mass-string", chain('mass = "heavy"\n'), "system.mass", "expected a number"),
    ("stiffness-list-length", chain("stiffness = [1.0]\n"), "system.stiffness", "needs 3 values"),
    ("spacing-zero", chain("spacing = 0.0\n"), "system.spacing", "must be positive"),
    ("ends-unknown", chain('ends = "open"\n'), "system.ends", "expected one of"),
    ("system-typo", chain("stifness = 1.0\n"), "system.stifness", "did you mean 'stiffness'"),
    ("defect-alone", chain("defect_site = 1\n"), "system.defect_mass", "go together"),
    ("defect-out-of-range", chain("defect_site = 9\ndefect_mass = 2.0\n"), "system.defect_site",
     "sites run from 0 to 3"),
    ("frozen-out-of-range", chain("frozen_sites = [7]\n"), "system.frozen_sites[0]", "sites run from 0 to 3"),
    ("frozen-everything", chain("frozen_sites = [0, 1, 2, 3]\n"), "system.frozen_sites", "nothing is left"),
    ("frozen-dof-out-of-range", chain("frozen_dofs = [4]\n"), "system.frozen_dofs[0]", "run from 0 to 3"),
    ("issue:beaded-n-1", scene("chain", "beaded_string", "n = 1\n"), "system.n", "n >= 2"),
    ("diatomic-three-masses", scene("chain", "diatomic_chain", "n_cells = 2\nmasses = [1.0, 2.0, 3.0]\n"),
     "system.masses", "needs 2 values"),
    ("co2-dims-2", scene("molecule", "co2", "dims = 2\n"), "system.dims", "expected one of"),
    ("h2o-unknown-key", scene("molecule", "h2o", "stretch = 1.0\n"), "system.stretch", "unknown key"),
    ("oscillator-negative-gamma", scene("oscillator", "oscillator", "w0 = 1.0\ngamma = -0.1\nm = 1.0\n"),
     "system.gamma", "must be >= 0"),
    ("pendulum-zero-length", scene("generalized", "double_pendulum", "m = 1.0\nm_prime = 1.0\na = 0.0\nb = 1.0\n"
                                   "g = 9.8\n"), "system.a", "must be positive"),
    # ---- matrices: issue cases
    ("issue:M-not-positive-definite", MATRICES + "M = [[1.0, 2.0], [2.0, 1.0]]\nK = [[1.0, 0.0], [0.0, 1.0]]\n",
     "system.M", "not positive definite"),
    ("issue:K-not-symmetric", MATRICES + "M = [[1.0, 0.0], [0.0, 1.0]]\nK = [[1.0, 0.5], [0.0, 1.0]]\n",
     "system.K", "not symmetric"),
    ("K-not-square", MATRICES + "M = [[1.0, 0.0], [0.0, 1.0]]\nK = [[1.0, 0.5], [0.5]]\n", "system.K",
     "square matrix"),
    ("K-size-differs", MATRICES + "M = [[1.0]]\nK = [[1.0, 0.0], [0.0, 1.0]]\n", "system.K", "must be 1x1"),
    ("K-string-entry", MATRICES + 'M = [[1.0]]\nK = [["a"]]\n', "system.K", "expected a number"),
    ("coordinates-count", MATRICES + 'M = [[1.0]]\nK = [[1.0]]\ncoordinates = ["x", "y"]\n',
     "system.coordinates", "needs 1 names"),
    # ---- springs: issue case
    # (issue 34: two sites in one place are the positions' fault, not the springs')
    ("issue:springs-same-position", SPRINGS + "positions = [0.0, 0.0]\nmasses = 1.0\nsprings = [[0, 1]]\n"
     "stiffness = 1.0\n", "system.positions", "same position"),
    ("springs-index-out-of-range", SPRINGS + "positions = [0.0, 1.0]\nmasses = 1.0\nsprings = [[0, 5]]\n"
     "stiffness = 1.0\n", "system.springs[0]", "site indices run from 0 to 1"),
    ("springs-self", SPRINGS + "positions = [0.0, 1.0]\nmasses = 1.0\nsprings = [[1, 1]]\nstiffness = 1.0\n",
     "system.springs[0]", "two different sites"),
    ("springs-missing", SPRINGS + "positions = [0.0, 1.0]\nmasses = 1.0\n", "system.springs", "is required"),
    ("springs-ragged-positions", SPRINGS + "positions = [[0.0, 1.0], [1.0]]\nmasses = 1.0\nsprings = [[0, 1]]\n"
     "stiffness = 1.0\n", "system.positions", "same number"),
    ("anchors-without-stiffness", SPRINGS + "positions = [0.0, 1.0]\nmasses = 1.0\nsprings = [[0, 1]]\n"
     "stiffness = 1.0\nanchors = [0]\n", "system.anchor_stiffness", "is required with anchors"),
    ("symbols-unknown", 'kind = "molecule"\n[system]\nbuilder = "springs"\npositions = [[0.0, 0, 0], [1.0, 0, 0]]\n'
     'masses = 1.0\nsprings = [[0, 1]]\nstiffness = 1.0\nsymbols = ["H", "Xx"]\n', "system.symbols[1]",
     "not a chemical symbol"),
    ("symbols-not-drawable", 'kind = "molecule"\n[system]\nbuilder = "springs"\n'
     'positions = [[0.0, 0, 0], [1.0, 0, 0]]\nmasses = 1.0\nsprings = [[0, 1]]\nstiffness = 1.0\n'
     'symbols = ["H", "Og"]\n[draw]\nmodes = true\n', "system.symbols[1]", "IR-activity hints"),
    # ---- compute
    ("n-modes-zero", chain(compute="n_modes = 0\n"), "compute.n_modes", "must be >= 1"),
    ("n-modes-too-many", chain(compute="n_modes = 9\n"), "compute.n_modes", "only 4 degrees of freedom"),
    ("band-reversed", chain(compute="band = [2.0, 1.0]\n"), "compute.band", "low < high"),
    ("band-three", chain(compute="band = [1.0, 2.0, 3.0]\n"), "compute.band", "needs 2 values"),
    ("band-and-n-modes", chain(compute="band = [1.0, 2.0]\nn_modes = 2\n"), "compute.band", "not both"),
    ("band-empty", chain(compute="band = [100.0, 200.0]\n"), "compute.band", "no mode has omega"),
    ("accuracy-unknown", chain(compute='accuracy = "best"\n'), "compute.accuracy", "expected one of"),
    ("solver-unknown", chain(compute='solver = "bidiagonal"\n'), "compute.solver", "expected one of"),
    ("solver-sparse-all", chain(compute='solver = "sparse"\n'), "compute.solver", "give compute.n_modes"),
    ("solver-accurate-fast", chain(compute='solver = "accurate"\naccuracy = "fast"\n'), "compute.solver",
     "needs accuracy"),
    ("solver-tridiagonal-periodic", chain('ends = "periodic"\n', compute='solver = "tridiagonal"\n'),
     "compute.solver", "tridiagonal K"),
    ("solver-banded-full-mass", MATRICES + "M = [[2.0, 1.0], [1.0, 2.0]]\nK = [[1.0, 0.0], [0.0, 1.0]]\n"
     '[compute]\nsolver = "banded"\n', "compute.solver", "diagonal masses"),
    ("solver-accurate-matrices", MATRICES + "M = [[1.0]]\nK = [[1.0]]\n[compute]\nsolver = \"accurate\"\n",
     "compute.solver", "spring system"),
    ("crosscheck-chain", chain(compute="crosscheck = true\n"), "compute.crosscheck", "is available for"),
    ("response-range", chain(compute="[compute.response]\nomega_min = 2.0\nomega_max = 1.0\n"),
     "compute.response.omega_max", "must exceed omega_min"),
    ("response-one-point", chain(compute=RESPONSE + "n_points = 1\n"), "compute.response.n_points",
     "2 <= value"),
    ("response-force-site", chain(compute=RESPONSE + "force_site = 4\n"), "compute.response.force_site",
     "run from 0 to 3"),
    ("response-method", chain(compute=RESPONSE + 'method = "fast"\n'), "compute.response.method",
     "expected one of"),
    ("issue:response-n-modes-direct", chain(compute=RESPONSE + "n_modes = 2\n"), "compute.response.n_modes",
     'method = "modal" only'),
    ("issue:response-omega-min-0-free-chain", chain(compute="[compute.response]\nomega_min = 0.0\n"
                                                    "omega_max = 2.0\nalpha = 0.1\n"),
     "compute.response.omega_min", "rigid-body modes"),
    ("issue:response-omega-min-0-molecule", scene("molecule", "co2", "dims = 1\n", compute="[compute.response]\n"
                                                  "omega_min = 0.0\nomega_max = 2.0\n"),
     "compute.response.omega_min", "rigid-body modes"),
    # fixed-end chain of 2 unit masses and springs: omega = 1 and sqrt(3); the grid 0.5, 1, 1.5 meets 1
    ("issue:undamped-resonance-on-grid", chain('ends = "fixed"\n', compute="[compute.response]\nomega_min = 0.5\n"
                                               "omega_max = 1.5\nn_points = 3\n").replace("n = 4", "n = 2"),
     "compute.response", "singular"),
    ("issue:continuum-sizes-decreasing", chain(compute="[compute.continuum]\nsizes = [16, 8]\n"),
     "compute.continuum.sizes[1]", "must increase"),
    ("continuum-one-size", chain(compute="[compute.continuum]\nsizes = [16]\n"), "compute.continuum.sizes",
     "at least 2"),
    ("continuum-mode-too-high", chain(compute="[compute.continuum]\nsizes = [4, 8]\nmodes = [4]\n"),
     "compute.continuum.modes", "longer than the smallest"),
    ("continuum-molecule", scene("molecule", "h2o", compute="[compute.continuum]\nsizes = [4, 8]\n"),
     "compute.continuum", "applies to chains"),
    # ---- draw
    ("issue:dispersion-mass-list", chain("mass = [1.0, 2.0, 1.0, 2.0]\n", draw="dispersion = true\n"),
     "draw.dispersion", "needs a uniform chain"),
    ("issue:dispersion-stiffness-list", chain("stiffness = [1.0, 2.0, 1.0]\n", draw="dispersion = true\n"),
     "draw.dispersion", "needs a uniform chain"),
    ("dispersion-beaded", scene("chain", "beaded_string", "n = 4\n", draw="dispersion = true\n"),
     "draw.dispersion", "linear_chain or diatomic_chain"),
    ("convergence-without-continuum", chain(draw="convergence = true\n"), "draw.convergence",
     "[compute.continuum]"),
    ("response-drawing-without-response", chain(draw="response = true\n"), "draw.response", "[compute.response]"),
    ("gif-generalized", scene("generalized", "double_pendulum", draw="gif = true\n"), "draw.gif", "animates"),
    ("oscillator-modes", scene("oscillator", "oscillator", "w0 = 1.0\ngamma = 0.1\nm = 1.0\n",
                               draw="modes = true\n"), "draw.modes", "draws only its response"),
    ("n-draw-zero", chain(draw="n_draw = 0\n"), "draw.n_draw", "1 <= value <= 24"),
    ("window-size-tiny", chain(draw="window_size = [10, 10]\n"), "draw.window_size", "64 <= value"),
    ("window-size-one", chain(draw="window_size = [640]\n"), "draw.window_size", "needs 2 values"),
    ("draw-string-flag", chain(draw='modes = "yes"\n'), "draw.modes", "expected true or false"),
]


@pytest.mark.parametrize("case, text, key, fragment", SCENES, ids=[case[0] for case in SCENES])
def test_validate_refuses_in_one_line(case: str, text: str, key: str, fragment: str, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "scene.toml"
    path.write_text(text, encoding="utf-8")
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 1, out
    line = one_line_failure(out)
    where = f"FAIL {path}: {key}" if key else f"FAIL {path}: "
    assert line.startswith(where), line
    assert fragment in line, line
    assert len(line) < 600 and "Traceback" not in err


def test_scene_keys_of_the_refusals_are_distinct_cases() -> None:
    assert len({case[0] for case in SCENES}) == len(SCENES) >= 100


def test_limits_can_be_raised() -> None:
    from vibra.pipeline.scene import Scene

    table = {"kind": "chain", "system": {"builder": "linear_chain", "n": 300_000}}
    with pytest.raises(ValueError, match=r"compute\.n_modes: is not given, so all 300000 modes"):
        Scene.from_dict(table, source="s.toml")  # ~1,800 s of O(N^2) work (dqds and a certificate per value)
    assert Scene.from_dict({**table, "compute": {"time_limit_s": 2000.0}}, source="s.toml").compute.time_limit_s == 2000
    assert Scene.from_dict({**table, "compute": {"n_modes": 10}}, source="s.toml").compute.n_modes == 10
    big = {"kind": "chain", "system": {"builder": "linear_chain", "n": 10**9}, "compute": {"n_modes": 3}}
    with pytest.raises(ValueError, match=r"system\.n: would need about 596 GiB"):
        Scene.from_dict(big, source="s.toml")
    raised = {**big, "compute": {"n_modes": 3, "memory_limit_gib": 1000.0}}
    assert Scene.from_dict(raised, source="s.toml").compute.memory_limit_gib == 1000.0


def test_a_byte_order_mark_is_tolerated(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + CHAIN.encode())  # issue: refused as invalid TOML before
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 0 and f"ok   {path}" in out


@pytest.mark.parametrize("raw", [b"kind = \"caf\xe9\"\n", b"\xff\xfe" + "kind = 1".encode("utf-16-le")],
                         ids=["latin-1", "utf-16"])
def test_not_utf8_is_one_line(raw: bytes, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "latin.toml"
    path.write_bytes(raw)
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 1 and "not UTF-8 text" in one_line_failure(out)


def test_a_file_over_the_size_cap_is_refused_unread(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "huge.toml"
    path.write_bytes(b"# " + b"x" * (1 << 20) + b"\n")
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 1 and "a scene file may hold at most 1048576 bytes" in one_line_failure(out)


def test_a_file_at_the_size_cap_is_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    body = CHAIN.encode()
    path = tmp_path / "padded.toml"
    path.write_bytes(body + b"#" + b"x" * ((1 << 20) - len(body) - 2) + b"\n")
    assert path.stat().st_size == 1 << 20
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 0, out


@pytest.mark.parametrize("make", ["dangling", "loop", "folder-named-toml"])
def test_broken_scene_paths_are_one_line(make: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "scene.toml"
    if make == "dangling":
        path.symlink_to(tmp_path / "nowhere.toml")
        fragment = "file not found"
    elif make == "loop":
        path.symlink_to(path)
        fragment = "cannot read file"
    else:
        path.mkdir()
        (path / "inner.toml").write_text("kind = 3\n")  # a folder is expanded; its scene is checked
        fragment = "kind"
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 1 and fragment in one_line_failure(out), out + err


def vibra(*args: str, timeout: float = 60, **kwargs: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vibra", *args], capture_output=True, text=True, cwd=ROOT,
                          timeout=timeout, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
                          **kwargs)  # type: ignore[call-overload]


@pytest.mark.parametrize("target", ["fifo", "dev-zero", "dev-null"])
def test_special_files_are_refused_without_reading(target: str, tmp_path: Path) -> None:
    # issue: a FIFO hung forever; a symlink to /dev/zero read until MemoryError
    path = tmp_path / "scene.toml"
    if target == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero" if target == "dev-zero" else "/dev/null")
    run = vibra("validate", str(path), timeout=30)  # the timeout is the guard against a hang, not a figure
    assert run.returncode == 1 and "not a regular file" in one_line_failure(run.stdout)
    report = vibra("report", str(path), "--out", str(tmp_path / "out"), "--quiet", timeout=30)
    assert report.returncode == 1 and "not a regular file" in report.stderr and "Traceback" not in report.stderr


# ---------------------------------------------------------------------- the command line itself
@pytest.mark.parametrize("args, fragment", [
    (["--jobs", "0"], "--jobs must be >= 1"),
    (["--jobs", "x"], "--jobs must be an integer"),
    (["--jobs", "-3"], "--jobs must be >= 1"),
    (["--window-size", "big"], "window size must look like 800x600"),
    (["--window-size", "10x10"], "out of range"),
    (["--wait", "-1"], "--wait must be between 0 and 86400"),
    (["--wait", "soon"], "--wait must be a number of seconds"),
    (["--colour"], "unrecognized arguments: --colour"),
], ids=["jobs-0", "jobs-x", "jobs-negative", "window-word", "window-small", "wait-negative", "wait-word",
        "unknown-option"])
def test_usage_errors_are_one_line(args: list[str], fragment: str, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        cli.main(["report", str(ROOT / "chains" / "monatomic-free.toml"), "--out", str(tmp_path / "o"), *args])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and fragment in err and "--help" in err
    assert not (tmp_path / "o").exists()


def test_unknown_command_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        cli.main(["render"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "invalid choice: 'render'" in err


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    from importlib.metadata import version

    with pytest.raises(SystemExit) as stop:
        cli.main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"vibra {version('vibra')}"


def test_jobs_defaults_to_the_available_cores() -> None:
    args = cli.build_parser().parse_args(["report", "x"])
    assert args.jobs is None  # filled in by _report from the affinity mask
    from vibra.pipeline.report import available_cores

    assert available_cores() == len(os.sched_getaffinity(0))


def test_missing_input_is_a_usage_error_that_touches_nothing(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "index.html").write_text("<p>earlier run</p>")
    (out / "summary.json").write_text('{"scenes": []}')
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    code, _, err = run_cli(capsys, "report", str(ROOT / "chains" / "monatomic-free.toml"),
                           str(tmp_path / "nonexistent.toml"), "--out", str(out), "--quiet")
    assert code == 2
    assert err.strip() == (f"vibra report: {tmp_path / 'nonexistent.toml'}: no such file or folder; expected scene "
                           "files (*.toml) or folders of them (nothing was written)")
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


def test_missing_input_creates_no_output_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, _ = run_cli(capsys, "report", str(tmp_path / "typo.toml"), "--out", str(tmp_path / "new"))
    assert code == 2 and not (tmp_path / "new").exists()


def _out_target(kind: str, tmp_path: Path) -> tuple[Path, str]:
    if kind == "regular-file":
        path = tmp_path / "file"
        path.write_text("x")
        return path, "is a regular file"
    if kind == "dangling-symlink":
        path = tmp_path / "link"
        path.symlink_to(tmp_path / "nowhere")
        return path, "is a symlink to a missing target"
    if kind == "symlink-loop":
        path = tmp_path / "loop"
        path.symlink_to(path)
        return path, "is a symlink loop"
    if kind == "dev-null":
        return Path("/dev/null"), "is a device"
    if kind == "below-a-file":
        (tmp_path / "file").write_text("x")
        return tmp_path / "file" / "out", "its parent"
    if kind == "summary-is-a-folder":
        (tmp_path / "o" / "summary.json").mkdir(parents=True)
        return tmp_path / "o", "summary.json is a folder"
    if kind == "bookkeeping-is-a-file":
        (tmp_path / "o").mkdir()
        (tmp_path / "o" / ".vibra").write_text("x")
        return tmp_path / "o", ".vibra is not a folder"
    raise AssertionError(kind)


OUT_KINDS = ["regular-file", "dangling-symlink", "symlink-loop", "dev-null", "below-a-file", "summary-is-a-folder",
             "bookkeeping-is-a-file"]


@pytest.mark.parametrize("kind", OUT_KINDS)
def test_bad_output_folders_are_one_line(kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # issue: tracebacks from mkdir
    out, fragment = _out_target(kind, tmp_path)
    code, _, err = run_cli(capsys, "report", str(ROOT / "chains" / "monatomic-free.toml"), "--out", str(out),
                           "--quiet")
    assert code == 1
    assert err.count("\n") == 1 and err.startswith("vibra report: --out") and fragment in err, err


def test_read_only_output_folder_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    # As root a chmod does not stop writes: the check asks os.access, patched here to answer
    # as it does for an ordinary user in a 0555 folder (test_read_only_output_folder_for_real).
    out = tmp_path / "ro"
    out.mkdir()
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **k: False if Path(p) == out else real_access(p, mode, **k))
    code, _, err = run_cli(capsys, "report", str(ROOT / "chains" / "monatomic-free.toml"), "--out", str(out))
    assert code == 1 and err.strip() == f"vibra report: --out {out}: the folder is not writable; choose another " \
                                        "--out or change its permissions"
    assert list(out.iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_output_folder_for_real(tmp_path: Path) -> None:
    out = tmp_path / "ro"
    out.mkdir()
    out.chmod(0o555)
    try:
        run = vibra("report", str(ROOT / "chains" / "monatomic-free.toml"), "--out", str(out))
    finally:
        out.chmod(0o755)
    assert run.returncode == 1 and "not writable" in run.stderr and "Traceback" not in run.stderr


def test_a_folder_where_an_output_file_goes_fails_that_scene(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(chain(draw="spectrum = true\n"))
    out = tmp_path / "out"
    (out / "small_spectrum.png").mkdir(parents=True)
    (out / ".vibra").mkdir()  # a folder vibra wrote before (another folder is refused whole: test_hostile_files)
    code, stdout, err = run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet", "--jobs", "1")
    assert code == 1
    assert f"FAILED {scene_file}: name: this scene's output file {out / 'small_spectrum.png'}: is a folder; vibra " \
           "writes regular files only" in err
    assert "Traceback" not in err + stdout and (out / "small_spectrum.png").is_dir()


def test_unexpected_error_is_one_line_and_debug_shows_the_traceback(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    import vibra.pipeline.plan

    def broken(scene: object) -> None:
        raise KeyError("a bug")

    monkeypatch.setattr(vibra.pipeline.plan, "validate", broken)
    path = tmp_path / "s.toml"
    path.write_text(CHAIN)
    code, _, err = run_cli(capsys, "validate", str(path))
    assert code == 3 and err.count("\n") == 1 and "Traceback" not in err
    assert "internal error: KeyError: 'a bug'; rerun with --debug" in err
    code, _, err = run_cli(capsys, "--debug", "validate", str(path))
    assert code == 3 and "Traceback (most recent call last)" in err


def test_modes_refusals_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    oscillator = tmp_path / "osc.toml"
    oscillator.write_text(scene("oscillator", "oscillator", "w0 = 1.0\ngamma = 0.1\nm = 1.0\n"))
    code, _, err = run_cli(capsys, "modes", str(oscillator))
    assert code == 1 and err.strip() == f"vibra modes: {oscillator}: kind: an oscillator scene has no normal modes " \
                                        "to list"
    code, _, err = run_cli(capsys, "modes", str(tmp_path / "none.toml"))
    assert code == 1 and err.count("\n") == 1 and "file not found" in err


def test_modes_of_a_scene_with_a_response_from_zero_lists_the_modes(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    # the response check is for `report`; the table only needs the modes
    path = tmp_path / "free.toml"
    path.write_text(chain(compute="[compute.response]\nomega_min = 0.0\nomega_max = 2.0\n"))
    code, out, _ = run_cli(capsys, "modes", str(path))
    assert code == 0 and "4 of 4 modes" in out


def test_validate_of_a_folder_without_scenes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_cli(capsys, "validate", str(tmp_path))
    assert code == 1 and err.count("\n") == 1 and "no scene file (*.toml)" in err


# ---------------------------------------------------------------------- reports that stay whole
def complete_png(path: Path) -> np.ndarray:
    with Image.open(path) as handle:
        handle.load()
        return np.asarray(handle.convert("RGB"))


def write_scenes(folder: Path, count: int) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(count):
        path = folder / f"c{i}.toml"
        path.write_text(chain(draw="spectrum = true\n").replace("n = 4", f"n = {4 + i}"))
        paths.append(path)
    return paths


def test_a_second_report_waits_for_the_first(tmp_path: Path) -> None:
    # issue: two runs into one folder both failed, each deleting the other's work folder
    scenes = write_scenes(tmp_path / "scenes", 3)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "vibra", "report", *map(str, scenes), "--out", str(out), "--quiet",
               "--jobs", "1", "--force", "--wait", "300"]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    first = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    second = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    results = [process.communicate(timeout=300) for process in (first, second)]
    assert first.returncode == 0 and second.returncode == 0, results
    summary = json.loads((out / "summary.json").read_text())
    assert sorted(s["name"] for s in summary["scenes"]) == ["c0", "c1", "c2"]
    for i in range(3):
        complete_png(out / f"c{i}_spectrum.png")
    assert not (out / ".work").exists()


def test_a_busy_folder_is_refused_naming_the_holder(tmp_path: Path) -> None:
    from vibra.pipeline.report import FolderLock

    out = tmp_path / "out"
    out.mkdir()
    scene_file = write_scenes(tmp_path / "scenes", 1)[0]
    with FolderLock(out, wait=0):
        run = vibra("report", str(scene_file), "--out", str(out), "--wait", "0", "--quiet")
    assert run.returncode == 1
    assert run.stderr.count("\n") == 1 and f"--out {out}: in use by pid {os.getpid()}, started " in run.stderr
    assert "(--wait 0)" in run.stderr and "Traceback" not in run.stderr
    assert not (out / "c0_spectrum.png").exists()


def test_kill_and_rerun_cleans_what_the_killed_run_left(tmp_path: Path) -> None:
    scenes = write_scenes(tmp_path / "scenes", 4)
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "vibra", "report", *map(str, scenes), "--out", str(out),
                                "--quiet", "--jobs", "1", "--force"], cwd=ROOT, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(out.glob("*.png")):
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=60)
    dead = process.pid
    # what a run killed at a worse moment leaves: its work folder and a temporary file
    (out / ".work" / str(dead) / "c3" / "out").mkdir(parents=True, exist_ok=True)
    (out / ".work" / str(dead) / "c3" / "out" / "c3_spectrum.png").write_bytes(b"\x89PNG half")
    stale = out / f".c3_spectrum.png.{dead}~tmp~abcd1234.tmp"
    stale.write_bytes(b"\x89PNG half")
    run = vibra("report", *map(str, scenes), "--out", str(out), "--quiet", "--jobs", "1", timeout=300)
    assert run.returncode == 0, run.stderr
    assert not stale.exists() and not (out / ".work").exists()
    for i in range(4):
        complete_png(out / f"c{i}_spectrum.png")
    assert [p.name for p in (out / ".vibra").iterdir() if "~tmp~" in p.name] == []


def test_a_live_process_keeps_its_work_folder(tmp_path: Path) -> None:
    from vibra.pipeline.report import clean_stale

    out = tmp_path / "out"
    mine = out / ".work" / str(os.getpid())
    mine.mkdir(parents=True)
    dead = out / ".work" / "999999999"
    dead.mkdir()
    old_style = out / ".work" / "co2-999999998"  # "<scene>-<pid>" of earlier versions
    old_style.mkdir()
    removed = clean_stale(out)
    assert mine.is_dir() and not dead.exists() and not old_style.exists()
    assert sorted(removed) == sorted([dead, old_style])


@pytest.mark.parametrize("damage", ["zero-bytes", "truncated", "not-a-png"])
def test_a_corrupt_leftover_output_is_redone(damage: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # issue: a zero-byte PNG was trusted and skipped on the next run
    scene_file = write_scenes(tmp_path / "scenes", 1)[0]
    out = tmp_path / "out"
    assert run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")[0] == 0
    image = out / "c0_spectrum.png"
    good = image.read_bytes()
    image.write_bytes({"zero-bytes": b"", "truncated": good[: len(good) // 2], "not-a-png": b"hello"}[damage])
    code, out_text, _ = run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")
    assert code == 0 and "skipped" not in out_text
    assert complete_png(image).std() > 5.0


def test_a_corrupt_manifest_means_redo(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene_file = write_scenes(tmp_path / "scenes", 1)[0]
    out = tmp_path / "out"
    run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")
    (out / ".vibra" / "c0.json").write_text("{not json")
    code, text, _ = run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")
    assert code == 0 and " ok " in text


def test_index_and_summary_merge_with_earlier_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # issue: a run of one scene rewrote index.html and summary.json with that one entry
    first, second = write_scenes(tmp_path / "scenes", 2)
    out = tmp_path / "out"
    assert run_cli(capsys, "report", str(first), str(second), "--out", str(out), "--quiet")[0] == 0
    second.write_text(chain(draw="spectrum = true\n").replace("n = 4", "n = 7"))
    assert run_cli(capsys, "report", str(second), "--out", str(out), "--quiet")[0] == 0
    summary = json.loads((out / "summary.json").read_text())
    assert [s["name"] for s in summary["scenes"]] == ["c0", "c1"]
    assert len(summary["scenes"][1]["frequencies"]["omega"]) == 7  # the re-run replaced its entry
    index = (out / "index.html").read_text()
    assert "src='c0_spectrum.png'" in index and "src='c1_spectrum.png'" in index


def test_summary_holds_numbers_with_units(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene_file = write_scenes(tmp_path / "scenes", 1)[0]
    out = tmp_path / "out"
    run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")
    entry = json.loads((out / "summary.json").read_text())["scenes"][0]
    numbers = entry["frequencies"]
    assert numbers["omega_unit"] == "rad/s" and numbers["unit"] == "Hz"
    assert all(isinstance(w, float) for w in numbers["omega"] + numbers["values"])
    # free chain of 4 unit masses and springs: omega_k = 2 sin(k pi / 8) (seed 003 eq. 161)
    expected = 2 * np.sin(np.arange(4) * np.pi / 8)
    assert np.allclose(numbers["omega"], expected, atol=1e-12)
    assert np.allclose(numbers["values"], expected / (2 * np.pi), atol=1e-12)


def test_changed_code_is_not_served_from_the_skip_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    # issue: the skip key was the scene's bytes and the version string only
    from vibra.pipeline.report import batch

    scene_file = write_scenes(tmp_path / "scenes", 1)[0]
    out = tmp_path / "out"
    run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")
    assert " skipped " in run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")[1]
    monkeypatch.setattr(batch, "code_hash", lambda: "another build of vibra")
    assert " ok " in run_cli(capsys, "report", str(scene_file), "--out", str(out), "--quiet")[1]


# ---------------------------------------------------------------------- issue 34: what the commands write
WATER = 'kind = "molecule"\nunits = "ASE"\n[system]\nbuilder = "h2o"\n'
XYZ_WATER = ('kind = "molecule"\nunits = "ASE"\n[system]\nbuilder = "molecule"\nxyz = "water.xyz"\n')
WATER_XYZ = "3\nwater\nO 0.0 0.0 0.119\nH 0.0 0.763 -0.477\nH 0.0 -0.763 -0.477\n"


def _tree(root: Path) -> dict[str, tuple[int, int, int, int]]:
    """Every entry below `root` (nothing followed or opened): kind+mode, size, mtime, inode (folders:
    kind+mode and inode)."""
    out = {}
    for folder, names, files in os.walk(root):
        for name in names + files:
            info = os.lstat(Path(folder) / name)
            folder_entry = stat.S_ISDIR(info.st_mode)
            out[str((Path(folder) / name).relative_to(root))] = (
                info.st_mode, 0 if folder_entry else info.st_size, 0 if folder_entry else info.st_mtime_ns, info.st_ino)
    return out


def _molden_target(kind: str, tmp_path: Path, scene_file: Path) -> tuple[Path, str]:
    """(the --molden FILE of one hostile kind, a fragment of the refusal)."""
    if kind == "scene-itself":
        return scene_file, "is an input of this run"
    if kind == "xyz-input":
        return tmp_path / "water.xyz", "is an input of this run"
    if kind == "symlink-to-scene":
        (tmp_path / "link.molden").symlink_to(scene_file)
        return tmp_path / "link.molden", "is an input of this run"
    if kind == "hardlink-to-scene":
        os.link(scene_file, tmp_path / "hard.molden")
        return tmp_path / "hard.molden", "is an input of this run"
    if kind == "folder":
        (tmp_path / "folder.molden").mkdir()
        return tmp_path / "folder.molden", "is a folder"
    if kind == "fifo":
        os.mkfifo(tmp_path / "fifo.molden")
        return tmp_path / "fifo.molden", "is a FIFO"
    if kind == "device":  # a node like /dev/null, made inside tmp_path (never the real one)
        try:
            os.mknod(tmp_path / "null", stat.S_IFCHR | 0o666, os.makedev(1, 3))
        except OSError:
            pytest.skip("cannot make a device node here (not root)")
        return tmp_path / "null", "is a device"
    if kind == "existing-without-force":
        (tmp_path / "old.molden").write_text("an earlier file")
        return tmp_path / "old.molden", "exists; --force replaces it"
    if kind == "below-a-file":
        (tmp_path / "plain").write_text("x")
        return tmp_path / "plain" / "h2o.molden", f"its folder {tmp_path / 'plain'} is a regular file, not a folder"
    raise AssertionError(kind)


MOLDEN_KINDS = ["scene-itself", "xyz-input", "symlink-to-scene", "hardlink-to-scene", "folder", "fifo", "device",
                "existing-without-force", "below-a-file"]


@pytest.mark.parametrize("kind", MOLDEN_KINDS)
def test_molden_never_writes_over_an_input_or_a_special_file(kind: str, tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: `--molden molecules/h2o.toml` overwrote the scene; `--molden NODE` replaced a device node
    scene_file = tmp_path / "water.toml"
    scene_file.write_text(XYZ_WATER)
    (tmp_path / "water.xyz").write_text(WATER_XYZ)
    target, fragment = _molden_target(kind, tmp_path, scene_file)
    before = _tree(tmp_path)
    code, out, err = run_cli(capsys, "modes", str(scene_file), "--molden", str(target))
    assert code == 1 and err.count("\n") == 1 and "Traceback" not in err + out, err
    assert err.startswith(f"vibra modes: {scene_file}: --molden {target}: {fragment}"), err
    assert _tree(tmp_path) == before and scene_file.read_text() == XYZ_WATER


def test_molden_replaces_an_existing_file_with_force_only(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene_file = tmp_path / "h2o.toml"
    scene_file.write_text(WATER)
    target = tmp_path / "h2o.molden"
    code, out, _ = run_cli(capsys, "modes", str(scene_file), "--molden", str(target))
    assert code == 0 and target.read_text().startswith("[Molden Format]")
    target.write_text("mine")
    code, _, err = run_cli(capsys, "modes", str(scene_file), "--molden", str(target))
    assert code == 1 and "exists; --force replaces it" in err and target.read_text() == "mine"
    code, _, _ = run_cli(capsys, "modes", str(scene_file), "--molden", str(target), "--force")
    assert code == 0 and target.read_text().startswith("[Molden Format]")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h2o.molden", "h2o.toml"]


def test_molden_refuses_the_real_dev_null_without_touching_it(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    # the refusal comes from lstat alone: /dev/null is never opened, renamed over or removed
    scene_file = tmp_path / "h2o.toml"
    scene_file.write_text(WATER)
    before = os.lstat("/dev/null")
    code, _, err = run_cli(capsys, "modes", str(scene_file), "--molden", "/dev/null", "--force")
    after = os.lstat("/dev/null")
    assert code == 1 and "--molden /dev/null: is a device" in err
    assert (before.st_ino, before.st_mode, before.st_rdev) == (after.st_ino, after.st_mode, after.st_rdev)


def test_sweep_out_that_is_a_file_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: "[Errno 17] File exists"
    out = tmp_path / "file"
    out.write_text("x")
    code, _, err = run_cli(capsys, "sweep", str(ROOT / "chains" / "mass-defect.toml"), "--vary",
                           "system.defect_mass=0.2:0.8:2", "--out", str(out), "-q")
    assert code == 1 and err.strip() == f"vibra sweep: --out {out}: is a regular file; expected a folder (created " \
                                        "when missing)"
    assert out.read_text() == "x"


def test_sweep_chart_path_that_is_a_folder_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: the CSV and JSON were written, the PNG not, and the error named the temporary file
    out = tmp_path / "out"
    (out / "mass-defect_sweep.png").mkdir(parents=True)
    code, _, err = run_cli(capsys, "sweep", str(ROOT / "chains" / "mass-defect.toml"), "--vary",
                           "system.defect_mass=0.2:0.8:2", "--out", str(out), "-q")
    assert code == 1 and err.count("\n") == 1 and "~tmp~" not in err
    assert f"--out {out / 'mass-defect_sweep.png'}: is a folder" in err
    assert sorted(p.name for p in out.iterdir()) == ["mass-defect_sweep.png"]


def test_sweep_outputs_never_replace_the_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a scene named like the sweep's own output, in the output folder
    scene_file = tmp_path / "c_sweep.json"
    scene_file.write_text('kind = "chain"\nname = "c"\n[system]\nbuilder = "linear_chain"\nn = 4\n')
    text = scene_file.read_text()
    code, _, err = run_cli(capsys, "sweep", str(scene_file), "--vary", "system.n=3:4:2", "--out", str(tmp_path), "-q")
    assert code == 1 and "is an input of this run" in err and scene_file.read_text() == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c_sweep.json"]


def test_a_billion_point_sweep_is_refused_with_the_count_and_an_estimate(tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: MemoryError building 10^9 points; the refusal needs one point built and costed by its size
    # (issue 44: an estimate from sizes, not a timed solve), not the grid in memory
    code, _, err = run_cli(capsys, "sweep", str(ROOT / "chains" / "mass-defect.toml"), "--vary",
                           "system.defect_mass=0.2:0.8:1000000000", "--out", str(tmp_path / "o"), "-q")
    assert code == 1 and err.count("\n") == 1, err
    assert "1,000,000,000 points is more than max_points=100,000 (--max-points); one point is estimated at ~" in err
    assert "from its size (" in err and "dofs, " in err
    assert "so the sweep would take about" in err and not (tmp_path / "o").exists()


def test_max_points_bounds_and_raises_the_limit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["sweep", str(ROOT / "chains" / "mass-defect.toml"), "--vary", "system.defect_mass=0.2:0.8:3",
            "--out", str(tmp_path), "-q"]
    code, _, err = run_cli(capsys, *args, "--max-points", "2")
    assert code == 1 and "3 points is more than max_points=2" in err and list(tmp_path.iterdir()) == []
    code, out, _ = run_cli(capsys, *args, "--max-points", "3")
    assert code == 0 and "3 points" in out
    with pytest.raises(SystemExit) as stop:
        cli.main([*args, "--max-points", "0"])
    assert stop.value.code == 2 and "--max-points must be >= 1" in capsys.readouterr().err


def test_help_says_what_each_writer_may_replace(capsys: pytest.CaptureFixture[str]) -> None:
    for command, fragment in (("modes", "--force"), ("sweep", "rewrites <scene>_sweep.csv"),
                              ("report", "each run rewrites its own files")):
        with pytest.raises(SystemExit):
            cli.main([command, "--help"])
        assert fragment in " ".join(capsys.readouterr().out.split())


# ---------------------------------------------------------------------- issue 34: inputs that are whole
def _network(tmp_path: Path, pdb_text: str) -> Path:
    scene_file = tmp_path / "ubiquitin.toml"
    scene_file.write_text((ROOT / "networks" / "ubiquitin" / "ubiquitin-anm.toml").read_text())
    (tmp_path / "1ubi.pdb").write_text(pdb_text)
    return scene_file


@pytest.mark.parametrize("fraction", [1 / 3, 2 / 3])
def test_a_network_scene_with_a_cut_pdb_is_refused_at_its_key(fraction: float, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: cut at two thirds, exit 0 with 47 of 76 atoms; at one third, an n_modes error with no hint
    text = (ROOT / "networks" / "ubiquitin" / "1ubi.pdb").read_text()
    atoms = [i for i, line in enumerate(text.splitlines(keepends=True)) if line.startswith("ATOM")]
    lines = text.splitlines(keepends=True)
    index = atoms[int(fraction * len(atoms))]
    scene_file = _network(tmp_path, "".join(lines[:index]) + lines[index][:33])
    for command in ("validate", "modes"):
        code, out, err = run_cli(capsys, command, str(scene_file))
        text_out = one_line_failure(out) if command == "validate" else err.strip()
        assert code == 1 and f"system.pdb: {tmp_path / '1ubi.pdb'}: line {index + 1}: the last ATOM record stops " \
                              "at column 33" in text_out, out + err


def test_a_network_scene_with_a_pdb_cut_between_lines_warns_in_one_line(tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    text = (ROOT / "networks" / "ubiquitin" / "1ubi.pdb").read_text()
    lines = text.splitlines(keepends=True)
    atoms = [i for i, line in enumerate(lines) if line.startswith("ATOM")]
    scene_file = _network(tmp_path, "".join(lines[:atoms[-200]]))
    code, out, err = run_cli(capsys, "validate", str(scene_file))
    warning = [line for line in err.splitlines() if "warning" in line]
    assert len(warning) == 1 and warning[0].startswith("vibra validate: warning: ") and "Traceback" not in err
    assert f"line {atoms[-200]}: the file ends without an END record" in warning[0]


#: (case, .xyz text, fragment): issue 34's "atom count line against the atoms read", and the NaN
#: coordinate once reported at name_or_atoms.positions[1,0] rather than the scene's key.
XYZ_CASES = [
    ("count-above-atoms", "4\nwater\n" + WATER_XYZ.split("\n", 2)[2], "line 5: the file ends after 3 atom lines, "
     "but line 1 announces 4; the file looks truncated"),
    ("count-below-atoms", "2\nwater\n" + WATER_XYZ.split("\n", 2)[2], "line 5: more lines follow the 2 atoms"),
    ("cut-mid-line", WATER_XYZ[:-12], "line 5: is 'H 0.0 -0'; an atom line reads 'symbol x y z'"),
    ("nan-coordinate", WATER_XYZ.replace("0.763 -0.477", "nan -0.477"), "line 4: coordinate y of atom 1 is 'nan'"),
    ("word-count", "three\nwater\n" + WATER_XYZ.split("\n", 2)[2], "line 1: is 'three'; an XYZ file starts with its "
     "number of atoms"),
    ("second-frame", WATER_XYZ + WATER_XYZ, "line 6: more lines follow the 3 atoms"),
    ("empty", "", "line 1: is ''"),
]


@pytest.mark.parametrize("case, xyz, fragment", XYZ_CASES, ids=[case[0] for case in XYZ_CASES])
def test_a_molecule_xyz_is_checked_whole_at_system_xyz(case: str, xyz: str, fragment: str, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    scene_file = tmp_path / "water.toml"
    scene_file.write_text(XYZ_WATER)
    (tmp_path / "water.xyz").write_text(xyz)
    code, out, err = run_cli(capsys, "validate", str(scene_file))
    assert code == 1 and f"system.xyz: 'water.xyz': {fragment}" in one_line_failure(out), out + err


def test_a_whole_xyz_with_trailing_blank_lines_is_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene_file = tmp_path / "water.toml"
    scene_file.write_text(XYZ_WATER)
    (tmp_path / "water.xyz").write_text(WATER_XYZ + "\n\n")
    code, out, _ = run_cli(capsys, "validate", str(scene_file))
    assert code == 0 and out.startswith("ok")


# ---------------------------------------------------------------------- issue 34: honest sizes
@pytest.mark.parametrize("scene_file, dofs", [
    ("networks/ubiquitin/ubiquitin-anm.toml", 3 * 71),  # C-alpha atoms of residues 1-71 of 1UBI, 3 coordinates each
    ("chains/long-chain.toml", 1_000_000),
    ("chains/double-pendulum.toml", 2),
], ids=["network", "long-chain", "generalized"])
def test_validate_prints_size_and_cost_of_every_accepted_scene(scene_file: str, dofs: int,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: a 129,000-atom network was accepted by validate without a size figure
    code, out, _ = run_cli(capsys, "validate", str(ROOT / scene_file))
    line = out.splitlines()[0]
    assert code == 0 and line.startswith("ok   ") and f": {dofs} dofs; modes: " in line
    assert "path" in line and "estimated ~" in line and line.rstrip()[-1] == "B"  # time and memory, in bytes


# ---------------------------------------------------------------------- issue 34: messages at the scene's key
def test_coincident_positions_are_refused_at_system_positions(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: duplicate positions in a springs scene were reported at system.springs
    path = tmp_path / "dup.toml"
    path.write_text(SPRINGS + "positions = [0.0, 0.0, 1.0]\nmasses = 1.0\nsprings = [[0, 1], [1, 2]]\n"
                    "stiffness = 1.0\n")
    code, out, _ = run_cli(capsys, "validate", str(path))
    assert code == 1 and f"{path}: system.positions: springs[0] joins sites 0 and 1 at the same position" in \
        one_line_failure(out)


def test_builder_arguments_map_to_scene_keys_by_construction() -> None:
    # the mapping reads the error's argument, never its text: the molecule's atoms come from system.xyz
    # (or system.name), a network's positions from system.pdb
    import dataclasses

    from vibra._core.validate import ArgumentError, finite
    from vibra.pipeline.plan.build import scene_key
    from vibra.pipeline.scene import Scene

    with pytest.raises(ArgumentError) as caught:
        finite(np.array([[0.0, np.nan]]), "name_or_atoms.positions")
    assert caught.value.argument == "name_or_atoms"
    molecule = Scene.from_dict({"kind": "molecule", "units": "ASE", "system": {"builder": "molecule", "name": "CH4"}},
                               source="m.toml")
    assert scene_key(molecule, "name_or_atoms") == "system.name"
    from_file = dataclasses.replace(molecule.system, parameters={**molecule.system.parameters, "name": None,
                                                                 "xyz": "a.xyz"})
    assert scene_key(dataclasses.replace(molecule, system=from_file), "name_or_atoms") == "system.xyz"
    chain_scene = Scene.from_dict({"kind": "chain", "system": {"builder": "linear_chain", "n": 3}}, source="c.toml")
    assert scene_key(chain_scene, "mass") == "system.mass" and scene_key(chain_scene, "units") == "system"


def test_report_never_writes_its_index_over_a_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a scene file named like report's own index, in the output folder: refused before any work
    scene_file = tmp_path / "index.html"
    scene_file.write_text(CHAIN)
    before = _tree(tmp_path)
    code, _, err = run_cli(capsys, "report", str(scene_file), "--out", str(tmp_path), "--quiet")
    assert code == 1 and err.count("\n") == 1 and "is an input of this run" in err
    assert _tree(tmp_path) == before and scene_file.read_text() == CHAIN


def test_sigterm_removes_the_work_folders_at_once(tmp_path: Path) -> None:
    # issue 34: after a kill, .work/<pid> waited for the next run; SIGTERM (what `kill PID` sends) now
    # cleans as Ctrl-C does: finished images complete, no work folder, exit 128 + 15
    scenes = write_scenes(tmp_path / "scenes", 6)
    out = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "vibra", "report", *map(str, scenes), "--out", str(out),
                                "--quiet", "--jobs", "1", "--force"], cwd=ROOT, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(out.glob("*.png")) and process.poll() is None:
        time.sleep(0.02)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=120)
    if process.returncode == 0:
        pytest.skip("the report finished before the signal arrived")
    assert process.returncode == 128 + signal.SIGTERM, err
    assert "vibra: terminated (SIGTERM)" in err and "Traceback" not in err
    assert not (out / ".work").exists()
    for png in out.glob("*.png"):
        complete_png(png)
    assert [p.name for p in out.iterdir() if "~tmp~" in p.name] == []


def test_a_signal_handler_is_given_back_after_main(capsys: pytest.CaptureFixture[str]) -> None:
    before = signal.getsignal(signal.SIGTERM)
    run_cli(capsys, "validate", str(ROOT / "chains" / "monatomic-free.toml"))
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_long_sweep_says_its_size_and_time_first_even_quiet(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    # issue 34: 100,000 points ran ~12 minutes silently under -q; the threshold is lowered here to keep it short
    monkeypatch.setattr(cli, "ANNOUNCE_POINTS", 2)
    code, _, err = run_cli(capsys, "sweep", str(ROOT / "chains" / "mass-defect.toml"), "--vary",
                           "system.defect_mass=0.2:0.8:3", "--out", str(tmp_path), "-q")
    assert code == 0 and err.count("\n") == 1 and err.startswith("vibra sweep: 3 points; one point is estimated at ~")
    assert "in one process" in err
    monkeypatch.setattr(cli, "ANNOUNCE_POINTS", 3)
    code, _, err = run_cli(capsys, "sweep", str(ROOT / "chains" / "mass-defect.toml"), "--vary",
                           "system.defect_mass=0.2:0.8:3", "--out", str(tmp_path / "again"), "-q")
    assert code == 0 and err == ""


# ---------------------------------------------------------------------- issue 34: whole phonopy files
@pytest.fixture(scope="module")
def phonopy_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The text of phonopy's files for a small silicon model (structure yaml, FORCE_CONSTANTS,
    a displacement yaml and its FORCE_SETS with forces -Phi u)."""
    from vibra import crystals

    folder = tmp_path_factory.mktemp("phonopy-files")
    write_force_sets(crystals.diamond(5.43, 28.09, 10.0, units="ASE"), folder)
    return {name: (folder / name).read_text() for name in ("structure.yaml", "FORCE_CONSTANTS", "FORCE_SETS",
                                                           "phonopy_disp.yaml")}


def _phonopy_scene(folder: Path, files: dict[str, str], extra_key: str, extra_file: str) -> Path:
    yaml_name = "structure.yaml" if extra_key == "force_constants_file" else "phonopy_disp.yaml"
    for name, text in files.items():
        (folder / name).write_text(text)
    scene_file = folder / "si.toml"
    scene_file.write_text(f'kind = "crystal"\nunits = "ASE"\n\n[system]\nbuilder = "phonopy"\nfile = "{yaml_name}"\n'
                          f'{extra_key} = "{extra_file}"\n\n[compute]\nnpoints = 40\nmesh = [4, 4, 4]\n\n'
                          '[draw]\nthermal = true\n')
    return scene_file


def _half(text: str, at_line: bool) -> str:
    n = len(text) // 2
    return text[:text.rfind("\n", 0, n) + 1] if at_line else text[:n]


#: (case, the file cut, whether at a line end, the key and the fragment of the refusal)
PHONOPY_CUTS = [
    ("yaml-mid-line", "structure.yaml", False, "system.file", "'structure.yaml': line "),
    ("force-constants-mid-line", "FORCE_CONSTANTS", False, "system.force_constants_file", "'FORCE_CONSTANTS': line "),
    ("force-constants-at-a-line", "FORCE_CONSTANTS", True, "system.force_constants_file",
     "announces 16 x 16 blocks; the file looks cut"),
    ("force-sets-at-a-line", "FORCE_SETS", True, "system.force_sets_file",
     "the file ends within displacement 1 of 1 (line 2 announces them; "),
    ("disp-yaml-at-a-line", "phonopy_disp.yaml", True, "system.file", "'phonopy_disp.yaml': line "),
]


@pytest.mark.parametrize("case, name, at_line, key, fragment", PHONOPY_CUTS, ids=[c[0] for c in PHONOPY_CUTS])
def test_a_crystal_scene_with_a_cut_phonopy_file_is_refused_at_its_key(
        case: str, name: str, at_line: bool, key: str, fragment: str, phonopy_files: dict[str, str], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    extra_key, extra = (("force_sets_file", "FORCE_SETS") if name in ("FORCE_SETS", "phonopy_disp.yaml")
                        else ("force_constants_file", "FORCE_CONSTANTS"))
    scene_file = _phonopy_scene(tmp_path, {**phonopy_files, name: _half(phonopy_files[name], at_line)}, extra_key, extra)
    code, out, err = run_cli(capsys, "validate", str(scene_file))
    line = one_line_failure(out)
    assert code == 1 and f"{scene_file}: {key}: " in line and fragment in line, out + err
    assert "the file looks cut" in line
    out_dir = tmp_path / "out"
    code, out, err = run_cli(capsys, "report", str(scene_file), "--out", str(out_dir), "-q")
    assert code != 0 and "Traceback" not in out + err and f"{key}: " in out + err
    assert not list(out_dir.glob("*.png"))


def test_a_crystal_scene_reads_its_phonopy_files_whole(phonopy_files: dict[str, str], tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    for extra_key, extra in (("force_constants_file", "FORCE_CONSTANTS"), ("force_sets_file", "FORCE_SETS")):
        folder = tmp_path / extra
        folder.mkdir()
        code, out, err = run_cli(capsys, "validate", str(_phonopy_scene(folder, phonopy_files, extra_key, extra)))
        assert code == 0 and out.startswith("ok "), out + err
    folder = tmp_path / "none"
    folder.mkdir()
    scene_file = _phonopy_scene(folder, phonopy_files, "force_sets_file", "FORCE_SETS")
    scene_file.write_text(scene_file.read_text().replace('force_sets_file = "FORCE_SETS"\n', ""))
    code, out, err = run_cli(capsys, "validate", str(scene_file))  # FORCE_SETS beside it, but not named: not read
    assert code == 1 and "system.file: 'phonopy_disp.yaml' holds no force constants and no forces; name its " \
                         "FORCE_CONSTANTS file (system.force_constants_file)" in one_line_failure(out)


# ---------------------------------------------------------------------- issue 34: what a SIGKILL leaves
def _dead_pid() -> int:
    """The pid of a process that has exited (and been reaped): what a SIGKILLed writer leaves behind."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


@pytest.mark.parametrize("command", ["sweep", "modes --molden"])
def test_a_killed_writers_temporary_files_go_with_the_next_write(command: str, tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    # issue 34: what a kill left waited for the next `vibra report` into that folder; now any
    # command that writes the same file removes it, and a live writer's stays
    dead, live = _dead_pid(), os.getpid()
    out = tmp_path / "out"
    (out / ".vibra").mkdir(parents=True)  # the killed writer had claimed the folder (vibra._core.filesystem.claim_out_folder)
    if command == "sweep":
        name = "mass-defect_sweep.csv"
        args = ["sweep", str(ROOT / "chains" / "mass-defect.toml"), "--vary", "system.defect_mass=0.2:0.8:2",
                "--out", str(out), "-q"]
    else:
        name = "h2o.molden"
        scene_file = tmp_path / "h2o.toml"
        scene_file.write_text(WATER)
        args = ["modes", str(scene_file), "--molden", str(out / name)]
    stale = out / f".{name}.{dead}~tmp~k1ll3d.tmp"
    stale.write_text("half a file")
    running = out / f".{name}.{live}~tmp~w0rk1n.tmp"
    running.write_text("being written")
    other = out / f".{name}.x.{dead}~tmp~0th3r.tmp"  # another file's temporary (name 'NAME.x'): not this write's
    other.write_text("not ours to judge here")
    code, _, err = run_cli(capsys, *args)
    assert code == 0, err
    assert not stale.exists() and running.exists() and other.exists()
    assert (out / name).stat().st_size > 0


def test_a_killed_reports_work_folder_goes_with_the_next_report(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    # what a SIGKILL leaves in a report folder: .work/<pid>/ and temporary files of that pid; the
    # next report into the folder removes them (a live pid's stay: test_a_live_process_keeps_its_work_folder)
    scene_file = write_scenes(tmp_path / "scenes", 1)[0]
    out = tmp_path / "out"
    dead = _dead_pid()
    (out / ".work" / str(dead) / "c0" / "out").mkdir(parents=True)
    (out / ".vibra").mkdir()  # the killed run had claimed the folder (vibra._core.filesystem.claim_out_folder)
    (out / ".work" / str(dead) / "c0" / "out" / "c0_spectrum.png").write_bytes(b"\x89PNG half")
    stale = out / f".summary.json.{dead}~tmp~abcd1234.tmp"
    stale.write_text("{")
    code, _, err = run_cli(capsys, "report", str(scene_file), "--out", str(out), "-q")
    assert code == 0, err
    assert not (out / ".work").exists() and not stale.exists()
    complete_png(out / "c0_spectrum.png")


@pytest.mark.parametrize("limit", [1000, 20_000])
def test_deep_nesting_refused_alike_whatever_the_recursion_limit(limit: int, tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """A file nested 2,000 deep is refused with the same line whether or not the TOML parser would
    recurse that deep (other libraries in a process raise the interpreter's limit: in the whole
    suite this case once reached the parsed-depth check instead, with another message)."""
    path = tmp_path / "scene.toml"
    path.write_text("a = " + "[" * 2000 + "]" * 2000 + "\n", encoding="utf-8")
    before = sys.getrecursionlimit()
    sys.setrecursionlimit(limit)
    try:
        code, out, _ = run_cli(capsys, "validate", str(path))
    finally:
        sys.setrecursionlimit(before)
    assert code == 1
    assert one_line_failure(out) == f"FAIL {path}: lists or tables nested too deeply to parse; a scene nests at most 8 levels"
