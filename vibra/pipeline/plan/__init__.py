"""A `Scene` -> a `Plan`: the list of steps that compute exactly what the scene asks.

docs/architecture.md, "Model only what a scene requires": the plan solves only the degrees of freedom
the scene models (the axial CO2 scene solves 3), passes ``n_modes`` / ``band`` to the
solver (a partial solver for "the lowest 10 modes of 10^6 sites"), computes shapes only
when a drawing needs them (``vectors=False`` otherwise), and imports ASE/phonopy only in
the cross-check step. `execute` runs the steps in order and records, per step, what was
computed, by which solver, its accuracy figure and its wall time.

- `vibra.pipeline.plan.model`: `Step`, `Plan`, `StepRecord`, `PlanResult`, `PlanKind`, `modes_plan`.
- `vibra.pipeline.plan.kinds`: `PLAN_KINDS` (what each scene kind computes), `make_plan`, `check_plan`,
  `validate`, `cost_summary`; the crystal and dynamics kinds in `crystal` and `dynamics`.
- `vibra.pipeline.plan.build`: `build_system` (builders from the fixed table `BUILD_FUNCTIONS`;
  nothing from a scene file is imported or executed).
- `vibra.pipeline.plan.analysis`: what drawings need computed (symmetry and IR hints, dispersion).
- `vibra.pipeline.plan.chartsteps`: the modes plan's charts, one `ChartStep` each (when a scene
  wants it, what it draws, the function that draws it).
- `vibra.pipeline.plan.checks`: `check_modes_plan` (what validate checks on a modes scene's built
  system) and `step_error` (a failing step -> a `SceneError` at the scene key that controls it).
- `vibra.pipeline.plan.steps`: `execute` and the step functions.
"""

from __future__ import annotations

from vibra.pipeline.plan.build import build_system
from vibra.pipeline.plan.checks import REFUSALS, step_error
from vibra.pipeline.plan.kinds import PLAN_KINDS, check_plan, cost_summary, make_plan, validate
from vibra.pipeline.plan.model import Plan, PlanKind, PlanResult, Step, StepRecord
from vibra.pipeline.plan.steps import execute, frequency_lines
from vibra.pipeline.scene import BUILD_FUNCTIONS

__all__ = ["Step", "Plan", "StepRecord", "PlanResult", "PlanKind", "PLAN_KINDS", "make_plan", "execute",
           "BUILD_FUNCTIONS",
           "build_system", "frequency_lines", "check_plan", "step_error", "validate", "REFUSALS",
           "cost_summary"]
