"""Tests of vibra/__init__.py: the API bound on first access, the lazy submodules, dir(), import cost."""

from __future__ import annotations

import importlib
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers.package import HEAVY

import vibra


def _run(code: str) -> str:
    """Run `code` in a fresh interpreter (nothing imported yet) and return its stdout."""
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                            cwd=Path(__file__).resolve().parents[2])
    return result.stdout


def test_submodule_table_lists_every_public_module_on_disk() -> None:
    on_disk = {info.name for info in pkgutil.iter_modules(vibra.__path__)
               if not info.name.startswith("_")}
    assert set(vibra.SUBMODULES) == on_disk


def test_dir_lists_the_api_and_the_submodules_only() -> None:
    names = dir(vibra)
    assert set(names) == {*vibra.__all__, *vibra.SUBMODULES, "SUBMODULES", "__version__"}
    assert "Any" not in names and "importlib" not in names and "annotations" not in names
    assert names == sorted(names)


def test_every_name_in_all_resolves_and_is_no_module() -> None:
    for name in vibra.__all__:
        value = getattr(vibra, name)
        assert not isinstance(value, type(vibra)), name  # submodules are listed in SUBMODULES
    assert set(vibra.__all__).isdisjoint(vibra.SUBMODULES)


@pytest.mark.parametrize("name", vibra.SUBMODULES)
def test_every_submodule_loads_by_attribute(name: str) -> None:
    module = getattr(vibra, name)
    assert module is importlib.import_module(f"vibra.{name}")
    assert module.__name__ == f"vibra.{name}"


def test_unknown_attribute_raises_attribute_error() -> None:
    with pytest.raises(AttributeError, match=r"module 'vibra' has no attribute 'chain'"):
        vibra.chain  # noqa: B018


def test_import_vibra_is_light() -> None:
    out = _run(f"import sys, vibra; print(sorted(m for m in {HEAVY!r} if m in sys.modules))")
    assert out.strip() == "[]"


def test_import_vibra_and_the_help_import_no_numpy() -> None:
    """Issue 45: ``vibra --help`` starts as fast as Python (the cost as modules imported, no clock);
    the API's names are bound on first access."""
    out = _run("import contextlib, io, sys, vibra\n"
               "print('R', 'numpy' in sys.modules, 'System' in vars(vibra))\n"
               "from vibra.cli import main\n"
               "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
               "    main(['--help'])\n"
               "print('R', 'numpy' in sys.modules)\n"
               "vibra.System\n"
               "print('R', 'numpy' in sys.modules, 'System' in vars(vibra))")
    lines = [line.split()[1:] for line in out.splitlines() if line.startswith("R ")]
    assert lines == [["False", "False"], ["False"], ["True", "True"]]


def test_star_import_binds_all_and_loads_nothing_heavy() -> None:
    code = (  # the cost as modules imported, not as a time (no clock in tests)
        "import sys\n"
        "from vibra import *\n"
        "names = dict(globals())\n"
        "import vibra\n"
        "print(all(name in names and names[name] is getattr(vibra, name) for name in vibra.__all__))\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    bound, heavy = _run(code).split("\n")[:2]
    assert bound == "True"
    assert heavy == "[]"
