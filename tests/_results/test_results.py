"""Results with one shape (issue 29, item 5): `Modes` and `QuadraticModes` share `path`,
``len``, indexing and slicing into a smaller result, a short repr, and a round trip through
`to_dict` / `from_dict` and a versioned ``.npz`` (`save` / `load`).

Truth: the result itself, field by field (a stored and reloaded result equals the original
bit for bit), and the closed form of the free chain for what a slice holds.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import vibra
from vibra import System, normal_modes
from vibra.modes import Modes
from vibra.solvers.structured.quadratic import QuadraticModes


def chain_modes(**kwargs: object) -> Modes:
    system = System.from_springs(np.arange(8, dtype=float), 1.0, np.c_[np.arange(7), np.arange(1, 8)], 1.0,
                                 units="SI")
    return system.modes(**kwargs)  # type: ignore[arg-type]


def charged() -> QuadraticModes:
    system = vibra.System.generalized(np.eye(2), np.eye(2), G=[[0.0, -1.0], [1.0, 0.0]])
    return system.quadratic_modes()


def same(a: object, b: object) -> None:
    assert type(a) is type(b)
    for field in dataclasses.fields(a):  # type: ignore[arg-type]
        x, y = getattr(a, field.name), getattr(b, field.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
            assert x.dtype == y.dtype
        else:
            assert x == y or (x != x and y != y), field.name  # (NaN residual without vectors)


@pytest.mark.parametrize("make", [chain_modes, lambda: chain_modes(vectors=False), charged])
def test_path_len_repr(make) -> None:  # type: ignore[no-untyped-def]
    result = make()
    assert result.path == (result.solver if isinstance(result, Modes) else result.method)
    assert len(result) == (result.omega.shape[0] if isinstance(result, Modes) else result.eigenvalues.shape[0])
    text = repr(result)
    assert text.startswith(type(result).__name__ + f"({len(result)} modes") and result.path in text
    assert len(text) < 200


def test_indexing_and_slicing_give_a_smaller_result_of_the_same_type() -> None:
    modes = chain_modes()
    exact = 2.0 * np.sin(np.arange(8) * np.pi / 16)  # free chain, m = kappa = 1 (seed 003 eq. 161)
    tail = modes[1:]
    assert isinstance(tail, Modes) and len(tail) == 7
    np.testing.assert_allclose(tail.omega, exact[1:], rtol=1e-12)
    assert tail.vectors.shape == (8, 7) and tail.shapes.shape == (8, 7)
    np.testing.assert_array_equal(tail.vectors, modes.vectors[:, 1:])
    one = modes[-1]
    assert len(one) == 1 and one.omega[0] == modes.omega[-1]
    picked = modes[[1, 3]]
    np.testing.assert_array_equal(picked.omega, modes.omega[[1, 3]])
    mask = modes[modes.omega > 1.0]
    assert np.all(mask.omega > 1.0) and len(mask) == int(np.sum(modes.omega > 1.0))
    with pytest.raises(IndexError, match="out of range"):
        modes[8]
    with pytest.raises(IndexError, match="mask"):
        modes[np.array([True, False])]
    with pytest.raises(dataclasses.FrozenInstanceError):
        tail.solver = "x"  # type: ignore[misc]
    assert not tail.omega.flags.writeable
    quadratic = charged()[1:]
    assert isinstance(quadratic, QuadraticModes) and len(quadratic) == len(charged()) - 1


@pytest.mark.parametrize("make", [chain_modes, lambda: chain_modes(vectors=False), charged])
def test_dict_and_npz_round_trips_are_exact(make, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    result = make()
    same(type(result).from_dict(result.to_dict()), result)
    path = result.save(tmp_path / "result.npz")
    same(type(result).load(path), result)
    assert [p.name for p in tmp_path.iterdir()] == ["result.npz"]  # nothing half-written left beside it


def test_storage_refuses_what_it_did_not_write(tmp_path: Path) -> None:
    modes = chain_modes()
    data = modes.to_dict()
    with pytest.raises(ValueError, match="format"):
        Modes.from_dict({**data, "format": 99})
    with pytest.raises(ValueError, match="type"):
        QuadraticModes.from_dict(data)
    with pytest.raises(ValueError, match="unknown keys"):
        Modes.from_dict({**data, "colour": "red"})
    with pytest.raises(ValueError, match=r"\.npz"):
        modes.save(tmp_path / "result.txt")
    np.savez(tmp_path / "other.npz", a=np.zeros(2))
    with pytest.raises(ValueError, match="not a vibra result"):
        Modes.load(tmp_path / "other.npz")


def test_a_slice_of_a_spring_system_keeps_its_units_and_figures() -> None:
    modes = normal_modes(np.diag([1.0, 2.0, 3.0]), np.ones(3), units="SI")[1:]
    assert modes.units.name == "SI" and modes.frequencies_hz().shape == (2,)
