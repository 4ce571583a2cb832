"""The scene schema's builder signatures, read from the cache (`builder_signature`, issue 45 item 1).

Truth: `inspect.signature` of the builders themselves, in this process, against what a fresh
interpreter reads back from the cache file another one wrote; and `sys.modules`: a scene refused
for a misspelt key, once the signatures are cached, is answered without importing numpy (the
start-up it saves is a benchmark's figure, `benchmarks/bench_startup.py`, not a test's).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from vibra._core.cache import _tuples
from vibra.pipeline.scene import builders
from vibra.pipeline.scene.builders import BUILD_FUNCTIONS, builder_fields

ROOT = Path(__file__).parents[2]

#: Every builder's signature as the schema reads it (`builder_signature`: derived, or from the cache file).
_PRINT_SIGNATURES = ("from vibra.pipeline.scene.builders import BUILD_FUNCTIONS, builder_signature; "
                     "print(repr({b: dict(builder_signature(b)) for b in BUILD_FUNCTIONS}))")


def test_every_builder_reads_back_as_its_signature_says(tmp_path: Path) -> None:
    runs = [subprocess.run([sys.executable, "-c", _PRINT_SIGNATURES], capture_output=True, text=True, timeout=300,
                           check=False, cwd=ROOT, env=dict(os.environ, VIBRA_CACHE_DIR=str(tmp_path)))
            for _ in range(2)]  # the first derives and writes, the second reads the file
    assert all(run.returncode == 0 for run in runs), runs[0].stderr + runs[1].stderr
    (stored,) = (tmp_path / "derived").glob("*.json")
    assert {f"scene builder signature {b}" for b in BUILD_FUNCTIONS} <= set(json.loads(stored.read_text()))
    # inspect.signature in this process, lists as tuples (as `builder_fields` has always read a default)
    here = {b: {key: _tuples(value) for key, value in builders._signature(b).items()} for b in BUILD_FUNCTIONS}
    assert runs[0].stdout.strip() == runs[1].stdout.strip() == repr(here)
    assert ("masses", False, (1.0, 2.0)) in here["diatomic_chain"]["scene"]  # a tuple default stays a tuple
    assert builder_fields("diatomic_chain")["masses"].default == (1.0, 2.0)


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
