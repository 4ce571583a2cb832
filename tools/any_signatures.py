"""Count `Any` on vibra's public signatures (issue 43, item 6: "`Any` on public signatures only
where a value really is any").

Run from the repository root: ``python tools/any_signatures.py`` prints the total, the count per
module and one line per annotation (``--quiet``: the total and the per-module counts only;
``--by-area``: per top-level area of ``vibra/`` instead of per module). Standard library only
(``ast``): nothing of vibra is imported, so it runs on any checkout.

What is counted, over ``vibra/`` (tests are outside it): each parameter annotation (``*args`` and
``**kwargs`` included) and each return annotation that mentions ``Any`` (``typing.Any``,
``Any``, an alias such as ``_Any``, or a string annotation that names it), of every PUBLIC
function or method:

- a module-level function whose name does not start with ``_``, or a method of a class whose name
  does not start with ``_`` (classes nested in public classes included); a method's name either
  does not start with ``_`` or is a dunder (``__init__``, ``__getitem__``, ...: these are the
  public API of the class);
- in a public module: no part of its dotted path starts with ``_`` (``__init__`` aside), or, in
  a private module (``vibra._results``, ``vibra._core.frozen``), the function or its class is
  listed in that module's ``__all__`` (the result protocol every public result type inherits);
- functions nested in functions are not counted (no caller outside sees them).

The figure is a guide, not a gate: an ``Any`` that stays must be a value that really is any (a
TOML value before validation, ``**kwargs`` forwarded to a third-party library, a JSON document);
docs/architecture.md, "Types", gives the rule and the figures.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "vibra"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_private_module(name: str) -> bool:
    return any(part.startswith("_") for part in name.split("."))


def _public_name(name: str) -> bool:
    return not name.startswith("_") or (name.startswith("__") and name.endswith("__"))


def _any_aliases(tree: ast.Module) -> tuple[set[str], set[str]]:
    """(names bound to typing.Any, names bound to the typing module) anywhere in the module."""
    names, modules = {"Any"}, {"typing"}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module in ("typing", "typing_extensions"):
            names.update(alias.asname or alias.name for alias in node.names if alias.name == "Any")
        elif isinstance(node, ast.Import):
            modules.update(alias.asname or alias.name for alias in node.names
                           if alias.name in ("typing", "typing_extensions"))
    return names, modules


def _mentions_any(annotation: ast.expr | None, names: set[str], modules: set[str]) -> bool:
    if annotation is None:
        return False
    for node in ast.walk(annotation):
        if isinstance(node, ast.Name) and node.id in names:
            return True
        if (isinstance(node, ast.Attribute) and node.attr == "Any" and isinstance(node.value, ast.Name)
                and node.value.id in modules):
            return True
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            try:
                inner = ast.parse(node.value, mode="eval").body
            except SyntaxError:
                continue
            if _mentions_any(inner, names, modules):
                return True
    return False


def _exported(tree: ast.Module) -> set[str] | None:
    """The names in the module's literal ``__all__``, or None when it has none."""
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(
            node, ast.AnnAssign) else []
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets) and node.value is not None:
            try:
                return set(ast.literal_eval(node.value))
            except ValueError:
                return None
    return None


def signatures(path: Path) -> list[tuple[str, int, str]]:
    """(qualified function name, line, parameter name or "return") for every annotation of a public
    signature of the module at `path` that mentions Any."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names, modules = _any_aliases(tree)
    module = _module_name(path)
    private = _is_private_module(module)
    exported = _exported(tree) or set()
    found: list[tuple[str, int, str]] = []

    def visit_function(node: ast.FunctionDef | ast.AsyncFunctionDef, qualname: str) -> None:
        args = node.args
        params = [*args.posonlyargs, *args.args, *args.kwonlyargs]
        params += [a for a in (args.vararg, args.kwarg) if a is not None]
        for arg in params:
            if _mentions_any(arg.annotation, names, modules):
                found.append((qualname, arg.lineno, arg.arg))
        if _mentions_any(node.returns, names, modules):
            found.append((qualname, node.lineno, "return"))

    def visit_body(body: list[ast.stmt], prefix: str, in_class: bool, top: str | None) -> None:
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                public = _public_name(node.name) if in_class else not node.name.startswith("_")
                if public and (not private or (top or node.name) in exported):
                    visit_function(node, prefix + node.name)
            elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
                visit_body(node.body, prefix + node.name + ".", True, top or node.name)
            elif isinstance(node, (ast.If, ast.Try)):  # conditional definitions at the same level
                visit_body(node.body, prefix, in_class, top)
                visit_body(getattr(node, "orelse", []), prefix, in_class, top)

    visit_body(tree.body, "", False, None)
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quiet", action="store_true", help="the total and the counts only")
    parser.add_argument("--by-area", action="store_true", help="count per top-level area of vibra/")
    options = parser.parse_args(argv)
    rows = [(_module_name(path), path.relative_to(ROOT).as_posix(), *row)
            for path in sorted(PACKAGE.rglob("*.py")) for row in signatures(path)]
    per: Counter[str] = Counter()
    for module, *_ in rows:
        per[".".join(module.split(".")[:2]) if options.by_area else module] += 1
    print(f"Any on public signatures: {len(rows)}")
    for module, count in sorted(per.items(), key=lambda item: (-item[1], item[0])):
        print(f"{count:5d}  {module}")
    if not options.quiet:
        print()
        for _, file, qualname, line, where in rows:
            print(f"{file}:{line}: {qualname}({where})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
