"""The README (issue 32, item 5): short, its commands and examples run as written, its links resolve.

Truth: the CO2 closed form (Kneller, Mécanique analytique, eq. 157), the free chain's closed form
omega_k = 2 sqrt(kappa/m) sin(k pi / 2n), `.ci/run` (which must run the README's test command
verbatim), the files on disk, and the ``vibra`` command itself run in a subprocess.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, re.S)


def test_the_readme_is_short() -> None:
    assert len(README.splitlines()) < 150


def test_the_two_quick_start_commands() -> None:
    from helpers.package import BUNDLED_FOLDERS

    report, tests = (block.strip() for block in blocks("bash"))
    assert report == f"pip install -e . && vibra report {' '.join(BUNDLED_FOLDERS)} --out plots"
    assert tests == 'pip install -e ".[test,xtb]" && python -m pytest'
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert tests in ci, ".ci/run must run the README's test command verbatim"


def test_the_library_example_runs_alone_and_says_what_it_computes(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    (block,) = blocks("python")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__main__"}
    exec(compile(block, "README.md python block", "exec"), namespace)
    kappa, m_O, m_C = 1.0, 16.0, 12.0
    exact = [0.0, np.sqrt(kappa / m_O), np.sqrt(kappa * (1 / m_O + 2 / m_C))]  # eq. 157
    np.testing.assert_allclose(namespace["modes"].omega, exact, atol=1e-7)  # type: ignore[attr-defined]
    lowest = namespace["lowest"]
    n = 100_000
    k = np.arange(20)
    np.testing.assert_allclose(lowest.omega, 2 * np.sin(k * np.pi / (2 * n)), rtol=1e-10, atol=1e-13)  # type: ignore[attr-defined]
    assert lowest.solver == "accurate-ritz"  # type: ignore[attr-defined]
    water = namespace["water"]
    assert water.point_group.name == "C2v" and water.species == ("A1", "A1", "B2")  # type: ignore[attr-defined]
    assert "C2v ('A1', 'A1', 'B2') [1595. 3680. 3733.]" in block  # the comment says what it prints


def test_the_scene_example_and_its_commands_run(tmp_path: Path) -> None:
    (scene,) = blocks("toml")
    (tmp_path / "chain.toml").write_text(scene, encoding="utf-8")
    commands = re.findall(r"`vibra ((?:validate|modes|sweep) chain\.toml[^`]*)`", " ".join(README.split()))
    assert [c.split()[0] for c in commands] == ["validate", "modes", "sweep"]
    for command in commands:
        run = subprocess.run([sys.executable, "-m", "vibra", *command.split()], cwd=tmp_path,
                             capture_output=True, text=True)
        assert run.returncode == 0, command + "\n" + run.stdout + run.stderr
    assert (tmp_path / "sweep" / "chain_sweep.csv").is_file()


def test_every_local_link_and_image_exists() -> None:
    targets = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README)
    local = [t for t in targets if not re.match(r"[a-z]+://", t)]
    assert local and [t for t in local if not (ROOT / t).exists()] == []


def test_the_quick_start_out_folder_is_vibra_s_own_in_a_fresh_clone() -> None:
    """`--out plots` writes only into a new, empty or vibra-marked folder (vibra._core.filesystem.claim_out_folder);
    plots/ is committed with the showcase, so its .vibra/ mark is committed too."""
    from vibra._core.filesystem import OWN_MARK, claim_out_folder

    tracked = subprocess.run(["git", "ls-files", "plots"], cwd=ROOT, capture_output=True, text=True).stdout.split()
    if tracked:  # a git checkout: what a fresh clone holds
        assert f"plots/{OWN_MARK}/README" in tracked
    assert (ROOT / "plots" / OWN_MARK).is_dir()
    claim_out_folder(ROOT / "plots", mark=False)  # no refusal: the quick start's report writes there
