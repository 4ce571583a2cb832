"""Move the flat test files into folders that mirror the package (issue 43, item 6).

Run from the repository root: ``python tools/mirror_tests.py`` (``--dry-run`` prints the mapping
and changes nothing). Each ``tests/test_*.py`` goes where a RULE puts it, or where the EXCEPTIONS
table below says; a new flat file that neither places makes the script fail, naming it, before
anything moves. It is idempotent: on a tree already mirrored it changes nothing.

The rule, on the file's name without ``test_`` (``crystals_bands`` for ``test_crystals_bands.py``):

(a) it starts with a package folder of ``vibra/`` and ``_`` (or is one): the file goes to that
    folder's mirror, less the prefix: ``test_crystals_bands.py`` -> ``tests/crystals/test_bands.py``,
    ``test_chains.py`` -> ``tests/chains/test_chains.py``;
(b) it is, or starts with, a loose module of ``vibra/`` (``vibra/modes.py``, ``vibra/cli.py``...)
    and ``_``: it stays in ``tests/``, which mirrors ``vibra/`` itself (``test_cli_distributed.py``);
(c) its longest ``_``-prefix is the name of modules or folders below exactly one package folder
    (``registry`` -> ``vibra/solvers/registry.py``, ``ring`` -> ``vibra/solvers/accurate/ring/``),
    ``charts/`` left out when another has it too (charts name their modules after what they draw:
    ``sweep`` -> ``vibra/pipeline/sweep/``, not ``vibra/charts/sweep.py``): the file keeps its name in
    that package folder's mirror (``tests/solvers/test_registry.py``); a name found below two package
    folders places nothing.

Mirrors are one level deep (``tests/solvers/`` holds the tests of all of ``vibra/solvers/``).

What the move would break, fixed in the same run:
- each test folder gets an ``__init__.py`` (``tests/`` itself none): under pytest's default import
  mode ``tests/`` stays on sys.path, so ``helpers`` and ``molecule_closed_forms`` import as before,
  and a test module is ``crystals.test_bands``: the same base name may sit in two folders
  (``crystals/test_accuracy.py``, ``solvers/test_accuracy.py``), and objects a test pickles by
  reference (Dask workers) still import;
- ``Path(__file__)...parent`` chains in a moved file get one ``parent`` more per level
  (``.parent.parent`` -> ``.parents[2]``, ``.parent / "data"`` -> ``.parents[1] / "data"``); any
  other use of a bare ``__file__`` stops the script, naming the file (fix it by hand, run again);
- references in the repository's text files (git-tracked and untracked-not-ignored; not
  CHANGELOG.md, which is history, nor this file): ``tests/test_x.py`` and ``tests/test_x.name``
  -> the new path; a bare ``test_x.py`` or ``test_x.name`` -> ``tests/<new path>``; ``from test_x import`` /
  ``import test_x`` (tests, benchmarks, scripts inside strings) -> ``from solvers.test_x import``
  (``tests/`` on sys.path). On later runs, a ``tests/test_x...`` reference to a file already moved
  (one written since) is rewritten too.

``tests/project/test_tests_layout.py`` keeps the layout (no flat test file but the loose modules'
tests, every folder a package folder's mirror or a named other one) and names this script.
"""

from __future__ import annotations

import argparse
import functools
import re
import shutil
import subprocess
import sys
from pathlib import Path

#: Files the rule places wrongly or not at all: old name -> new path under tests/.
EXCEPTIONS: dict[str, str] = {
    # the repository around the package: docs, README, notebooks, layout, packaging, start-up
    "test_docs_blocks.py": "project/test_docs_blocks.py",
    "test_docs_public_api.py": "project/test_docs_public_api.py",
    "test_docs_site.py": "project/test_docs_site.py",
    "test_doctests.py": "project/test_doctests.py",
    "test_layout.py": "project/test_layout.py",
    "test_notebooks.py": "project/test_notebooks.py",       # the rule: charts/ (vibra/charts/notebooks.py)
    "test_package.py": "project/test_package.py",           # vibra/__init__.py
    "test_readme.py": "project/test_readme.py",
    "test_startup.py": "project/test_startup.py",
    "test_tests_layout.py": "project/test_tests_layout.py",
    # a domain's doc page beside the domain's tests (as crystals/test_docs.py, dynamics/test_docs.py)
    "test_docs_examples.py": "response/test_docs.py",       # docs/response.md
    # named after no module, or after one the rule would misread
    "test_bad_inputs.py": "_core/test_bad_inputs.py",       # vibra/_core/validate.py's rule, library-wide
    "test_bad_inputs_cli.py": "test_cli_bad_inputs.py",     # vibra/cli.py (a loose module: stays flat)
    "test_hostile_files.py": "_core/test_hostile_files.py",  # vibra/_core/filesystem.py, _results/files.py
    "test_plurals.py": "_core/test_plurals.py",             # vibra/_core/text.py
    "test_result_protocol.py": "_results/test_protocol.py",
    "test_results.py": "_results/test_results.py",          # the rule: pipeline/ (pipeline/sweep/results.py)
    "test_viewer.py": "_results/test_viewer.py",            # vibra/_results/display.py (the rule: pipeline/report/viewer.py)
    "test_viewer_browser.py": "_results/test_viewer_browser.py",
    "test_bounds.py": "solvers/test_bounds.py",
    "test_partial_solves.py": "solvers/test_partial_solves.py",
    "test_refinement.py": "solvers/test_refinement.py",
    "test_solver_registry_paths.py": "solvers/test_registry_paths.py",
    "test_distributed_fd.py": "molecules/test_distributed_fd.py",  # the rule: solvers/ (solvers/distributed/)
    "test_engine_scenes.py": "molecules/test_engine_scenes.py",    # vibra/molecules/engines/choice.py
    "test_fd_noise.py": "molecules/test_noise.py",                 # vibra/molecules/noise.py
    "test_gnm_scene.py": "networks/test_gnm_scene.py",
    "test_isotope_pairing.py": "spectra/test_isotope_pairing.py",  # spectra.isotope_shifts
    "test_thermo_low_frequency.py": "spectra/test_thermo_low_frequency.py",  # vibra/spectra/thermochemistry.py
    "test_validate_property.py": "pipeline/test_validate_property.py",  # the rule: _core/ (_core/validate.py)
}

#: Folders under tests/ that mirror no package folder.
NOT_PACKAGES = ("helpers", "data", "broken_scenes", "project")

#: Not rewritten: history, and this file (its table names the old files).
NO_REWRITE = {"CHANGELOG.md", "tools/mirror_tests.py"}


class Refused(Exception):
    """The script stops: a file it cannot place or fix."""


def git(*args: str, check: bool = True) -> str:
    done = subprocess.run(["git", *args], capture_output=True, text=True, check=False)
    if check and done.returncode:
        raise Refused(f"git {' '.join(args)}: {done.stderr.strip()}")
    return done.stdout


class Package:
    """What vibra/ holds: its package folders, its loose modules, and where each name below lives."""

    def __init__(self, root: Path) -> None:
        vibra = root / "vibra"
        self.folders = sorted(p.name for p in vibra.iterdir() if (p / "__init__.py").is_file())
        self.loose = sorted(p.stem for p in vibra.glob("*.py") if p.stem not in ("__init__", "__main__"))
        self.where: dict[str, set[str]] = {}
        for top in self.folders:
            for path in (vibra / top).rglob("*"):
                if "__pycache__" in path.parts or path.name == "__init__.py":
                    continue
                if path.suffix == ".py" or (path.is_dir() and (path / "__init__.py").is_file()):
                    self.where.setdefault(path.stem, set()).add(top)

    def place(self, filename: str) -> str | None:
        """The new path under tests/ of a flat test file, by the exceptions or the rule; None: unplaced."""
        if filename in EXCEPTIONS:
            return EXCEPTIONS[filename]
        name = filename[len("test_"):-len(".py")]
        for top in sorted(self.folders, key=len, reverse=True):                     # (a)
            if name == top:
                return f"{top}/{filename}"
            if name.startswith(top + "_"):
                return f"{top}/test_{name[len(top) + 1:]}.py"
        if any(name == m or name.startswith(m + "_") for m in self.loose):          # (b)
            return filename
        words = name.split("_")
        for n in range(len(words), 0, -1):                                          # (c)
            tops = self.where.get("_".join(words[:n]), set())
            if len(tops) > 1 and "charts" in tops:      # charts/ names modules after what they draw
                tops = tops - {"charts"}
            if len(tops) == 1:
                return f"{next(iter(tops))}/{filename}"
            if len(tops) > 1:
                return None
        return None


FILE_PATH = re.compile(r"Path\(__file__\)(\.resolve\(\))?((?:\.parent(?![\w\[]))+|\.parents\[(\d+)\])")
BARE_FILE = re.compile(r"(?<![\w.\"'])__file__")


def deepen(text: str, levels: int, where: str) -> str:
    """``Path(__file__)`` parent chains reaching `levels` more folders up (the file moved that deep)."""
    def one(match: re.Match[str]) -> str:
        up = int(match.group(3)) + 1 if match.group(3) else match.group(2).count(".parent")
        return f"Path(__file__){match.group(1) or ''}.parents[{up + levels - 1}]"

    if not levels:
        return text
    new = FILE_PATH.sub(one, text)
    rest = [m for m in BARE_FILE.finditer(new)
            if not new.startswith("Path(__file__)", m.start() - 5)]
    if rest:
        line = new.count("\n", 0, rest[0].start()) + 1
        raise Refused(f"{where}:{line}: a use of __file__ this script cannot re-point; fix it by hand")
    return new


def text_files(root: Path) -> list[Path]:
    listed = git("ls-files", "-z") + git("ls-files", "-z", "--others", "--exclude-standard")
    return [root / name for name in sorted(set(listed.split("\0"))) if name and name not in NO_REWRITE
            and (root / name).is_file()]


def bare_reference(match: re.Match[str], new: dict[str, str], bound: set[str]) -> str:
    """``test_x.py`` or ``test_x.name`` -> ``tests/<new path>``, but ``test_x.name`` where code imported test_x."""
    if match.group(1) in bound and not match.string.startswith(".py", match.end()):
        return match.group(0)
    return f"tests/{new[match.group(1)]}"


def rewrite_references(root: Path, moved: dict[str, str], bare: bool) -> list[str]:
    """References to the moved files (old name -> new path under tests/), in every text file."""
    if not moved:
        return []
    names = "|".join(re.escape(old[:-3]) for old in sorted(moved, key=len, reverse=True))
    new = {old[:-3]: path[:-3] for old, path in moved.items()}
    prefixed = re.compile(rf"(?<![\w/.-])tests/({names})(?=\.py\b|\.[A-Za-z_]|::)")
    plain = re.compile(rf"(?<![\w/.-])({names})(?=\.py\b|\.[A-Za-z_])")
    imports = re.compile(rf"^(\s*from\s+)({names})(\s+import\b)|^(\s*import\s+)({names})\b(\s+as\b)?", re.MULTILINE)

    def module(old: str) -> str:
        return new[old].replace("/", ".")

    def imported(m: re.Match[str]) -> str:
        if m.group(1):
            return f"{m.group(1)}{module(m.group(2))}{m.group(3)}"
        return f"{m.group(4)}{module(m.group(5))}{m.group(6) or ' as ' + m.group(5)}"

    changed = []
    for path in text_files(root):
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue
        out = prefixed.sub(lambda m: f"tests/{new[m.group(1)]}", text)
        if bare:
            bound: set[str] = set()         # ``import test_x``: ``test_x.name`` is code there, kept
            if path.suffix == ".py":
                bound = {m.group(5) for m in imports.finditer(out) if m.group(5)}
                out = imports.sub(imported, out)
            out = plain.sub(functools.partial(bare_reference, new=new, bound=bound), out)
        if out != text:
            path.write_text(out, encoding="utf-8")
            changed.append(path.relative_to(root).as_posix())
    return changed


def stale_references(root: Path, package: Package, tests: Path) -> dict[str, str]:
    """Old flat names that moved already: ``tests/test_x.py`` gone, its placement present."""
    pattern = re.compile(r"(?<![\w/.-])tests/(test_\w+?)(?=\.py\b|\.[A-Za-z_]|::)")
    seen: set[str] = set()
    for path in text_files(root):
        try:
            seen.update(pattern.findall(path.read_text(encoding="utf-8")))
        except (UnicodeDecodeError, OSError):
            continue
    stale = {}
    for stem in seen:
        target = package.place(stem + ".py")
        if target and target != stem + ".py" and not (tests / (stem + ".py")).exists() \
                and (tests / target).exists():
            stale[stem + ".py"] = target
    return stale


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dry-run", action="store_true", help="print the mapping, change nothing")
    args = parser.parse_args(argv)
    root = Path.cwd()
    tests = root / "tests"
    if not (root / "vibra" / "__init__.py").is_file() or not tests.is_dir():
        print("run from the repository root (vibra/ and tests/ there)", file=sys.stderr)
        return 2
    package = Package(root)
    unknown = sorted(p for p in EXCEPTIONS.values()
                     if "/" in p and p.split("/")[0] not in (*package.folders, *NOT_PACKAGES))
    if unknown:
        print(f"exception table names folders that are no package folder: {unknown}", file=sys.stderr)
        return 2
    mapping: dict[str, str] = {}
    stays = []
    unplaced = []
    for path in sorted(tests.glob("test_*.py")):
        target = package.place(path.name)
        if target is None:
            unplaced.append(path.name)
        elif target != path.name:
            mapping[path.name] = target
        else:
            stays.append(path.name)
    if unplaced:
        print("no rule places these; add them to EXCEPTIONS in tools/mirror_tests.py:\n  "
              + "\n  ".join(unplaced), file=sys.stderr)
        return 1
    taken = [f"{old} -> tests/{new} (exists)" for old, new in mapping.items() if (tests / new).exists()]
    twice = sorted({new for new in mapping.values() if list(mapping.values()).count(new) > 1})
    if taken or twice:
        print("destinations taken:\n  " + "\n  ".join(taken + twice), file=sys.stderr)
        return 1
    width = max((len(old) for old in [*mapping, *stays]), default=0)
    for old, new in mapping.items():
        print(f"tests/{old:<{width}} -> tests/{new}")
    for name in stays:
        print(f"tests/{name:<{width}}    stays (tests/ mirrors vibra/'s loose modules)")
    if args.dry_run:
        return 0
    try:
        sources = {old: (tests / old).read_text(encoding="utf-8") for old in mapping}
        fixed = {old: deepen(text, mapping[old].count("/"), f"tests/{old}") for old, text in sources.items()}
        tracked = set(git("ls-files", "-z", "tests").split("\0"))
        for old, new in mapping.items():
            target = tests / new
            folder = target.parent
            for level in [*reversed(folder.relative_to(tests).parents), folder.relative_to(tests)]:
                if level == Path("."):
                    continue
                (tests / level).mkdir(exist_ok=True)
                init = tests / level / "__init__.py"
                if not init.exists():
                    init.write_text("", encoding="utf-8")
                    git("add", "--", init.relative_to(root).as_posix())
                    print(f"  new {init.relative_to(root).as_posix()}")
            if f"tests/{old}" in tracked:
                git("mv", "--", f"tests/{old}", f"tests/{new}")
            else:
                shutil.move(tests / old, target)
                print(f"  (tests/{old} is not tracked: moved without git)")
            if fixed[old] != sources[old]:
                target.write_text(fixed[old], encoding="utf-8")
        changed = rewrite_references(root, mapping, bare=True)
        stale = stale_references(root, package, tests)
        changed += rewrite_references(root, stale, bare=False)
    except Refused as refusal:
        print(refusal, file=sys.stderr)
        return 1
    for name in sorted(set(changed)):
        print(f"  references rewritten: {name}")
    if stale:
        print(f"  stale references to moved files rewritten: {sorted(stale)}")
    if not (mapping or changed):
        print("nothing to do: tests/ already mirrors vibra/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
