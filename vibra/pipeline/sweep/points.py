"""The points of a sweep: value ranges (`vary`, `ValueRange`), their Cartesian product (`grid`,
`Grid`, `GridPoints`) and ensembles (`ensemble`, `member_rng`); all lazy, a value computed when read.

Re-exported by `vibra.pipeline.sweep`, which runs them.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Literal, Mapping, Sequence, SupportsIndex

import numpy as np

__all__ = ["Axis", "vary", "parse_vary", "Grid", "grid", "Ensemble", "ensemble", "member_rng", "ValueRange",
           "GridPoints", "DEFAULT_MAX_POINTS"]

#: Points a sweep runs without ``max_points=`` (``--max-points``): 10^5 points of a
#: millisecond each take minutes; more is refused with the count and an estimate.
DEFAULT_MAX_POINTS = 100_000


class ValueRange(Sequence[float]):
    """`n` values from `start` to `stop`, linear or logarithmic, each computed when read.

    Value i is the one ``numpy.linspace`` (``numpy.geomspace``) gives: ``start + i * step``
    (``10 ** (log10(start) + i * step)``), with the ends exactly `start` and `stop`.
    """

    def __init__(self, start: float, stop: float, n: int, spacing: Literal["linear", "log"]) -> None:
        self.start, self.stop, self.n, self.spacing = float(start), float(stop), int(n), spacing
        if spacing == "log":
            self._low, self._high = float(np.log10(self.start)), float(np.log10(self.stop))
        else:
            self._low, self._high = self.start, self.stop
        self._step = (self._high - self._low) / (self.n - 1) if self.n > 1 else 0.0

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, index: SupportsIndex | slice) -> float | tuple[float, ...]:  # type: ignore[override]
        if isinstance(index, slice):
            return tuple(self[i] for i in range(*index.indices(self.n)))
        i = int(index)
        if i < 0:
            i += self.n
        if not 0 <= i < self.n:
            raise IndexError(f"index {index} out of range for {self.n} values")
        if i == 0:
            return self.start
        if i == self.n - 1:
            return self.stop
        value = np.float64(i) * np.float64(self._step) + np.float64(self._low)
        return float(np.power(10.0, value)) if self.spacing == "log" else float(value)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, ValueRange):
            return (self.start, self.stop, self.n, self.spacing) == (other.start, other.stop, other.n, other.spacing)
        if isinstance(other, (tuple, list)):
            return len(other) == self.n and all(a == b for a, b in zip(self, other))
        return NotImplemented

    def __hash__(self) -> int:
        return hash((self.start, self.stop, self.n, self.spacing))

    def __repr__(self) -> str:
        return f"ValueRange({self.start!r}, {self.stop!r}, {self.n}, {self.spacing!r})"


class GridPoints(Sequence[tuple[object, ...]]):
    """The Cartesian product of value sequences, the first varying slowest; point i computed when read."""

    def __init__(self, axes: Sequence[Sequence[object]]) -> None:
        self.axes = tuple(axes)
        self._size = math.prod(len(a) for a in self.axes)

    def __len__(self) -> int:
        return self._size

    def __getitem__(self, index: SupportsIndex | slice  # type: ignore[override]
                    ) -> tuple[object, ...] | tuple[tuple[object, ...], ...]:
        if isinstance(index, slice):
            return tuple(self[i] for i in range(*index.indices(self._size)))
        i = int(index)
        if i < 0:
            i += self._size
        if not 0 <= i < self._size:
            raise IndexError(f"point {index} out of range for {self._size} points")
        values = []
        for axis in reversed(self.axes):
            i, digit = divmod(i, len(axis))
            values.append(axis[digit])
        return tuple(reversed(values))

    def __iter__(self) -> Iterator[tuple[object, ...]]:
        return itertools.product(*self.axes)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, GridPoints):
            return self.axes == other.axes
        if isinstance(other, (tuple, list)):
            return len(other) == self._size and all(a == b for a, b in zip(self, other))
        return NotImplemented

    def __hash__(self) -> int:
        return hash(self.axes)

    def __repr__(self) -> str:
        return f"GridPoints({len(self)} points of {len(self.axes)} axes)"


# ---------------------------------------------------------------------- points
@dataclass(frozen=True)
class Axis:
    """One swept key and its values, in order.

    Attributes
    ----------
    key : str
        Dotted key of the scene (``system.defect_mass``), one value of a list in it
        (``system.stiffness[1]``, ``system.positions[2][0]``), or a builder's keyword.
    values : sequence of int or float
        The values, in the key's own unit (a tuple, or a lazy `ValueRange` from `vary`).
    """

    key: str
    values: Sequence[Any]


def vary(key: str, start: float, stop: float, n: int, *, spacing: Literal["linear", "log"] = "linear") -> Axis:
    """`n` values from `start` to `stop` (both included), evenly or logarithmically spaced.

    `key` is a dotted key of the scene (``system.defect_mass``), one value of a list
    (``system.stiffness[1]``: the scene must give the list, or its builder a default list),
    or a builder's keyword; `sweep` checks it against the scene.

    >>> vary("system.stiffness[1]", 1.0, 2.0, 3).values[1]
    1.5

    Raises
    ------
    ValueError
        An empty key, `n` < 1 (an empty range), `start` == `stop` with `n` > 1, non-finite
        bounds, or a non-positive bound with ``spacing="log"``.
    """
    if not isinstance(key, str) or not key.strip():
        raise ValueError(f"key is {key!r}; expected a dotted key such as 'system.defect_mass'")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"n must be an int, got {type(n).__name__}")
    if n < 1:
        raise ValueError(f"{key}: n is {n}; an empty range has nothing to sweep (expected n >= 1)")
    low, high = float(start), float(stop)
    if not (math.isfinite(low) and math.isfinite(high)):
        raise ValueError(f"{key}: start and stop must be finite, got {start!r} and {stop!r}")
    if n > 1 and low == high:
        raise ValueError(f"{key}: start and stop are both {low!r}; {n} points need start != stop")
    if spacing == "log":
        if low <= 0 or high <= 0:
            raise ValueError(f"{key}: log spacing needs positive start and stop, got {start!r} and {stop!r}")
    elif spacing != "linear":
        raise ValueError(f"spacing is {spacing!r}; expected 'linear' or 'log'")
    return Axis(key, ValueRange(low, high, int(n), spacing))  # lazy: nothing allocated for n values


def parse_vary(text: str) -> Axis:
    """An `Axis` from the command-line form ``KEY=START:STOP:N`` or ``KEY=log:START:STOP:N``.

    >>> parse_vary("system.stiffness[1]=50:150:5").key
    'system.stiffness[1]'

    Raises
    ------
    ValueError
        Malformed text (the message shows the expected form), or what `vary` refuses.
    """
    key, sep, spec = str(text).partition("=")
    form = "expected KEY=START:STOP:N or KEY=log:START:STOP:N, e.g. system.defect_mass=0.2:0.8:7"
    if not sep or not key.strip():
        raise ValueError(f"--vary {text!r}: {form}")
    parts = spec.split(":")
    spacing: Literal["linear", "log"] = "linear"
    if parts and parts[0] in ("log", "lin", "linear"):
        spacing = "log" if parts[0] == "log" else "linear"
        parts = parts[1:]
    if len(parts) != 3:
        raise ValueError(f"--vary {text!r}: {form}")
    try:
        start, stop = float(parts[0]), float(parts[1])
        n = int(parts[2])
    except ValueError:
        raise ValueError(f"--vary {text!r}: START and STOP must be numbers and N an integer; {form}") from None
    return vary(key.strip(), start, stop, n, spacing=spacing)


@dataclass(frozen=True)
class Grid:
    """The Cartesian product of axes: every combination, the first axis varying slowest.

    Attributes
    ----------
    keys : tuple of str
    points : sequence of tuple
        One value per key for each point (a lazy `GridPoints`: ``len`` is the count, point i
        is computed when read).
    """

    keys: tuple[str, ...]
    points: Sequence[tuple[Any, ...]]


def grid(*axes: Axis | Mapping[str, Sequence[float]]) -> Grid:
    """A `Grid` from `Axis` objects (`vary`) and/or mappings ``{key: values}``.

    Raises
    ------
    ValueError
        No axis, an axis without values, or a key given twice.
    """
    flat: list[Axis] = []
    for entry in axes:
        if isinstance(entry, Axis):
            flat.append(entry)
        elif isinstance(entry, Mapping):
            flat.extend(Axis(str(k), tuple(_scalar(k, v) for v in np.atleast_1d(np.asarray(values))))
                        for k, values in entry.items())
        else:
            raise TypeError(f"grid takes Axis objects or mappings {{key: values}}, got {type(entry).__name__}")
    if not flat:
        raise ValueError("grid needs at least one axis (a key and its values)")
    keys = [a.key for a in flat]
    for a in flat:
        if not a.values:
            raise ValueError(f"{a.key}: no values; an empty range has nothing to sweep")
        if keys.count(a.key) > 1:
            raise ValueError(f"{a.key}: the key is swept twice; give each key once")
    return Grid(tuple(keys), GridPoints([a.values for a in flat]))


def _scalar(key: str, value: Any) -> Any:
    """A grid value as a plain Python int or float (ints stay ints: builders take n as an int)."""
    item = value.item() if hasattr(value, "item") else value
    if isinstance(item, bool) or not isinstance(item, (int, float)) or not math.isfinite(item):
        raise ValueError(f"{key}: grid values must be finite numbers, got {value!r}")
    return item


@dataclass(frozen=True)
class Ensemble:
    """`n` random members drawn from `seed` (see `member_rng`).

    Attributes
    ----------
    seed : int
    n : int
    draw : callable or None
        ``draw(generator) -> {key: value}`` for a scene; None for a builder (it gets ``rng=``).
    """

    seed: int
    n: int
    draw: Callable[[np.random.Generator], Mapping[str, object]] | None = None


def ensemble(seed: int, n: int, draw: Callable[[np.random.Generator], Mapping[str, object]] | None = None) -> Ensemble:
    """An `Ensemble` of `n` members from `seed` (a non-negative integer)."""
    for name, value in (("seed", seed), ("n", n)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if seed < 0:
        raise ValueError(f"seed is {seed}; expected a non-negative integer")
    if n < 1:
        raise ValueError(f"n is {n}; an ensemble needs at least 1 member")
    if draw is not None and not callable(draw):
        raise TypeError(f"draw must be callable (generator -> {{key: value}}), got {type(draw).__name__}")
    return Ensemble(int(seed), int(n), draw)


def member_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of ensemble member `index`: the `index`-th child of ``SeedSequence(seed)``."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(index),)))
