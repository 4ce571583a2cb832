"""The source documents vibra's physics is checked against, named once.

The course notes and the article below give the equations that the tests use as oracles. Code,
docs and reports cite them by ``cite(key)`` ("G. R. Kneller, *Mécanique analytique*") and an
equation or section number, never by an opaque file number.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Source", "SOURCES", "cite"]


@dataclass(frozen=True)
class Source:
    key: str
    author: str
    title: str
    published: str
    year: str
    about: str

    def short(self) -> str:
        """'Kneller, Mécanique analytique'."""
        return f"{self.author.split()[-1]}, {self.title}"

    def full(self) -> str:
        """One line for a references list: author, title, where, year."""
        year = f", {self.year}" if self.year else ""
        return f"{self.author}, {self.title}. {self.published}{year}."


SOURCES: dict[str, Source] = {s.key: s for s in (
    Source("000", "Jules Vieille",
           "Sur les équations différentielles de la dynamique réduites au plus petit nombre "
           "possible de variables",
           "Journal de mathématiques pures et appliquées, 1re série, tome 14, p. 201-224 "
           "(numdam JMPA_1849_1_14__201_0)", "1849",
           "generalised coordinates; the double pendulum"),
    Source("003", "Gerald R. Kneller", "Mécanique analytique",
           "Course notes, Université d'Orléans and Centre de Biophysique Moléculaire (CNRS), "
           "Orléans", "",
           "Lagrange and Hamilton mechanics; small oscillations and normal modes (eqs. 133-151); "
           "the forced damped oscillator (eqs. 120-123); the linear chain and its continuum "
           "limit (section 5.3, eqs. 162-165); Gauss's principle and the isokinetic "
           "thermostat (section 4.2, example 10)"),
    Source("004", "Mourad Bentahar", "Mécanique générale",
           "Course notes, Université du Maine, Le Mans", "",
           "rigid bodies, kinematics and the general mechanics of systems"),
)}


def cite(key: str) -> str:
    """The short name of a source: ``cite("003")`` -> 'Kneller, Mécanique analytique'."""
    try:
        return SOURCES[key].short()
    except KeyError:
        raise KeyError(f"no source {key!r}; expected one of {sorted(SOURCES)}") from None
