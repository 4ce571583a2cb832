"""The documentation sends readers to the public API only, and names every chart on its topic's
page (issue 48, item 3).

Read: every page under docs/ (the API pages included), README.md and every notebook (markdown
and code cells). A vibra name is a dotted path (``vibra.charts.save_figure``) or a name imported
``from vibra... import``. None may have a private component (``_x``; dunders are public), and
each must exist: the test imports it. Source files named by their path (``vibra/_core/filesystem.py``, where
a rule is implemented) are not names a reader calls, and are left alone; so is the module map of
docs/architecture.md, the contributors' map, which names every module, private ones included
(tests/project/test_layout.py).
"""

from __future__ import annotations

import importlib
import json
import pkgutil
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]
SOURCES = sorted([*ROOT.glob("docs/**/*.md"), ROOT / "README.md", *ROOT.glob("notebooks/**/*.ipynb")])

DOTTED = re.compile(r"(?<![\w./-])vibra(?:\.[A-Za-z_]\w*)+")
FROM_IMPORT = re.compile(r"\bfrom\s+(vibra(?:\.\w+)*)\s+import\s+(\([^)]*\)|[^\n#;]*)")


def lines(path: Path) -> Iterator[tuple[str, str]]:
    """(where, text) of each line: ``docs/x.md:12``, ``notebooks/y.ipynb cell 3 line 2``."""
    name = path.relative_to(ROOT).as_posix()
    if path.suffix == ".ipynb":
        for index, cell in enumerate(json.loads(path.read_text(encoding="utf-8"))["cells"], 1):
            source = "".join(cell["source"])
            # join a parenthesised import's lines, so that it is read whole
            for number, text in enumerate(_joined(source), 1):
                yield f"{name} cell {index} line {number}", text
    else:
        for number, text in enumerate(_joined(path.read_text(encoding="utf-8")), 1):
            yield f"{name}:{number}", text


def _joined(text: str) -> list[str]:
    """The lines of `text`, a ``from ... import (`` continued up to its ``)`` on its first line."""
    out = text.split("\n")
    for match in FROM_IMPORT.finditer(text):
        if match.group(2).startswith("("):
            first = text.count("\n", 0, match.start())
            out[first] = out[first] + " " + " ".join(match.group(2).split("\n")[1:])
    return out


def names(text: str) -> Iterator[str]:
    """Every vibra name `text` refers to, as a dotted path."""
    for match in DOTTED.finditer(text):
        yield match.group(0)
    for match in FROM_IMPORT.finditer(text):
        for item in match.group(2).strip("()").split(","):
            imported = item.strip().split(" as ")[0].strip()
            if imported and imported != "*":
                yield f"{match.group(1)}.{imported}"


def private(path: str) -> bool:
    return any(part.startswith("_") and not (part.startswith("__") and part.endswith("__"))
               for part in path.split("."))


def resolves(path: str) -> bool:
    """Whether `path` imports: its longest module prefix, then attributes or submodules."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:cut]))
            break
        except ImportError:
            continue
    for part in parts[cut:]:
        if hasattr(obj, part):
            obj = getattr(obj, part)
            continue
        try:
            obj = importlib.import_module(f"{obj.__name__}.{part}")
        except (ImportError, AttributeError):
            return False
    return True


REFERENCES = [(where, name) for source in SOURCES for where, text in lines(source) for name in names(text)]
#: rows of docs/architecture.md's module map ("| `vibra.units`, `vibra._core.validate`, ... | stage |")
MODULE_MAP = {where for source in SOURCES if source.name == "architecture.md" and source.parent.name == "docs"
              for where, text in lines(source) if text.startswith("| `vibra.")}


def test_the_sources_are_read() -> None:
    read = {source.relative_to(ROOT).parts[0] for source in SOURCES}
    assert read == {"docs", "README.md", "notebooks"}
    assert len(REFERENCES) > 100 and 5 < len(MODULE_MAP) < 40


def test_no_page_or_notebook_names_a_private_vibra_name() -> None:
    found = [f"{where}: {name}" for where, name in REFERENCES if private(name) and where not in MODULE_MAP]
    assert not found, "private names in the docs (use the public one):\n" + "\n".join(found)


def test_every_vibra_name_in_the_docs_exists() -> None:
    missing = [f"{where}: {name}" for where, name in REFERENCES if not private(name) and not resolves(name)]
    assert not missing, "names the docs give that do not import:\n" + "\n".join(missing)


def test_the_scanner_sees_imports_and_paths() -> None:
    text = ("from vibra.charts._style import save_figure\nimport vibra._core.filesystem as io\nvibra.x._y(1)\n"
            "from vibra.charts import (\n    save_figure,\n    _hidden as h,\n)\nvibra.__version__")
    found = list(names("\n".join(_joined(text))))
    assert [name for name in found if private(name)] == [
        "vibra.charts._style", "vibra._core.filesystem", "vibra.x._y", "vibra.charts._style.save_figure", "vibra.charts._hidden"]
    assert "vibra.charts.save_figure" in found and not private("vibra.__version__")
    assert not list(names("`vibra/_core/filesystem.py` holds the writer; vibra report --out plots"))
    assert resolves("vibra.charts.save_figure") and not resolves("vibra.charts.no_such_chart")


# ---------------------------------------------------------------------- every chart on its topic's page
#: the page of each chart (every ``plot_*`` and ``*_figure`` of the vibra.charts modules, and the
#: annotations set on renders): where a reader of that topic looks
TOPIC = {
    "chains": "chains.md", "continuum": "chains.md", "crystals": "crystals.md", "infrared": "crystals.md",
    "dynamics": "dynamics.md", "networks": "networks.md", "orbits": "generalized.md", "pendulum": "generalized.md",
    "response": "response.md", "spectra": "spectra.md", "experiment": "spectra.md", "sweep": "distributed.md",
    "modes": "scenes.md",
    "renders": "scenes.md",
}
#: charts of vibra.charts.notebooks, shared by notebooks of several topics: each on its own page
NOTEBOOK_CHARTS = {"plot_cost_vs_error": "solvers.md", "plot_step_errors": "solvers.md",
                   "plot_time_series": "generalized.md"}


def charts() -> list[tuple[str, str]]:
    import vibra.charts

    out = []
    for module in pkgutil.iter_modules(vibra.charts.__path__):
        if module.name.startswith("_"):
            continue
        public = importlib.import_module(f"vibra.charts.{module.name}").__all__
        out += [(module.name, name) for name in public
                if name.startswith("plot_") or name.endswith("_figure") or name == "annotate_render"]
    return out


CHARTS = charts()


def test_the_charts_are_found() -> None:
    assert ("crystals", "plot_bands_dos") in CHARTS and ("crystals", "plot_thermal") in CHARTS
    assert ("infrared", "infrared_figure") in CHARTS and len(CHARTS) > 30


@pytest.mark.parametrize("module,name", CHARTS, ids=[f"{m}.{n}" for m, n in CHARTS])
def test_each_chart_is_named_on_its_topic_page(module: str, name: str) -> None:
    page = NOTEBOOK_CHARTS[name] if module == "notebooks" else TOPIC[module]
    text = (ROOT / "docs" / page).read_text(encoding="utf-8")
    assert re.search(rf"\b{name}\b", text), f"vibra.charts.{module}.{name} is not named on docs/{page}"
    assert f"vibra.charts.{module}" in text, f"docs/{page} does not say where {name} lives"


def test_save_figure_is_public() -> None:
    import vibra.charts

    assert "save_figure" in vibra.charts.__all__


# ---------------------------------------------------------------------- examples on a base install
def test_the_network_examples_read_the_repositorys_own_file() -> None:
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "networks.md").read_text(encoding="utf-8"), re.S)
    assert blocks and all(re.search(r'"networks/\w+/[\w.-]+\.pdb"', block) for block in blocks)
    read = {path for block in blocks for path in re.findall(r'"(networks/\w+/[\w.-]+\.pdb)"', block)}
    assert read and all((ROOT / path).is_file() for path in read), read
    assert not [block for block in blocks if re.search(r"^\s*(import|from) prody", block, re.M)]  # an extra
    assert (ROOT / "networks" / "ubiquitin" / "1ubi.pdb").is_file()
