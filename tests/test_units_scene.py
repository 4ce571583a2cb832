"""Scene files and the library read unit names the same way (issue 48, item 6).

Truth: `vibra.units.unit_system` is the library's reader; the scene's ``units`` key must accept
exactly the spellings it accepts (every capitalisation of 'SI', 'ASE' and 'dimensionless') and
refuse the ones it refuses, with one message naming the accepted spellings.
"""

from __future__ import annotations

import itertools

import pytest

from vibra.pipeline.scene import Scene, SceneError
from vibra.units import UNIT_NAMES, UNITS_EXPECTED, unit_system


def _spellings(word: str) -> list[str]:
    """Every capitalisation of `word` (2**len(word) of them; 'dimensionless' has 8192)."""
    return ["".join(letters) for letters in itertools.product(*((c.lower(), c.upper()) for c in word))]


def _scene(units: object) -> Scene:
    return Scene.from_dict({"kind": "chain", "units": units,
                            "system": {"builder": "linear_chain", "n": 3, "mass": 1.0, "stiffness": 1.0}},
                           source="units.toml")


def _library(units: object) -> str | None:
    try:
        return unit_system(units).name  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None


def _scene_units(units: object) -> str | None:
    try:
        return _scene(units).units
    except SceneError:
        return None


ACCEPTED = [s for name in ("SI", "ASE") for s in _spellings(name)] + ["dimensionless", "DIMENSIONLESS", "Dimensionless",
                                                                      "dImEnSiOnLeSs"]
REFUSED = ["cgs", "S I", " SI", "SI ", "ase-units", "dimension-less", "", "Å", "si\n", 3, 1.0, None, ["SI"], True]


@pytest.mark.parametrize("units", ACCEPTED + REFUSED)
def test_scene_accepts_exactly_what_the_library_accepts(units: object) -> None:
    assert _scene_units(units) == _library(units)


def test_every_capitalisation_of_dimensionless_agrees() -> None:
    spellings = _spellings("dimensionless")
    assert {_library(s) for s in spellings} == {"dimensionless"}
    # building a scene per spelling is slow-ish; the reader the scene uses is checked on all of them
    from vibra.pipeline.scene.specs import units_name

    assert {units_name(s, pytest.fail) for s in spellings} == {"dimensionless"}


def test_the_scene_keeps_vibras_spelling() -> None:
    assert [_scene(name.lower()).units for name in UNIT_NAMES] == list(UNIT_NAMES)


@pytest.mark.parametrize("units", ["cgs", 3])
def test_both_refusals_name_the_accepted_spellings(units: object) -> None:
    with pytest.raises(SceneError, match=r"units\.toml: units: is .*; expected one of 'SI', 'ASE', 'dimensionless' "
                                         r"\(in any capitalisation\)"):
        _scene(units)
    error = ValueError if isinstance(units, str) else TypeError
    with pytest.raises(error) as caught:
        unit_system(units)  # type: ignore[arg-type]
    assert isinstance(units, int) or UNITS_EXPECTED in str(caught.value)
