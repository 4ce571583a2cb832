"""Tests of `vibra/solvers/accuracy.py`, the one module that says what each accuracy level means
(issue 43, item 2): its readers take the levels, the 1e-10 target and the 600 s limit from it,
a function that offers fewer levels refuses the others with what they promise, and sweeps
and scene files take all three.

Truth: the documented values (docs/architecture.md, "Three accuracy levels") and object identity.
"""

from __future__ import annotations

import pytest

from vibra import solvers
from vibra.crystals.builders import fcc
from vibra.chains import linear_chain
from vibra.pipeline.scene import Scene
from vibra.pipeline.sweep import sweep
from vibra.solvers import accuracy


def test_the_levels_and_their_figures() -> None:
    assert accuracy.LEVELS == ("fast", "high", "certified") and accuracy.DEFAULT == "high"
    assert accuracy.HIGH_TARGET == 1e-10 and accuracy.CERTIFIED_TARGET == 1e-13
    assert accuracy.CERTIFIED_OVERESTIMATE == 1000.0 and accuracy.TIME_LIMIT_S == 600.0
    assert set(accuracy.PROMISES) == set(accuracy.LEVELS)
    assert [accuracy.uses_springs(level) for level in accuracy.LEVELS] == [False, True, True]


def test_the_readers_take_them_from_here() -> None:
    from vibra.crystals import dynamical
    from vibra.pipeline.scene import limits
    from vibra.solvers import budget
    from vibra.solvers.accurate import spring_ritz
    from vibra.solvers.accurate.ring import counted

    assert solvers.ACCURACY_LEVELS is accuracy.LEVELS and solvers.common.ACCURACY_LEVELS is accuracy.LEVELS
    assert budget.TIME_LIMIT_S == limits.DEFAULT_TIME_LIMIT_S == accuracy.TIME_LIMIT_S
    assert spring_ritz.TARGET == counted.AIM == dynamical.HIGH_RTOL == accuracy.HIGH_TARGET
    assert counted.HIGH_LEVELS[-1] == accuracy.HIGH_TARGET


def test_check_names_the_levels() -> None:
    assert accuracy.check("fast") == "fast"
    with pytest.raises(ValueError, match=r"accuracy is 'best'; expected one of 'fast', 'high', 'certified'"):
        accuracy.check("best")
    with pytest.raises(ValueError, match=r"compute\.accuracy is 'best'; expected one of 'fast', 'high'$"):
        accuracy.check("best", name="compute.accuracy", offered=("fast", "high"))


def test_phonons_refuse_certified_saying_what_it_promises() -> None:
    argon = fcc(1.0, 1.0, 2.0)
    assert argon.frequencies([[0.5, 0.0, 0.5]], accuracy="high").shape == (1, 3)
    with pytest.raises(ValueError, match=r"accuracy is 'certified' \(every bound a certificate, within 1000x the "
                                         r"true error or 1e-13 relative.*\), which phonons does not offer; "
                                         r"expected one of 'high', 'fast'"):
        argon.phonons([[0.5, 0.0, 0.5]], accuracy="certified")


def test_sweeps_take_the_three_levels_and_refuse_others_before_any_point() -> None:
    table = sweep(linear_chain, {"n": [3, 4]}, accuracy="certified")
    assert [row.omega.shape[0] for row in table.rows] == [3, 4]
    with pytest.raises(ValueError, match=r"accuracy is 'best'; expected one of 'fast', 'high', 'certified'"):
        sweep(linear_chain, {"n": [3, 4]}, accuracy="best")  # type: ignore[arg-type]


def test_scene_files_take_the_three_levels() -> None:
    table = {"kind": "chain", "system": {"builder": "linear_chain", "n": 4}}
    for level in accuracy.LEVELS:
        assert Scene.from_dict({**table, "compute": {"accuracy": level}}, source="c.toml").compute.accuracy == level
    assert Scene.from_dict(table, source="c.toml").compute.accuracy == accuracy.DEFAULT
