"""What each scene kind computes: one `PlanKind` per kind, in `PLAN_KINDS`, and what reads them.

A kind is declared twice, once per layer, and nowhere else: what its scene file may say in
`vibra.pipeline.scene.kinds` (`SceneKind`: units, tables, report heading), and what it computes
here (`PlanKind`: its plan, its checks, the line ``vibra validate`` prints, its own step functions
and their scene keys). The kinds whose result is one set of normal modes share `modes_plan`,
`check_modes_plan` and `modes_summary`; a kind with its own steps declares them in its own module
(`vibra.pipeline.plan.crystal.KIND`, `vibra.pipeline.plan.dynamics.KIND`). `make_plan`,
`check_plan`, `validate`, `cost_summary` and `build_note` look the scene's kind up here instead of
branching on its name (docs/architecture.md, "Scene kinds and builders").
"""

from __future__ import annotations

from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Mapping

from vibra._core.text import counted
from vibra.pipeline.plan.build import BuiltSystem, build_system
from vibra.pipeline.plan.checks import REFUSALS, check_modes_plan, modes_summary, step_error
from vibra.pipeline.plan.crystal import KIND as CRYSTAL
from vibra.pipeline.plan.dynamics import KIND as DYNAMICS
from vibra.pipeline.plan.electronic import ELECTRONIC_STEPS, engine_missing
from vibra.pipeline.plan.model import Plan, PlanKind, modes_plan
from vibra.pipeline.scene import SCENE_KINDS, Scene, SceneError

if TYPE_CHECKING:
    from vibra.generalized import GeneralizedSystem
    from vibra.response.oscillator import Oscillator
    from vibra.system import System

__all__ = ["PLAN_KINDS", "plan_kind", "make_plan", "check_plan", "validate", "cost_summary", "build_note"]


def _dofs(scene: Scene, system: System | GeneralizedSystem) -> str:
    return counted(system.n_dof, "degree of freedom")


def _no_check(scene: Scene, system: object, response: bool) -> None:
    """(an oscillator's closed forms refuse nothing that the scene schema let through)"""


def _oscillators(scene: Scene, system: tuple[Oscillator, ...]) -> str:
    return f"{counted(len(system), 'oscillator')}, closed forms"


def _no_note(scene: Scene, system: object) -> None:
    return None


def _modes_kind(name: str, **options: Any) -> PlanKind:
    """A kind whose result is one set of normal modes (`modes_plan`)."""
    return PlanKind(name, plan=modes_plan, check=check_modes_plan, summary=modes_summary, build_note=_dofs,
                    **options)


#: kind -> what it computes; the same kinds as `vibra.pipeline.scene.SCENE_KINDS`, in its order.
PLAN_KINDS: Mapping[str, PlanKind] = MappingProxyType({kind.name: kind for kind in (
    _modes_kind("chain", renders=True),
    _modes_kind("molecule", renders=True, steps=ELECTRONIC_STEPS),
    PlanKind("oscillator", plan=modes_plan, check=_no_check, summary=_oscillators, build_note=_no_note),
    _modes_kind("generalized"),
    _modes_kind("network", renders=True),
    CRYSTAL,
    DYNAMICS,
)})


def plan_kind(scene: Scene) -> PlanKind:
    """The declaration of what `scene`'s kind computes."""
    return PLAN_KINDS[scene.kind]


def make_plan(scene: Scene) -> Plan:
    """The steps that compute exactly what `scene` asks (no work is done here)."""
    return plan_kind(scene).plan(scene)


def check_plan(scene: Scene, system: BuiltSystem, *, response: bool = True) -> None:
    """Check, on the built `system`, what the plan's later steps would refuse (cheap checks only).

    Raises
    ------
    SceneError
        At the key that controls the refused step: for a modes scene a solver that cannot serve
        this system (``compute.solver``), or a response grid on a pole (``compute.response``;
        checked only when `response` is true); a crystal's path labels and supercell; a dynamics
        run's time step and initial state.
    """
    plan_kind(scene).check(scene, system, response)


def validate(scene: Scene) -> BuiltSystem:
    """What ``vibra validate`` runs on a scene: build its system and `check_plan`; return the system.

    Raises
    ------
    SceneError
        Whatever the builder or the checks refuse, at the key that controls it.
    """
    missing = engine_missing(scene) if scene.kind == "molecule" else None
    if missing is not None:  # (the report renders such a scene as a page saying what to install)
        raise SceneError(scene.source, "system.engine", str(missing))
    try:
        system = build_system(scene)
        check_plan(scene, system)
    except REFUSALS as error:
        raise step_error(scene, "build", error) from error
    return system


def cost_summary(scene: Scene, system: BuiltSystem) -> str:
    """What ``vibra validate`` prints of an accepted scene: its size and cost (`PlanKind.summary`)."""
    return plan_kind(scene).summary(scene, system)


def build_note(scene: Scene, system: BuiltSystem) -> str | None:
    """The build step's figure in the report (`PlanKind.build_note`)."""
    return plan_kind(scene).build_note(scene, system)


if set(PLAN_KINDS) != set(SCENE_KINDS):  # (a kind added to one layer only: say so at import, not mid-report)
    raise RuntimeError(f"scene kinds {sorted(set(SCENE_KINDS) ^ set(PLAN_KINDS))} are declared in only one of "
                       "vibra/pipeline/scene/kinds.py and vibra/pipeline/plan/kinds.py")
