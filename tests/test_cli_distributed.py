"""The command line on Dask: ``vibra sweep`` and ``vibra report --scheduler``.

Truth: the Montroll-Potts closed form (vibra.chains.montroll_potts_frequency) for the mass
defect's localised mode; numpy's geomspace for log spacing; the default (local processes)
report for ``--scheduler local``; the csv and json modules for the written tables.
"""

from __future__ import annotations

import csv
import re
import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from vibra.chains import montroll_potts_frequency
from vibra.cli import main

ROOT = Path(__file__).resolve().parent.parent
DEFECT = ROOT / "chains" / "mass-defect.toml"


def test_sweep_writes_table_and_chart_each_row_against_montroll_potts(tmp_path, capsys) -> None:
    code = main(["sweep", str(DEFECT), "--vary", "system.defect_mass=0.2:0.7:6", "--out", str(tmp_path)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == [  # and .vibra/, the mark of vibra's own folder
        ".vibra", "mass-defect_sweep.csv", "mass-defect_sweep.json", "mass-defect_sweep.png"]
    rows = list(csv.DictReader((tmp_path / "mass-defect_sweep.csv").open()))
    assert len(rows) == 6
    for row in rows:
        top = float(row[f"omega_{int(row['n_modes']) - 1}"])
        assert top == pytest.approx(montroll_potts_frequency(20.0, 1.0, float(row["system.defect_mass"])), rel=1e-10)
    progress = [line for line in captured.err.splitlines() if line.startswith("[")]
    assert len(progress) == 6 and progress[-1].startswith("[6/6] point 5: system.defect_mass=0.7")
    image = imread(tmp_path / "mass-defect_sweep.png")
    assert image[..., :3].std() > 0.05


def test_sweep_grid_with_log_spacing_on_a_local_cluster(tmp_path) -> None:
    code = main(["sweep", str(DEFECT), "--vary", "system.defect_mass=0.3:0.5:2", "--vary",
                 "system.stiffness=log:25:400:3", "--scheduler", "local", "--jobs", "2", "--out", str(tmp_path), "-q"])
    assert code == 0
    data = json.loads((tmp_path / "mass-defect_sweep.json").read_text())
    assert data["keys"] == ["system.defect_mass", "system.stiffness"]
    stiffness = [row["parameters"]["system.stiffness"] for row in data["rows"]]
    np.testing.assert_allclose(stiffness[:3], np.geomspace(25.0, 400.0, 3), rtol=1e-15)
    assert len(data["rows"]) == 6


@pytest.mark.parametrize("arguments, code, match", [
    (["--vary", "system.defect_mas=0.2:0.7:3"], 1, r"system\.defect_mas: unknown key; did you mean 'defect_mass'\?"),
    (["--vary", "system.defect_mass=0.2:0.7:0"], 2, r"n is 0; an empty range has nothing to sweep"),
    (["--vary", "system.defect_mass=0.2:0.7"], 2, r"expected KEY=START:STOP:N"),
    (["--vary", "system.defect_mass=0.2:0.7:3", "--scheduler", "nowhere"], 2,
     r"--scheduler is 'nowhere'; expected 'local' or a scheduler address"),
    (["--vary", "system.defect_mass=0.2:0.7:3", "--scheduler", "tcp://127.0.0.1:9", "--timeout", "1"], 1,
     r"no Dask scheduler answered at 'tcp://127\.0\.0\.1:9' within 1 s"),
])
def test_sweep_bad_input_is_one_line_and_writes_nothing(arguments, code, match, tmp_path, capsys,
                                                        client_timeouts) -> None:
    out = tmp_path / "out"
    assert main(["sweep", str(DEFECT), *arguments, "--out", str(out), "-q"]) == code
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and re.search(match, err), err
    assert not out.exists()
    assert client_timeouts in ([], [1.0])  # a scheduler tried is given the --timeout (no clock)


def _frequencies(out: Path) -> dict[str, object]:
    summary = json.loads((out / "summary.json").read_text())
    return {scene["name"]: scene["frequencies"] for scene in summary["scenes"]}


def _small_scenes(folder: Path) -> list[str]:
    """The bundled mass-defect and axial CO2 scenes, drawing a spectrum only (no 3-D renders)."""
    folder.mkdir()
    paths = []
    for source in (ROOT / "chains" / "mass-defect.toml", ROOT / "molecules" / "co2-axial.toml"):
        text = source.read_text().split("[draw]")[0] + "[draw]\nspectrum = true\n"
        (folder / source.name).write_text(text)
        paths.append(str(folder / source.name))
    return paths


def test_report_on_a_local_scheduler_gives_the_default_frequencies(tmp_path) -> None:
    scenes = _small_scenes(tmp_path / "scenes")
    assert main(["report", *scenes, "--out", str(tmp_path / "default"), "-q"]) == 0
    assert main(["report", *scenes, "--scheduler", "local", "--jobs", "2", "--out", str(tmp_path / "dask"), "-q"]) == 0
    default, dask = _frequencies(tmp_path / "default"), _frequencies(tmp_path / "dask")
    assert set(default) == {"mass-defect", "co2-axial"} and default == dask
    assert all(len(frequencies["omega"]) >= 3 for frequencies in default.values())  # type: ignore[index]
    assert sorted(p.name for p in (tmp_path / "default").glob("*.png")) == sorted(
        p.name for p in (tmp_path / "dask").glob("*.png"))


def test_report_unreachable_scheduler_writes_nothing(tmp_path, capsys) -> None:
    out = tmp_path / "out"
    code = main(["report", str(DEFECT), "--scheduler", "tcp://127.0.0.1:9", "--timeout", "1", "--out", str(out), "-q"])
    assert code == 1
    assert "no Dask scheduler answered" in capsys.readouterr().err
    assert not out.exists() or not any(out.iterdir())


def test_bad_timeout_is_a_usage_error(capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["sweep", str(DEFECT), "--vary", "system.defect_mass=0.2:0.7:3", "--timeout", "soon"])
    assert exit_info.value.code == 2
    assert "--timeout must be a number of seconds, got 'soon'" in capsys.readouterr().err
