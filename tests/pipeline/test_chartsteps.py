"""The modes plan's charts declared once (issue 43 item 3): a `ChartStep` in
`vibra.pipeline.plan.chartsteps` and its ``[draw]`` key on `DrawSpec`; the plan, the step table,
the step keys and the schema all read those two declarations."""

from __future__ import annotations

from pathlib import Path

import pytest

from vibra.pipeline.plan.chartsteps import CHART_STEP_KEYS, CHART_STEPS, chart_steps
from vibra.pipeline.plan.checks import STEP_KEYS
from vibra.pipeline.plan.model import modes_plan
from vibra.pipeline.plan.steps import STEPS
from vibra.pipeline.scene import Scene, SceneError, load_scene
from vibra.pipeline.scene.specs import DrawSpec

ROOT = Path(__file__).resolve().parents[2]


def test_every_chart_key_has_its_chart_and_every_chart_is_run() -> None:
    keys = DrawSpec.chart_keys()
    by_key = {chart.key: chart for chart in CHART_STEPS}
    assert len(by_key) == len(CHART_STEPS), "two charts share a key"
    for key in keys:  # a [draw] chart key asks for the chart of its name
        assert key in by_key and by_key[key].wanted is None, key
    for chart in CHART_STEPS:  # a chart no key of its name asks for says who does
        assert chart.key in keys or chart.wanted is not None, chart.key
        assert chart.step in STEPS and STEP_KEYS[chart.step] == CHART_STEP_KEYS[chart.step]


#: Each bundled scene's steps as the plan built them before the charts were declared in one table
#: (main at 5538503, the same for every variant of the bundled scenes' [draw] keys): a regression guard.
PLANS = {
    "networks/ubiquitin/ubiquitin-anm.toml": ("build", "modes", "fluctuations", "render-modes", "chart-spectrum",
                                              "chart-bfactors", "chart-correlations"),
    "chains/continuum-limit.toml": ("build", "modes", "continuum", "render-modes", "chart-convergence"),
    "chains/forced-damped.toml": ("build", "modes", "response", "chart-spectrum", "chart-response"),
    "chains/diatomic.toml": ("build", "modes", "dispersion", "render-modes", "chart-spectrum", "chart-dispersion"),
    "molecules/h2o.toml": ("build", "modes", "symmetry", "structure", "render-modes", "chart-spectrum"),
    "molecules/h2o-hf.toml": ("build", "electronic", "modes", "symmetry", "structure", "render-modes", "chart-spectrum",
                              "chart-experiment"),
}


@pytest.mark.parametrize("scene_file", sorted(PLANS))
def test_the_plan_draws_the_charts_asked_in_the_tables_order(scene_file: str) -> None:
    scene = load_scene(ROOT / scene_file)
    names = modes_plan(scene).step_names
    if scene_file == "molecules/h2o-hf.toml" and names == ("build", "engine-missing"):
        pytest.skip("PySCF is not installed: the scene plans engine-missing alone")
    assert names == PLANS[scene_file]
    assert [name for name in names if name.startswith("chart-")] == [name for name, _ in chart_steps(scene)]


def test_a_chart_key_of_another_kind_is_refused_by_its_declared_purpose() -> None:
    restricted = {key: chart for key, chart in DrawSpec.chart_keys().items() if chart.kinds is not None}
    assert set(restricted) == {"bfactors"}
    data = {"kind": "chain", "system": {"builder": "linear_chain", "n": 5}, "draw": {"bfactors": True}}
    with pytest.raises(SceneError) as error:
        Scene.from_dict(data, source="probe.toml")
    assert error.value.key == "draw.bfactors"  # the refusal's words as they were before the table
    assert error.value.problem == ("compares predicted and crystallographic B-factors of a network scene, "
                                   "not of a 'chain' scene")
