"""The names of vibra's unit systems, and their one parser, in a module that imports nothing.

`vibra.units.unit_system` and a scene's ``units`` key both read a name through `canonical_unit_name`;
a scene check reads it here without importing numpy (`vibra validate` on a refused scene).

>>> canonical_unit_name("si"), canonical_unit_name("Dimensionless")
('SI', 'dimensionless')
"""

from __future__ import annotations

__all__ = ["UNIT_NAMES", "UNITS_EXPECTED", "canonical_unit_name"]

#: The unit systems' names as vibra writes them; `canonical_unit_name` reads each in any capitalisation.
UNIT_NAMES: tuple[str, ...] = ("SI", "ASE", "dimensionless")
#: What `canonical_unit_name` (and so `vibra.units.unit_system` and a scene's ``units`` key) accepts, for messages.
UNITS_EXPECTED = f"expected one of {', '.join(repr(name) for name in UNIT_NAMES)} (in any capitalisation)"

_BY_LOWER = {name.lower(): name for name in UNIT_NAMES}


def canonical_unit_name(units: str) -> str:
    """`units` in vibra's spelling (one of `UNIT_NAMES`), read in any capitalisation.

    Raises
    ------
    ValueError
        `units` names no unit system (the message ends with `UNITS_EXPECTED`).
    """
    try:
        return _BY_LOWER[units.lower()]
    except KeyError:
        raise ValueError(f"units is {units!r}; {UNITS_EXPECTED}") from None
