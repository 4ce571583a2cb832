"""Tests of the package layout (issues 29 and 43): one name per module, every listed submodule
imports, no module over 600 lines, the module map names every module."""

from __future__ import annotations

import hashlib
import importlib
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

import vibra
from vibra import solvers

ROOT = Path(__file__).resolve().parents[1]


def _vibra_modules_by_file() -> dict[str, list[ModuleType]]:
    """Source file -> the distinct module objects in sys.modules loaded from it (vibra only)."""
    by_file: dict[str, list[ModuleType]] = {}
    for name, module in list(sys.modules.items()):
        file = getattr(module, "__file__", None)
        if name.startswith("vibra") and file and not any(module is m for m in by_file.get(file, [])):
            by_file.setdefault(file, []).append(module)
    return by_file


def test_an_unknown_name_is_not_found() -> None:
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("vibra.no_such_module")


@pytest.mark.parametrize("old", ["vibra.pencil", "vibra.scene", "vibra.scene.schema", "vibra.lagrangian",
                                 "vibra.structures", "vibra.report"])
def test_no_second_name_for_a_module(old: str) -> None:
    """The names modules had before the layout of issue 29 are gone (issue 43: no shim for a version
    never released): one name per module."""
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(old)
    assert not hasattr(vibra, old.split(".")[1])
    assert not any(type(finder).__name__ == "MovedFinder" for finder in sys.meta_path)


@pytest.mark.parametrize("name", vibra.SUBMODULES)
def test_every_listed_submodule_imports(name: str) -> None:
    module = importlib.import_module(f"vibra.{name}")
    assert module.__name__ == f"vibra.{name}"


@pytest.mark.parametrize("name", solvers.__all__)
def test_every_name_in_solvers_all_resolves(name: str) -> None:
    value = getattr(solvers, name)
    assert not isinstance(value, ModuleType), name


def test_the_former_solver_names_stay_importable() -> None:
    from vibra.solvers import (
        BAND_LIMIT, BDSQR_LIMIT, DENSE_ALL_LIMIT, DENSE_LIMIT, EPS, FACTOR_RTOL, SAMPLE, SOLVER_PATHS, Plan,
        Segment, available_memory, budget, check_factor_matches, check_plan, check_spring_factor, largest_entry,
    )

    assert Plan is solvers.SolvePlan and check_plan is solvers.check_solve_plan
    assert "Plan" not in solvers.__all__ and "check_plan" not in solvers.__all__
    assert all(value is not None for value in (BAND_LIMIT, BDSQR_LIMIT, DENSE_ALL_LIMIT, DENSE_LIMIT, EPS,
                                               FACTOR_RTOL, SAMPLE, SOLVER_PATHS, Segment, available_memory,
                                               budget, check_factor_matches, check_spring_factor, largest_entry))


def test_networks_keeps_its_names() -> None:
    from vibra import networks
    from vibra.networks import models, pdb

    assert networks.from_pdb is pdb.from_pdb and networks.anm is models.anm
    assert all(hasattr(networks, name) for name in networks.__all__)


def test_the_report_code_hash_covers_the_whole_package() -> None:
    """The report's skip key hashes every .py file of vibra (not only the pipeline's)."""
    from vibra.pipeline.report.folder import code_hash

    package = ROOT / "vibra"
    digest = hashlib.sha256()
    for file in sorted(package.rglob("*.py")):
        digest.update(file.relative_to(package).as_posix().encode() + b"\0" + file.read_bytes() + b"\0")
    assert code_hash() == digest.hexdigest()


def test_no_module_passes_600_lines() -> None:
    long = {str(path.relative_to(ROOT)): n for path in (ROOT / "vibra").rglob("*.py")
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > 600}
    assert long == {}


def test_the_module_map_names_every_module() -> None:
    """docs/architecture.md's module map (moved there from the README) names every top-level module
    and subpackage of vibra, and names none that does not exist."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    table = text[text.index("| module | stage |"):]
    table = table[:table.index("\n\n")]
    named = set(re.findall(r"`vibra\.([a-z_]+)", table))
    present = {path.stem for path in (ROOT / "vibra").iterdir()
               if (path.suffix == ".py" or (path / "__init__.py").exists()) and not path.name.startswith("__")}
    assert present - named == set(), "missing from the module map"
    assert named - present == set(), "in the module map, not in vibra/"


def test_sources_are_cited_by_name() -> None:
    """The course notes are cited by author and title (`vibra.sources`), never as "seed 00N",
    and nothing points to a DESIGN.md that is not in the repository."""
    texts = [*(ROOT / "vibra").rglob("*.py"), *(ROOT / "docs").glob("*.md"), ROOT / "README.md",
             *(ROOT / "chains").glob("*.toml"), *(ROOT / "molecules").glob("*.toml")]
    offenders = [f"{path.relative_to(ROOT)}: {word}" for path in texts for word in ("seed 00", "DESIGN.md")
                 if word in path.read_text(encoding="utf-8")]
    assert offenders == []
