"""Values derived from vibra's own sources, kept between processes (`vibra._core.cache`, issue 45 item 1).

Truth: what a second interpreter reads (it is given a `derive` that would fail, so a value it
returns came from the file), what JSON can carry (a value that cannot survive it is never
stored), and the file system (a changed source file changes the key; a damaged, foreign or
unwritable cache reads as "not cached yet" and fails nothing).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vibra._core import cache

ROOT = Path(__file__).parents[2]


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder of this test, this process's memory of the file forgotten before and after."""
    monkeypatch.setenv("VIBRA_CACHE_DIR", str(tmp_path))
    cache.forget_in_process()
    yield tmp_path
    cache.forget_in_process()


def _in_a_new_process(code: str, folder: Path) -> str:
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False,
                         env=dict(os.environ, VIBRA_CACHE_DIR=str(folder)), cwd=ROOT)
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


def test_derived_once_then_read_by_another_process(folder: Path) -> None:
    calls = []
    value = {"names": ["n", "mass"], "scene": [["n", True, None], ["mass", False, [1.0, 2.0]]]}
    assert cache.remembered("a", lambda: calls.append(1) or value) == {
        "names": ("n", "mass"), "scene": (("n", True, None), ("mass", False, (1.0, 2.0)))}
    assert cache.remembered("a", lambda: calls.append(1) or value) and calls == [1]  # this process: its memory
    (stored,) = (folder / "derived").glob("*.json")
    assert stored.name == f"{cache.source_key()}.json"
    # another interpreter reads the file: its derive would raise ZeroDivisionError
    code = "from vibra._core.cache import remembered; print(remembered('a', lambda: 1 / 0))"
    assert _in_a_new_process(code, folder) == str(cache.remembered("a", lambda: 1 / 0))


def test_types_survive_the_file(folder: Path) -> None:
    value = [1, 2.0, "x", None, True, float("inf"), [[0, 1], [2, 3]]]
    cache.remembered("types", lambda: value)
    code = ("from vibra._core.cache import remembered; v = remembered('types', lambda: 1 / 0); "
            "print([type(x).__name__ for x in v], v)")
    assert _in_a_new_process(code, folder) == (
        "['int', 'float', 'str', 'NoneType', 'bool', 'float', 'tuple'] (1, 2.0, 'x', None, True, inf, ((0, 1), (2, 3)))")


def test_a_value_json_cannot_carry_is_derived_in_every_process(folder: Path) -> None:
    marker = object()
    assert cache.remembered("object", lambda: marker) is marker
    assert cache.remembered("tuple key", lambda: {(1, 2): 3}) == {(1, 2): 3}
    assert not (folder / "derived").exists()  # nothing was written for either


def test_two_names_in_one_file_and_another_process_adds_its_own(folder: Path) -> None:
    cache.remembered("first", lambda: 1)
    _in_a_new_process("from vibra._core.cache import remembered; remembered('second', lambda: 2)", folder)
    (stored,) = (folder / "derived").glob("*.json")
    assert json.loads(stored.read_text()) == {"first": 1, "second": 2}
    cache.remembered("third", lambda: 3)  # this process keeps what the other wrote
    assert json.loads(stored.read_text()) == {"first": 1, "second": 2, "third": 3}


@pytest.mark.parametrize("content", ["{not json", "[1, 2]", ""])
def test_a_damaged_or_foreign_file_reads_as_not_cached(folder: Path, content: str) -> None:
    path = folder / "derived" / f"{cache.source_key()}.json"
    path.parent.mkdir(parents=True)
    path.write_text(content)
    assert cache.remembered("value", lambda: 7) == 7
    assert json.loads(path.read_text()) == {"value": 7}  # replaced by a whole file


def test_an_unwritable_cache_fails_nothing(folder: Path) -> None:
    if os.geteuid() == 0:
        blocked = folder / "derived"
        blocked.write_text("a file where the folder should be")  # (root writes through permissions)
    else:
        folder.chmod(0o500)
    try:
        assert cache.remembered("value", lambda: 7) == 7
    finally:
        folder.chmod(0o700)


def test_no_home_folder_no_cache(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("VIBRA_CACHE_DIR")
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setattr(os.path, "expanduser", lambda path: path)  # no home folder known: "~" stays "~"
    cache.forget_in_process()
    try:
        assert cache.cache_dir() is None
        calls = []
        assert cache.remembered("value", lambda: calls.append(1) or 5) == 5 and calls == [1]
    finally:
        cache.forget_in_process()


def test_the_key_follows_every_source_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The key is the sources' bytes: an edit that keeps the size and the time (``cp -p``, ``rsync -a``,
    a container layer) changes it; a touch, or a file that is not a source, does not."""
    package = tmp_path / "package"
    (package / "sub").mkdir(parents=True)
    (package / "a.py").write_text("x = 1\n")
    (package / "sub" / "b.py").write_text("y = 2\n")
    (package / "data.txt").write_text("not a source")
    monkeypatch.setattr(cache, "_PACKAGE", package)
    first = cache.source_key()
    (package / "data.txt").write_text("still not a source")
    os.utime(package / "a.py", ns=(0, 10**18))  # a touch
    assert cache.source_key() == first
    times = os.stat(package / "sub" / "b.py").st_mtime_ns
    (package / "sub" / "b.py").write_text("y = 3\n")  # the same size ...
    os.utime(package / "sub" / "b.py", ns=(times, times))  # ... and the same time
    second = cache.source_key()
    (package / "c.py").write_text("")  # a new file
    assert len({first, second, cache.source_key()}) == 3


def test_no_source_files_no_cache(folder: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """A zipped or compiled install (no ``.py`` file found): no key, nothing stored, the value derived."""
    empty = tmp_path / "compiled"
    empty.mkdir()
    monkeypatch.setattr(cache, "_PACKAGE", empty)
    assert cache.source_key() == ""
    assert cache.remembered("value", lambda: 3) == 3 and not (folder / "derived").exists()


def test_a_source_edited_after_the_import_is_not_stored(folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A process that imported vibra before a source file changed may derive from the modules as they
    were: it neither stores under the new sources' key nor reads it."""
    import vibra._core

    cache.remembered("before", lambda: 1)  # sources older than the import: stored
    cache.forget_in_process()
    monkeypatch.setattr(vibra._core, "IMPORTED_AT", 0.0)  # as if every source changed after this process imported vibra
    calls = []
    assert cache.remembered("before", lambda: calls.append(1) or 2) == 2 and calls == [1]  # not read
    assert cache.remembered("after", lambda: 3) == 3
    (stored,) = (folder / "derived").glob("*.json")
    assert json.loads(stored.read_text()) == {"before": 1}  # nor stored


def test_the_other_keys_files_go(folder: Path) -> None:
    old = folder / "derived" / "0123456789abcdef01234567.json"  # an earlier version's
    old.parent.mkdir(parents=True)
    old.write_text('{"value": 1}')
    assert cache.remembered("value", lambda: 2) == 2
    assert [path.name for path in (folder / "derived").iterdir()] == [f"{cache.source_key()}.json"]


def test_types_are_kept_or_nothing_is_stored(folder: Path) -> None:
    """A value whose types JSON would change (an int subclass, a float-valued enum) is not stored."""
    import enum

    class Level(enum.IntEnum):
        LOW = 1

    assert cache.remembered("enum", lambda: [Level.LOW]) == (Level.LOW,)
    assert cache.remembered("float", lambda: [1.0, 2]) == (1.0, 2)
    (stored,) = (folder / "derived").glob("*.json")
    assert json.loads(stored.read_text()) == {"float": [1.0, 2]}
