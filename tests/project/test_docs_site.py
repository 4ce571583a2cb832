"""The documentation site's sources (issue 32, item 6): every page of docs/ is in mkdocs.yml's nav,
the API reference names modules that exist and covers every subpackage that exports names, and
docs/references.md names every source of `vibra.sources`. (CI builds the site itself with
``mkdocs build --strict``; this checks what a build would not flag.)

Truth: the files on disk, `importlib`, and `vibra.sources.SOURCES`.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import vibra
from vibra.sources import SOURCES

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
CONFIG = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
NAV = CONFIG[CONFIG.index("\nnav:"):]


def api_modules() -> set[str]:
    return {name for page in (DOCS / "api").glob("*.md")
            for name in re.findall(r"^::: ([\w.]+)$", page.read_text(encoding="utf-8"), re.M)}


def test_every_page_is_in_the_nav_and_every_nav_entry_is_a_page() -> None:
    pages = {path.relative_to(DOCS).as_posix() for path in DOCS.rglob("*.md")}
    listed = set(re.findall(r":\s+([\w/.-]+\.md)\s*$", NAV, re.M))
    assert pages - listed == set(), "pages missing from mkdocs.yml's nav"
    assert listed - pages == set(), "nav entries with no page"


def test_the_api_reference_names_real_modules() -> None:
    for name in api_modules():
        importlib.import_module(name)


def test_every_subpackage_with_public_names_has_an_api_page() -> None:
    covered = api_modules()
    exporting = {f"vibra.{name}" for name in vibra.SUBMODULES
                 if hasattr(importlib.import_module(f"vibra.{name}"), "__all__")}
    internal = {"vibra.cli", "vibra.charts"}  # the command line, and drawing (the report's): not a library API
    assert exporting - internal - covered == set()


def test_the_references_page_names_every_source() -> None:
    text = (DOCS / "references.md").read_text(encoding="utf-8")
    for source in SOURCES.values():
        assert source.full() in text, source.key


def test_the_changelog_page_includes_the_changelog() -> None:
    assert (DOCS / "changelog.md").read_text(encoding="utf-8").strip() == '--8<-- "CHANGELOG.md"'
    assert "check_paths: true" in CONFIG  # a missing file fails the build instead of leaving the page empty
