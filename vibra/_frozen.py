"""Immutability of result objects: frozen dataclasses whose arrays are read-only.

Every result type calls `freeze_arrays(self)` in `__post_init__` (STYLE.md, "Results are
frozen, documented values").
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
            value = value.copy()
            for part in ("data", "indices", "indptr"):
                if hasattr(value, part):
                    getattr(value, part).flags.writeable = False
            object.__setattr__(obj, field.name, value)
