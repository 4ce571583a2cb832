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


@pytest.mark.parametrize("scene_file", ["networks/ubiquitin/ubiquitin-anm.toml", "chains/continuum-limit.toml",
                                        "chains/forced-damped.toml", "chains/diatomic.toml", "molecules/h2o.toml",
                                        "molecules/h2o-hf.toml"])
def test_the_plan_draws_the_charts_asked_in_the_tables_order(scene_file: str) -> None:
    scene = load_scene(ROOT / scene_file)
    names = modes_plan(scene).step_names
    charts = [name for name in names if name.startswith("chart-")]
    assert charts == [name for name, _ in chart_steps(scene)]
    assert charts and names[-len(charts):] == tuple(charts)  # the charts come last
    order = [chart.step for chart in CHART_STEPS]
    assert charts == sorted(charts, key=order.index)


def test_a_chart_key_of_another_kind_is_refused_by_its_declared_purpose() -> None:
    restricted = {key: chart for key, chart in DrawSpec.chart_keys().items() if chart.kinds is not None}
    assert restricted, "no chart names its kinds: this test checks nothing"
    for key, chart in restricted.items():
        data = {"kind": "chain", "system": {"builder": "linear_chain", "n": 5}, "draw": {key: True}}
        assert "chain" not in chart.kinds
        with pytest.raises(SceneError) as error:
            Scene.from_dict(data, source="probe.toml")
        assert error.value.key == f"draw.{key}"
        assert error.value.problem == f"{chart.purpose}, not of a 'chain' scene"
