"""A `Scene` -> a `Plan`: the list of steps that compute exactly what the scene asks.

docs/architecture.md, "Model only what a scene requires": the plan solves only the degrees of freedom
the scene models (the axial CO2 scene solves 3), passes ``n_modes`` / ``band`` to the
solver (a partial solver for "the lowest 10 modes of 10^6 sites"), computes shapes only
when a drawing needs them (``vectors=False`` otherwise), and imports ASE/phonopy only in
the cross-check step. `execute` runs the steps in order and records, per step, what was
computed, by which solver, its accuracy figure and its wall time.

- `vibra.pipeline.plan.model`: `Step`, `Plan`, `StepRecord`, `PlanResult`, `make_plan`.
- `vibra.pipeline.plan.build`: `build_system` (builders from the fixed table `BUILD_FUNCTIONS`;
  nothing from a scene file is imported or executed).
- `vibra.pipeline.plan.analysis`: what drawings need computed (symmetry and IR hints, dispersion).
- `vibra.pipeline.plan.checks`: `check_plan` (what validate checks on the built system) and
  `step_error` (a failing step -> a `SceneError` at the scene key that controls it).
- `vibra.pipeline.plan.steps`: `execute` and the step functions.
"""

from __future__ import annotations

from vibra.pipeline.plan.build import build_system
from vibra.pipeline.plan.checks import REFUSALS, check_plan, cost_summary, step_error, validate
from vibra.pipeline.plan.model import Plan, PlanResult, Step, StepRecord, make_plan
from vibra.pipeline.plan.steps import execute, frequency_lines
from vibra.pipeline.scene import BUILD_FUNCTIONS

__all__ = ["Step", "Plan", "StepRecord", "PlanResult", "make_plan", "execute", "BUILD_FUNCTIONS",
           "build_system", "frequency_lines", "check_plan", "step_error", "validate", "REFUSALS",
           "cost_summary"]
