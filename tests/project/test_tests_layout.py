"""The test suite's own layout (issue 43 item 6): helpers shared through `tests/helpers`, never by
one test module importing another (which runs the imported module's tests' set-up twice and hides
what is shared)."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def test_no_test_module_imports_another() -> None:
    offenders = []
    for path in sorted(TESTS.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.relative_to(TESTS)}:{node.lineno} imports {name}"
                          for name in names if any(part.startswith(("test_", "conftest")) for part in name.split("."))]
    assert not offenders, "share it through tests/helpers instead:\n" + "\n".join(offenders)


def test_each_helper_is_defined_once() -> None:
    """No name defined at the top of two helper modules (one place for each helper)."""
    seen: dict[str, str] = {}
    twice = []
    for path in sorted((TESTS / "helpers").glob("*.py")):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                if node.name in seen:
                    twice.append(f"{node.name}: {seen[node.name]} and {path.name}")
                seen[node.name] = path.name
    assert not twice, twice


#: Folders under tests/ that mirror no package folder: shared helpers, data files, the broken scene
#: files, and the tests of the repository around the package (docs, README, notebooks, layout).
NOT_PACKAGES = ("helpers", "data", "broken_scenes", "project")


def test_tests_mirror_the_package() -> None:
    """Tests mirror vibra/ (issue 43, item 6): tests/crystals/test_bands.py tests vibra/crystals/bands.py.

    A test file lies flat in tests/ only when it tests a loose module of vibra/ (tests/test_modes.py,
    tests/test_cli_distributed.py: vibra/modes.py, vibra/cli.py); every folder is a package folder's
    mirror or one of NOT_PACKAGES, and each folder of tests has an __init__.py (one base name may sit
    in two folders) while tests/ has none (pytest keeps tests/ on sys.path: ``import helpers``).
    ``python tools/mirror_tests.py`` moves a new flat file where it belongs."""
    package = TESTS.parent / "vibra"
    loose = {path.stem for path in package.glob("*.py")} - {"__init__", "__main__"}
    flat = [path.name for path in sorted(TESTS.glob("test_*.py"))
            if not any(path.stem[5:] == name or path.stem[5:].startswith(name + "_") for name in loose)]
    assert not flat, f"flat in tests/ (run python tools/mirror_tests.py): {flat}"
    assert not (TESTS / "__init__.py").exists(), "tests/ must stay off the packages: helpers import as `helpers`"
    wrong = []
    for folder in sorted(path for path in TESTS.rglob("*") if path.is_dir()):
        parts = folder.relative_to(TESTS).parts
        if "__pycache__" in parts or parts[0].startswith(".") or parts[0] in NOT_PACKAGES[:3]:
            continue
        name = "/".join(parts)
        if parts[0] not in NOT_PACKAGES and not (package / name / "__init__.py").is_file():
            wrong.append(f"tests/{name}/ mirrors no package folder (no vibra/{name}/)")
        if list(folder.glob("test_*.py")) and not (folder / "__init__.py").is_file():
            wrong.append(f"tests/{name}/ has test files and no __init__.py")
    assert not wrong, "\n".join(wrong)
