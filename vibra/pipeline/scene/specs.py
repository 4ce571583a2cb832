"""The frozen values a scene is made of, and `SceneError`."""

from __future__ import annotations

import re
from dataclasses import dataclass, field, fields
from typing import Any, Callable, Mapping, Sequence

from vibra.pipeline.scene.values import Fail, brief
from vibra._core.unit_names import UNIT_NAMES, UNITS_EXPECTED, canonical_unit_name

__all__ = ["SceneError", "UNITS", "units_name", "SAFE_NAME", "SystemSpec", "ResponseSpec",
           "ContinuumSpec", "ComputeSpec", "ChartKey", "chart_key", "DrawSpec", "CrystalSpec", "FREQUENCY_UNITS"]

#: How a crystal scene labels its frequency axis (``draw.frequency_unit``).
FREQUENCY_UNITS = ("THz", "cm^-1")

UNITS = UNIT_NAMES  # a scene's units key is read by `units_name`, as `vibra.units.unit_system` reads it
#: A scene name: letters, digits and ``_ . -`` (output files are ``<name>_<what>.png``).
SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


def units_name(value: Any, fail: Fail) -> str:
    """A scene's ``units`` as `vibra.units.unit_system` reads it (any capitalisation), in vibra's spelling.

    >>> units_name("si", print), units_name("Dimensionless", print)
    ('SI', 'dimensionless')
    """
    try:
        return canonical_unit_name(value) if isinstance(value, str) else fail(f"is {brief(value)}; {UNITS_EXPECTED}")
    except ValueError:
        return fail(f"is {brief(value)}; {UNITS_EXPECTED}")


class SceneError(ValueError):
    """A scene file that cannot be used; the message reads ``file: key.path: problem``.

    One error may carry several problems of the same scene (`SceneError.combine`: what
    `Scene.from_dict` finds in every key of every section): `errors` lists them, each a
    `SceneError` of its own, and the message is their lines, one per problem. `key` and
    `problem` are then the first one's.

    Attributes
    ----------
    source : str
        The scene file (or the name a table was given).
    key : str
        The dotted key path of the (first) problem; ``""`` for the file as a whole.
    problem : str
        What is wrong at `key` and what is expected.
    errors : tuple of SceneError
        Every problem, in the order found (``(self,)`` for a single one).
    """

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source = source
        self.key = key
        self.problem = message
        self._problems: tuple[SceneError, ...] = ()  # several: one single error each
        where = f"{key}: " if key else ""
        super().__init__(f"{source}: {where}{message}")

    @property
    def errors(self) -> tuple[SceneError, ...]:
        return self._problems or (self,)

    @classmethod
    def combine(cls, errors: Sequence[SceneError]) -> SceneError:
        """One error carrying `errors` (flattened, repeats dropped): the first itself when it is alone."""
        parts: list[tuple[str, str, str]] = []
        for error in errors:
            for one in error.errors:
                if (one.source, one.key, one.problem) not in parts:
                    parts.append((one.source, one.key, one.problem))
        if not parts:
            raise ValueError("SceneError.combine needs at least one error")
        if len(parts) == 1 and len(errors) == 1 and not errors[0]._problems:
            return errors[0]
        singles = [SceneError(*part) for part in parts]
        combined = cls(*parts[0])
        combined._problems = tuple(singles)
        combined.args = ("\n".join(str(single) for single in singles),)
        return combined

    # pickles with every problem (a Dask worker's error)
    def __reduce__(self) -> tuple[Callable[..., SceneError], tuple[tuple[tuple[str, str, str], ...]]]:
        return (_rebuild_scene_error, (tuple((e.source, e.key, e.problem) for e in self.errors),))


def _rebuild_scene_error(parts: tuple[tuple[str, str, str], ...]) -> SceneError:
    return SceneError.combine([SceneError(*part) for part in parts])


@dataclass(frozen=True)
class SystemSpec:
    """What system a scene builds.

    Attributes
    ----------
    builder : str
        A key of `BUILDERS`.
    parameters : Mapping[str, Any]
        Read-only builder parameters with defaults filled in (lists as tuples), in the
        scene's units.
    """

    builder: str
    parameters: Mapping[str, Any]


@dataclass(frozen=True)
class ResponseSpec:
    """A forced-damped response over a frequency range (``[compute.response]``).

    Attributes
    ----------
    omega_min, omega_max : float
        Angular-frequency range, in rad per time unit of the scene's units.
    n_points : int
        Number of frequencies, spaced linearly.
    alpha : float
        Mass-proportional damping C = alpha M + beta K, in 1 / time unit (Kneller, Mécanique analytique, §2.6: eta).
    beta : float
        Stiffness-proportional damping, in time units.
    force_site : int
        Degree of freedom driven by a unit harmonic force.
    method : str
        ``"direct"`` or ``"modal"``.
    n_modes : int or None
        Modes kept by the modal method (all when None).
    """

    omega_min: float
    omega_max: float
    n_points: int = 400
    alpha: float = 0.0
    beta: float = 0.0
    force_site: int = 0
    method: str = "direct"
    n_modes: int | None = None


@dataclass(frozen=True)
class ContinuumSpec:
    """The continuum-limit comparison (``[compute.continuum]``).

    Attributes
    ----------
    modes : tuple of int
        Mode numbers k (1-based, lowest non-zero modes) compared with the wave equation.
    sizes : tuple of int
        Chain lengths N, at fixed total length.
    ends : str
        ``"free"``, ``"fixed"`` or ``"periodic"``.
    """

    modes: tuple[int, ...] = (1, 2, 3)
    sizes: tuple[int, ...] = (8, 16, 32, 64, 128, 256)
    ends: str = "free"


@dataclass(frozen=True)
class ComputeSpec:
    """What a scene computes (``[compute]``).

    Attributes
    ----------
    n_modes : int or None
        Number of lowest modes (a partial solver); all when None and `band` is None.
    band : (float, float) or None
        Only modes with omega in [low, high], in rad per time unit of the scene's units.
    shapes : bool
        Compute mode shapes even when nothing drawn needs them.
    accuracy : str
        ``"high"``, ``"fast"`` or ``"certified"`` (`vibra.System.modes`).
    solver : str
        ``"auto"`` or a solver path of `vibra.normal_modes`.
    response : ResponseSpec or None
    continuum : ContinuumSpec or None
    crosscheck : bool
        Compare against ASE and phonopy (molecules only).
    memory_limit_gib : float or None
        Largest memory estimate (`vibra.pipeline.scene.limits`) the scene may reach, in GiB; None:
        half of the machine's physical memory.
    time_limit_s : float or None
        Longest estimated all-modes solve (O(N^2) work) the scene may ask for, in s; None:
        `vibra.pipeline.scene.limits.DEFAULT_TIME_LIMIT_S` (600 s).
    """

    n_modes: int | None = None
    band: tuple[float, float] | None = None
    shapes: bool = False
    accuracy: str = "high"
    solver: str = "auto"
    response: ResponseSpec | None = None
    continuum: ContinuumSpec | None = None
    crosscheck: bool = False
    memory_limit_gib: float | None = None
    time_limit_s: float | None = None


@dataclass(frozen=True)
class ChartKey:
    """What the scene schema knows of a ``[draw]`` key that asks for a chart (`chart_key`).

    Attributes
    ----------
    kinds : tuple of str or None
        The scene kinds it applies to (None: every kind on the modes plan that does not refuse it).
    purpose : str
        What the chart shows, as the refusal for another kind begins ("compares ... of a network
        scene"; the refusal ends "not of a 'chain' scene").
    """

    kinds: tuple[str, ...] | None = None
    purpose: str = ""


def chart_key(*, kinds: tuple[str, ...] | None = None, purpose: str = "") -> Any:
    """A `DrawSpec` field that asks for a chart: a boolean ``[draw]`` key, False by default, whose
    `ChartKey` the scene schema reads (`parse_draw` its checker, `check_combinations` its kinds).
    The chart it asks for is declared in `vibra.pipeline.plan.chartsteps` under the same name."""
    return field(default=False, metadata={"chart": ChartKey(kinds, purpose)})


@dataclass(frozen=True)
class DrawSpec:
    """What a scene draws (``[draw]``).

    Attributes
    ----------
    modes : bool
        Render mode shapes off-screen with pyvista (atoms and bonds, or a row of masses).
    n_draw : int
        How many modes to draw (the lowest non-zero ones).
    spectrum : bool
        Stick spectrum chart of the frequencies.
    dispersion : bool
        Dispersion chart with the chain's modes on top (chains).
    response : bool
        Response chart (needs ``[compute.response]``, or an oscillator scene).
    convergence : bool
        Continuum-convergence chart (needs ``[compute.continuum]``).
    gif : bool
        Animated GIF of the lowest drawn mode.
    bfactors : bool
        Predicted against crystallographic B-factors (network scenes).
    window_size : (int, int)
        Size of rendered images in pixels (width, height).
    """

    modes: bool = False
    n_draw: int = 6
    spectrum: bool = chart_key()
    dispersion: bool = chart_key()
    response: bool = chart_key()
    convergence: bool = chart_key()
    gif: bool = False
    bfactors: bool = chart_key(kinds=("network",), purpose="compares predicted and crystallographic B-factors of a "
                               "network scene")
    window_size: tuple[int, int] = (1024, 640)

    @classmethod
    def chart_keys(cls) -> dict[str, ChartKey]:
        """The keys that ask for a chart (`chart_key`), in field order."""
        return {f.name: f.metadata["chart"] for f in fields(cls) if "chart" in f.metadata}

    @property
    def needs_shapes(self) -> bool:
        """True when a drawing needs mode shapes."""
        return self.modes or self.gif


@dataclass(frozen=True)
class CrystalSpec:
    """What a crystal scene computes and draws (its ``[compute]`` and ``[draw]`` tables).

    Attributes
    ----------
    path : tuple of tuple of str, or None
        Runs of special-point labels (a new run after a break); None: SeeK-path's path.
    npoints : int
        q-points along the whole path.
    mesh : (int, int, int)
        Gamma-centred mesh of the DOS and the thermal properties.
    dos_method : str
        ``"tetrahedron"`` or ``"gaussian"``.
    temperatures : (float, float)
        Range of the thermal properties, in K.
    n_temperatures : int
        Temperatures in that range, evenly spaced.
    bands : bool
        Draw the band structure with the DOS beside it.
    frequency_unit : str
        ``"THz"`` or ``"cm^-1"``.
    thermal : bool
        Draw free energy, entropy and heat capacity against T.
    mode : bool
        Render one mode on a supercell (a GIF).
    mode_q : str or (float, float, float)
        The mode's wave vector: a label of the path's special points, or fractional coordinates.
    mode_branch : int
        The mode's branch, 0 = lowest.
    supercell : (int, int, int)
        Cells drawn along each lattice vector.
    frames : int
        Frames of the GIF (one period).
    """

    path: tuple[tuple[str, ...], ...] | None = None
    npoints: int = 300
    mesh: tuple[int, int, int] = (16, 16, 16)
    dos_method: str = "tetrahedron"
    temperatures: tuple[float, float] = (0.0, 1000.0)
    n_temperatures: int = 101
    bands: bool = True
    frequency_unit: str = "THz"
    thermal: bool = False
    mode: bool = False
    mode_q: Any = "X"
    mode_branch: int = 0
    supercell: tuple[int, int, int] = (4, 4, 4)
    frames: int = 24
