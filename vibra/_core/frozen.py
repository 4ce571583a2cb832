"""Immutability of result objects: frozen dataclasses whose arrays are read-only.

Every result type is a frozen dataclass built on `Frozen`, whose `__post_init__` calls
`freeze_arrays(self)` (STYLE.md, "Results are frozen, documented values"); a class with more
to do after its fields are set calls `freeze_arrays` itself.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
from typing import Iterator

import numpy as np
import scipy.sparse as sp

#: Set (by `owned_arrays`) while vibra builds a result from arrays it has just created and
#: holds no other reference to: those are frozen in place instead of copied (a full set of
#: 10^4 x 10^4 mode shapes is 800 MB).
_OWNED = contextvars.ContextVar("vibra_owned_arrays", default=False)


@contextlib.contextmanager
def owned_arrays() -> Iterator[None]:
    """Within this block, result constructors freeze their arrays without copying them."""
    token = _OWNED.set(True)
    try:
        yield
    finally:
        _OWNED.reset(token)


def freeze_arrays(obj: object) -> None:
    """Copy every ndarray field of a frozen dataclass and make the copy read-only."""
    owned = _OWNED.get()
    for field in dataclasses.fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, field.name)
        if isinstance(value, np.ndarray):
            value = value.view() if owned else value.copy()
            value.flags.writeable = False
            object.__setattr__(obj, field.name, value)
        elif sp.issparse(value):
            object.__setattr__(obj, field.name, read_only(value.copy()))


def read_only(matrix: sp.spmatrix) -> sp.spmatrix:
    """`matrix` with its stored arrays (data, and indices and indptr where it has them) made read-only, in place."""
    for part in ("data", "indices", "indptr"):
        if hasattr(matrix, part):
            getattr(matrix, part).flags.writeable = False
    return matrix


class Frozen:
    """Base of vibra's frozen dataclasses (results, systems, models): their arrays are copied and made
    read-only (`freeze_arrays`) as soon as the fields are set. `vibra._results.Result` is one."""

    def __post_init__(self) -> None:
        freeze_arrays(self)


# ---------------------------------------------------------------------- short reprs
def span(values: object, unit: str = "", digits: int = 4) -> str:
    """'a..b unit' (or 'a unit' when all equal, 'none' when empty) for the finite entries of `values`."""
    array = np.asarray(values, dtype=float)
    array = array[np.isfinite(array)]
    if array.size == 0:
        return "none"
    low, high = float(array.min()), float(array.max())
    text = f"{low:.{digits}g}" if low == high else f"{low:.{digits}g}..{high:.{digits}g}"
    return f"{text} {unit}".rstrip()


def frequency_span(omega: object, units: object) -> str:
    """The span of angular frequencies `omega` as ordinary frequencies in THz where `units` are
    physical (signed: an imaginary mode is negative), else in rad per time unit."""
    try:
        return span(units.omega_to_thz(np.asarray(omega, dtype=float)), "THz")  # type: ignore[attr-defined]
    except (ValueError, AttributeError):
        return span(omega, "rad/time unit")


def short_repr(obj: object, *parts: str) -> str:
    """'TypeName(part, part, ...)': the one-line repr of a result (its arrays are summarised
    by `span`, never printed)."""
    return f"{type(obj).__name__}({', '.join(part for part in parts if part)})"
