"""Value checks of the scene schema: each takes (value, fail) and returns the normalised value.

Lists become tuples; ``fail(message)`` raises a `SceneError` at the key being checked. Every
value in a scene is a number, a string, a boolean, a list or a table: nothing is evaluated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, NoReturn

from vibra._core.text import counted

__all__ = ["brief", "Check", "Fail", "FieldSpec", "field_spec", "kind_name", "number", "positive", "nonnegative", "integer",
           "boolean", "string", "one_of", "list_of", "scalar_or_list", "index_pairs", "matrix", "coordinates",
           "table", "HYDROGEN_ISOTOPES", "element_symbol"]

#: Isotope symbols a scene may use as chemical symbols: D and T are hydrogen (2H, 3H).
HYDROGEN_ISOTOPES = {"D": "H", "T": "H"}


def element_symbol(symbol: str) -> str:
    """The element of a scene's chemical symbol: ``"D"`` and ``"T"`` are ``"H"``, others unchanged."""
    return HYDROGEN_ISOTOPES.get(symbol, symbol)

#: How a check refuses a value: ``fail(message)`` raises a `SceneError` at the key, and never returns.
Fail = Callable[[str], NoReturn]
#: A value check: (the TOML value, which is any value before it is checked, fail) -> the normalised value.
Check = Callable[[Any, Fail], Any]


def brief(value: object, limit: int = 60) -> str:
    """``repr(value)`` cut to `limit` characters (``...`` marks the cut): messages stay one short line."""
    text = repr(value) if not isinstance(value, (list, dict)) or len(value) < 64 else \
        f"{type(value).__name__} of {len(value)} entries"
    text = text.replace("\n", "\\n")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def kind_name(value: object) -> str:
    names = {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
             list: "a list", dict: "a table"}
    return names.get(type(value), type(value).__name__)


def number(value: Any, fail: Fail) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        fail(f"expected a number, got {kind_name(value)} ({brief(value)})")
    if not math.isfinite(value):
        fail(f"expected a finite number, got {brief(value)}")
    return float(value)


def positive(value: Any, fail: Fail) -> float:
    checked = number(value, fail)
    if checked <= 0:
        fail(f"must be positive, got {brief(value)}")
    return checked


def nonnegative(value: Any, fail: Fail) -> float:
    checked = number(value, fail)
    if checked < 0:
        fail(f"must be >= 0, got {brief(value)}")
    return checked


def integer(low: int, high: int | None = None) -> Check:
    def check(value: Any, fail: Fail) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            fail(f"expected an integer, got {kind_name(value)} ({brief(value)})")
        if value < low or (high is not None and value > high):
            bound = f"{low} <= value <= {high}" if high is not None else f">= {low}"
            fail(f"must be {bound}, got {value}")
        return int(value)
    return check


def boolean(value: Any, fail: Fail) -> bool:
    if not isinstance(value, bool):
        fail(f"expected true or false, got {kind_name(value)} ({brief(value)})")
    return bool(value)


def string(value: Any, fail: Fail) -> str:
    if not isinstance(value, str):
        fail(f"expected a string, got {kind_name(value)} ({brief(value)})")
    return str(value)


def one_of(*allowed: object) -> Check:
    def check(value: Any, fail: Fail) -> Any:
        if value not in allowed or isinstance(value, bool) != isinstance(allowed[0], bool):
            options = ", ".join(repr(a) for a in allowed)
            fail(f"is {brief(value)}; expected one of {options}")
        return value
    return check


def list_of(item: Check, *, length: int | None = None, min_length: int = 1) -> Check:
    def check(value: Any, fail: Fail) -> tuple[Any, ...]:
        if not isinstance(value, list):
            fail(f"expected a list, got {kind_name(value)} ({brief(value)})")
        if length is not None and len(value) != length:
            fail(f"needs {counted(length, 'value')}, got {len(value)}")
        if len(value) < min_length:
            fail(f"needs at least {counted(min_length, 'value')}, got {len(value)}")
        out = []
        for i, entry in enumerate(value):
            out.append(item(entry, _prefixed(fail, f"[{i}] ")))
        return tuple(out)
    return check


def _prefixed(fail: Fail, prefix: str) -> Fail:
    def prefixed(message: str) -> NoReturn:
        return fail(prefix + message)
    return prefixed


def scalar_or_list(item: Check) -> Check:
    listed = list_of(item)

    def check(value: Any, fail: Fail) -> Any:
        return listed(value, fail) if isinstance(value, list) else item(value, fail)
    return check


def index_pairs(value: Any, fail: Fail) -> tuple[tuple[int, int], ...]:
    return list_of(list_of(integer(0), length=2), min_length=0)(value, fail)


def matrix(value: Any, fail: Fail) -> tuple[tuple[float, ...], ...]:
    rows = list_of(list_of(number))(value, fail)
    if any(len(row) != len(rows) for row in rows):
        fail(f"must be a square matrix (a list of {len(rows)} rows of {len(rows)} numbers)")
    return rows


def coordinates(value: Any, fail: Fail) -> tuple[float, ...] | tuple[tuple[float, ...], ...]:
    if not isinstance(value, list) or not value:
        fail(f"expected a non-empty list of coordinates, got {kind_name(value)}")
    if all(not isinstance(v, list) for v in value):
        return list_of(number)(value, fail)
    rows = list_of(list_of(number))(value, fail)
    if len({len(r) for r in rows}) != 1 or len(rows[0]) not in (1, 2, 3):
        fail("every site needs the same number (1, 2 or 3) of coordinates")
    return rows


@dataclass(frozen=True)
class FieldSpec:
    """One key of a table: its check, its default, and whether a scene must give it."""

    check: Check
    default: object = None
    required: bool = False


def field_spec(check: Check, default: object = None, *, required: bool = False) -> FieldSpec:
    return FieldSpec(check, default, required)



def table(value: Any, fail: Fail) -> dict[str, object]:
    """A ``[section]`` table, checked later against its own fields."""
    if not isinstance(value, dict):
        fail(f"expected a table ([section]), got {kind_name(value)} ({brief(value)})")
    return value
