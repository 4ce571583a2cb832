"""Tests of the package layout (issues 29 and 43): one name per module, every listed submodule
imports, no module over 600 lines, the module map names every module."""

from __future__ import annotations

import ast
import hashlib
import importlib
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

import vibra
from vibra import solvers

ROOT = Path(__file__).resolve().parents[2]


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


# ------------------------------------------------- folders (issue 43 item 5)
def _runtime_imports() -> list[tuple[str, str, str, str]]:
    """(importing module, its file, imported module, imported name or "") for every import of vibra
    inside vibra, function bodies included; an ``if TYPE_CHECKING:`` block is no import at run time."""
    modules = {}
    for path in (ROOT / "vibra").rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    found = []
    for name, path in sorted(modules.items()):
        stack: list[ast.AST] = [ast.parse(path.read_text(encoding="utf-8"))]
        while stack:
            node = stack.pop()
            if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
                stack.extend(node.orelse)
                continue
            stack.extend(ast.iter_child_nodes(node))
            if isinstance(node, ast.Import):
                pairs = [(alias.name, "") for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                pairs = [(f"{node.module}.{a.name}", "") if f"{node.module}.{a.name}" in modules
                         else (node.module, a.name) for a in node.names]
            else:
                continue
            for target, imported in pairs:
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target.startswith("vibra") and target != name:
                    found.append((name, f"{path.relative_to(ROOT)}:{node.lineno}", target, imported))
    return found


def _folder(module: str) -> str:
    """The package (folder) a module's file lies in: a package's own __init__ lies in that package."""
    path = ROOT.joinpath(*module.split("."))
    return module if (path / "__init__.py").exists() else module.rpartition(".")[0]


def test_no_import_loop_between_sibling_folders() -> None:
    """Folder-level import graph: an import from a module under folder A into one under folder B,
    where A and B are different folders of the same parent (e.g. `solvers/accurate/chain/` and
    `solvers/accurate/ring/`), is an edge A -> B; those edges form no loop. A folder importing from
    the folders above it, or a parent's modules importing its subfolders, is no sibling edge."""
    edges: dict[str, dict[str, str]] = {}
    for name, where, target, _ in _runtime_imports():
        source, goal = _folder(name).split("."), _folder(target).split(".")
        common = 0
        while common < min(len(source), len(goal)) and source[common] == goal[common]:
            common += 1
        if common < len(source) and common < len(goal):
            a, b = ".".join(source[:common + 1]), ".".join(goal[:common + 1])
            edges.setdefault(a, {}).setdefault(b, f"{where} imports {target}")

    def path_back(start: str) -> list[str] | None:
        paths, seen = [[start]], {start}
        while paths:
            path = paths.pop(0)
            for goal in sorted(edges.get(path[-1], {})):
                if goal == start:
                    return path + [start]
                if goal not in seen:
                    seen.add(goal)
                    paths.append(path + [goal])
        return None

    loops = []
    for folder in sorted(edges):
        if (loop := path_back(folder)) and folder == min(loop):  # each loop once
            loops.append(" -> ".join(loop) + "  (" + "; ".join(edges[a][b] for a, b in zip(loop, loop[1:])) + ")")
    assert loops == [], "move what both folders use up into their parent:\n" + "\n".join(loops)


def test_no_private_name_is_imported_from_another_folder() -> None:
    """`from vibra.x.y import _z` only from a module of the same folder: what modules of two folders
    share is public (issue 43 item 5; STYLE.md: private names stay in their module's folder)."""
    offenders = [f"{where} imports {imported} from {target}" for name, where, target, imported in _runtime_imports()
                 if imported.startswith("_") and not imported.startswith("__") and _folder(name) != _folder(target)]
    assert offenders == [], "\n".join(offenders)
