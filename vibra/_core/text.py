"""Words in messages: one place for counted nouns, so no message reads "1 atoms"."""

from __future__ import annotations

__all__ = ["counted", "plural"]

# Nouns whose plural is not noun + "s" (the ones vibra's messages count).
_IRREGULAR = {"degree of freedom": "degrees of freedom", "entry": "entries", "branch": "branches",
              "mass": "masses", "axis": "axes", "vertex": "vertices", "matrix": "matrices", "index": "indices",
              "dof": "dofs", "q-point": "q-points", "species": "species"}


def plural(noun: str, n: float = 2) -> str:
    """`noun` as it reads after the number `n`: singular for exactly 1, plural otherwise.

    >>> plural("atom", 1), plural("atom", 3), plural("branch", 0), plural("frozen degree of freedom", 2)
    ('atom', 'atoms', 'branches', 'frozen degrees of freedom')
    """
    if n == 1:
        return noun
    for singular, many in _IRREGULAR.items():  # also at the end of a phrase: "frozen degree of freedom"
        if noun == singular or noun.endswith(" " + singular):
            return noun[: len(noun) - len(singular)] + many
    return noun + "s"


def counted(n: float, noun: str, *, thousands: bool = False) -> str:
    """``"1 atom"``, ``"3 atoms"``, ``"1,024 points"`` (`thousands`): a number and its noun, agreeing.

    >>> counted(1, "atom"), counted(2, "scene"), counted(4096, "point", thousands=True), counted(1, "entry")
    ('1 atom', '2 scenes', '4,096 points', '1 entry')
    """
    number = f"{n:,}" if thousands else f"{n}"
    return f"{number} {plural(noun, n)}"
