"""The scene schema's builder signatures, read from the cache (`builder_signature`, issue 45 item 1).

Truth: `inspect.signature` of the builders themselves, in this process, against what a fresh
interpreter reads back from the cache file another one wrote; and `sys.modules`: a scene refused
for a misspelt key, once the signatures are cached, is answered without importing numpy (the
start-up it saves is a benchmark's figure, `benchmarks/bench_startup.py`, not a test's).
"""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vibra.pipeline.scene.builders import BUILD_FUNCTIONS, NOT_IN_SCENES, builder_function

ROOT = Path(__file__).parents[2]

#: Every builder's scene keys as the schema reads them: default (repr) and required.
_PRINT_FIELDS = ("import json; from vibra.pipeline.scene.builders import BUILD_FUNCTIONS, builder_fields; "
                 "print(json.dumps({b: {name: [repr(f.default), f.required] for name, f in builder_fields(b).items()} "
                 "for b in BUILD_FUNCTIONS}))")


def test_every_builder_reads_back_as_its_signature_says(tmp_path: Path) -> None:
    """The truth is `inspect.signature` of each builder in this process; the first interpreter derives the
    fields and writes the cache, the second reads them from the file."""
    runs = [subprocess.run([sys.executable, "-c", _PRINT_FIELDS], capture_output=True, text=True, timeout=300,
                           check=False, cwd=ROOT, env=dict(os.environ, VIBRA_CACHE_DIR=str(tmp_path)))
            for _ in range(2)]
    assert all(run.returncode == 0 for run in runs), runs[0].stderr + runs[1].stderr
    (stored,) = (tmp_path / "derived").glob("*.json")
    assert {f"scene builder signature {b}" for b in BUILD_FUNCTIONS} <= set(json.loads(stored.read_text()))
    assert runs[0].stdout == runs[1].stdout
    fields = json.loads(runs[1].stdout)
    variadic = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    for builder in BUILD_FUNCTIONS:
        for name, parameter in inspect.signature(builder_function(builder)).parameters.items():
            if name in NOT_IN_SCENES[builder] or parameter.kind in variadic:
                assert name not in fields[builder]
                continue
            empty = parameter.default is inspect.Parameter.empty
            default = None if empty else parameter.default
            assert fields[builder][name][0] == repr(tuple(default) if isinstance(default, list) else default), (builder, name)
            assert fields[builder][name][1] or not empty, (builder, name)
    assert fields["diatomic_chain"]["masses"] == ["(1.0, 2.0)", False]  # a tuple default stays a tuple


@pytest.mark.parametrize("scene, key", [("chains/monatomic-free.toml", "system"), ("crystals/argon-fcc.toml", "system"),
                                        ("molecules/co2.toml", "system"), ("dynamics/fput-alpha.toml", "compute"),
                                        ("networks/ubiquitin/ubiquitin-anm.toml", "system")])
def test_a_refused_scene_imports_no_numpy_once_cached(tmp_path: Path, scene: str, key: str) -> None:
    text = (ROOT / scene).read_text()
    broken = tmp_path / "broken.toml"
    broken.write_text(text.replace(f"[{key}]", f"[{key}]\nmisspelt_key = 1", 1))
    code = ("import sys\nfrom vibra import cli\ntry:\n    cli.main(['validate', sys.argv[1]])\nexcept SystemExit:\n    pass\n"
            "print('numpy' in sys.modules, 'scipy' in sys.modules)")
    cache = tmp_path / "cache"
    runs = [subprocess.run([sys.executable, "-c", code, str(broken)], capture_output=True, text=True, timeout=300,
                           check=False, cwd=ROOT, env=dict(os.environ, VIBRA_CACHE_DIR=str(cache))) for _ in range(2)]
    for run in runs:
        assert f"{key}.misspelt_key: unknown key" in run.stdout, run.stdout + run.stderr
    assert runs[1].stdout.split()[-2:] == ["False", "False"]
