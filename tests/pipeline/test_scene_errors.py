"""Every problem of a scene at once: `Scene.from_dict` checks every key of every section before it
raises one `SceneError` carrying them all (`SceneError.errors`), and ``vibra validate`` prints a
FAIL line for each (issue 48, item 6)."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from vibra import cli
from vibra.pipeline.scene import Scene, SceneError, load_scene

ROOT = Path(__file__).resolve().parents[2]
THREE = ROOT / "tests" / "broken_scenes" / "three-problems.toml"
#: The three independent problems of THREE, in the order of its sections.
THREE_PROBLEMS = [("system.mass", "must be positive, got -1.0"),
                  ("compute.n_modes", "expected an integer, got a string ('six')"),
                  ("draw.modse", "unknown key; did you mean 'modes'?")]


def test_a_scene_with_three_problems_reports_all_three() -> None:
    with pytest.raises(SceneError) as info:
        load_scene(THREE)
    error = info.value
    assert [(e.key, e.problem.split(" (allowed")[0]) for e in error.errors] == THREE_PROBLEMS
    lines = str(error).splitlines()
    assert len(lines) == 3 and all(line.startswith(f"{THREE}: ") for line in lines)
    assert (error.source, error.key, error.problem) == (str(THREE), "system.mass", "must be positive, got -1.0")


def test_validate_prints_every_problem_in_a_fail_line_each(capsys: pytest.CaptureFixture[str]) -> None:
    code = cli.main(["validate", str(THREE), str(ROOT / "chains" / "mass-defect.toml")])
    out = capsys.readouterr().out
    assert code == cli.EXIT_FAILED
    fails = [line for line in out.splitlines() if line.startswith("FAIL ")]
    assert [line.split(": ", 2)[1] for line in fails] == [key for key, _ in THREE_PROBLEMS]
    for line, (key, problem) in zip(fails, THREE_PROBLEMS):
        assert line.startswith(f"FAIL {THREE}: {key}: {problem}")
    assert "ok   " in out and "2 scenes, 1 invalid" in out  # the other scene is still checked
    assert "Traceback" not in out


def test_the_sweep_command_lists_every_problem_in_a_line_each(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    code = cli.main(["sweep", str(THREE), "--vary", "system.n=3:4:2", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.splitlines()
    assert code == cli.EXIT_FAILED
    assert [line.split(": ")[2] for line in err] == [key for key, _ in THREE_PROBLEMS]
    assert all(line.startswith(f"vibra sweep: {THREE}: ") for line in err)


def chain(**sections: object) -> dict[str, object]:
    return {"kind": "chain", "system": {"builder": "linear_chain", "n": 4}, **sections}


@pytest.mark.parametrize("data, keys", [
    # the top level and every section: unknown keys, wrong types, out-of-range values
    ({**chain(), "colour": "red", "title": 3}, ["colour", "title"]),
    (chain(system={"builder": "linear_chain", "n": 4, "mass": "heavy", "stifness": 1.0, "ends": "loose"},
           compute={"accuracy": "perfect", "response": {"omega_min": -1.0, "omega_max": 2.0, "alpha": "x"}},
           draw={"n_draw": 0, "window_size": [10, 10]}),
     ["system.stifness", "system.mass", "system.ends", "compute.accuracy", "compute.response.omega_min",
      "compute.response.alpha", "draw.n_draw", "draw.window_size"]),
    # a dynamics scene: its [compute] and [draw] together
    ({"kind": "dynamics", "system": {"builder": "fput", "n": 4, "alpha": "x"},
      "compute": {"dt": 0.1, "n_steps": 10, "mode": 1, "tau": -1.0, "thermostat": "nose-hoover",
                  "temperature": 1.0},
      "draw": {"energies": 3, "mode_energies": True}},
     ["system.alpha", "compute.tau", "draw.energies"]),
])
def test_every_problem_of_every_section_is_listed(data, keys) -> None:
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data, source="many.toml")
    assert [e.key for e in info.value.errors] == keys
    assert len(str(info.value).splitlines()) == len(keys)


def test_a_bad_value_read_as_absent_is_not_reported_twice() -> None:
    # temperature = "hot" is refused; the thermostat's "temperature is required" would only echo it
    data = {"kind": "dynamics", "system": {"builder": "fput", "n": 4},
            "compute": {"dt": 0.1, "n_steps": 10, "mode": 1, "thermostat": "nose-hoover", "temperature": "hot"},
            "draw": {"energies": True}}
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data, source="d.toml")
    assert [(e.key, e.problem) for e in info.value.errors] == [
        ("compute.temperature", "expected a number, got a string ('hot')")]


def test_a_bad_kind_or_system_stops_the_scene_with_the_top_level_problems() -> None:
    with pytest.raises(SceneError) as info:
        Scene.from_dict({"kind": "liquid", "colour": 1, "system": {"builder": "x"}}, source="k.toml")
    assert [e.key for e in info.value.errors] == ["colour", "kind"]


def test_a_single_problem_is_a_plain_error_and_problems_survive_pickling() -> None:
    with pytest.raises(SceneError) as one:
        Scene.from_dict(chain(draw={"modse": True}), source="a.toml")
    assert one.value.errors == (one.value,) and "\n" not in str(one.value)
    with pytest.raises(SceneError) as many:
        load_scene(THREE)
    copy = pickle.loads(pickle.dumps(many.value))
    assert str(copy) == str(many.value) and [e.key for e in copy.errors] == [e.key for e in many.value.errors]


def test_combine_flattens_and_drops_repeats() -> None:
    a, b = SceneError("s.toml", "x", "bad"), SceneError("s.toml", "y", "worse")
    combined = SceneError.combine([a, SceneError.combine([a, b])])
    assert [e.key for e in combined.errors] == ["x", "y"]
    assert str(combined) == "s.toml: x: bad\ns.toml: y: worse"
    assert SceneError.combine([a]) is a
    with pytest.raises(ValueError, match="at least one error"):
        SceneError.combine([])
