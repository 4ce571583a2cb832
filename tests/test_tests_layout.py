"""The test suite's own layout (issue 43 item 6): helpers shared through `tests/helpers`, never by
one test module importing another (which runs the imported module's tests' set-up twice and hides
what is shared)."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def test_no_test_module_imports_another() -> None:
    offenders = []
    for path in sorted(TESTS.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            names = ([alias.name for alias in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{path.relative_to(TESTS)}:{node.lineno} imports {name}"
                          for name in names if name.split(".")[0].startswith(("test_", "conftest"))]
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
