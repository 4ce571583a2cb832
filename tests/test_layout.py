"""Tests of the package layout (issue 29, item 6): `vibra._moved` and the names it keeps working.

A module that moved (`vibra._moved.MOVED`) is reached by its old name as the very module object
of its new name, never a second copy: ``import vibra.pencil``, ``vibra.scene.schema``,
``from vibra.lagrangian import ...`` and a monkeypatch through an old name all act on the one
module. Truth: `sys.modules`, object identity and a fresh interpreter.
"""

from __future__ import annotations

import hashlib
import importlib
import pickle
import re
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

import vibra
from vibra import solvers
from vibra._moved import MOVED, new_name

ROOT = Path(__file__).resolve().parents[1]


def _vibra_modules_by_file() -> dict[str, list[ModuleType]]:
    """Source file -> the distinct module objects in sys.modules loaded from it (vibra only)."""
    by_file: dict[str, list[ModuleType]] = {}
    for name, module in list(sys.modules.items()):
        file = getattr(module, "__file__", None)
        if name.startswith("vibra") and file and not any(module is m for m in by_file.get(file, [])):
            by_file.setdefault(file, []).append(module)
    return by_file


@pytest.mark.parametrize(("old", "new"), sorted(MOVED.items()))
def test_an_old_name_is_the_moved_module_itself(old: str, new: str) -> None:
    module = importlib.import_module(old)
    assert module is importlib.import_module(new)
    assert sys.modules[old] is sys.modules[new] is module
    assert module.__name__ == new and module.__spec__ is not None and module.__spec__.name == new
    assert getattr(vibra, old.rpartition(".")[2]) is module  # vibra.__getattr__ serves old names too
    twins = _vibra_modules_by_file()[module.__file__]
    assert twins == [module], f"{module.__file__} is loaded as {len(twins)} module objects"


def test_no_vibra_file_is_loaded_twice() -> None:
    for old in MOVED:
        importlib.import_module(old)
    importlib.import_module("vibra.scene.schema")
    importlib.import_module("vibra.report.batch")
    duplicates = {file: len(modules) for file, modules in _vibra_modules_by_file().items() if len(modules) > 1}
    assert duplicates == {}


def test_a_module_below_a_moved_package_is_the_new_one() -> None:
    import vibra.pipeline.scene.schema
    import vibra.scene.schema

    assert vibra.scene.schema is vibra.pipeline.scene.schema
    from vibra.plan.steps import STEPS
    from vibra.pipeline.plan.steps import STEPS as steps

    assert STEPS is steps
    assert new_name("vibra.scene.schema") == "vibra.pipeline.scene.schema"
    assert new_name("vibra.scenery") is None and new_name("vibra.pipeline.scene") is None


def test_from_imports_and_monkeypatches_through_an_old_name_reach_the_one_module(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from vibra.lagrangian import linearize
    from vibra.mechanics.lagrangian import linearize as real

    assert linearize is real
    import vibra.pencil
    import vibra.solvers.structured.pencil as pencil

    monkeypatch.setattr(vibra.pencil, "_layout_probe", 1, raising=False)
    assert pencil._layout_probe == 1  # type: ignore[attr-defined]
    monkeypatch.setattr("vibra.scene.limits.BYTES_PER_DOF", 2)
    from vibra.pipeline.scene import limits

    assert limits.BYTES_PER_DOF == 2


@pytest.mark.parametrize("old", ["vibra.scene.schema", "vibra.report", "vibra.structures", "vibra.pencil"])
def test_an_old_name_imported_first_in_a_fresh_interpreter(old: str) -> None:
    """The old name before the new one (nothing imported yet): still one module."""
    new = new_name(old)
    code = (f"import importlib, sys\n"
            f"a = importlib.import_module({old!r}); b = importlib.import_module({new!r})\n"
            "twins = {id(m) for m in list(sys.modules.values()) if getattr(m, '__file__', None) == a.__file__}\n"
            "print(a is b, a.__name__, a.__spec__.name, len(twins))\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert result.stdout.split() == ["True", new, new, "1"]


def test_a_pickle_naming_an_old_module_loads() -> None:
    """Pickles written before the move name the old modules (protocol 0: the names as text)."""
    from vibra.pipeline.plan import Plan
    from vibra.solvers.structured.quadratic import QuadraticModes

    for cls, old in ((QuadraticModes, b"vibra.quadratic"), (Plan, b"vibra.plan.model")):
        data = pickle.dumps(cls, protocol=0).replace(cls.__module__.encode(), old)
        assert old in data and pickle.loads(data) is cls


def test_an_unknown_name_is_still_not_found() -> None:
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("vibra.no_such_module")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("vibra.scene.no_such_module")


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
