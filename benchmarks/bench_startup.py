"""Start-up and first calls (issue 45, items 1 and 2): the first call as fast as the tenth.

Every figure is a fresh process (interpreter start, imports, exit), timed by the parent:

- imports: ``python -c "import numpy, scipy.sparse, scipy.linalg"`` (the floor: what vibra's
  own dependencies cost), ``python -c "import vibra"`` and ``vibra --help``; the contract:
  ``import vibra`` within 0.3 s of the floor;
- first call against a warm one, timed inside the child (the system built before either): the
  lowest 10 modes of a disordered chain of 2,000 sites at the default accuracy ("high";
  `corpus.chain(2_000, spread=1e3)`), and 26 modes of the 1,500-dof random network
  (`corpus.random_network(500)`) at "high" and at "fast"; warm = the best of the calls after
  the first (9 for the chain, 4 for a network);
- the first call of a tiny compiled kernel after ``import vibra`` (`count_kernels.walled_factor`
  on 3 sites): what loading numba and a kernel's cache costs a process, the figure behind
  `vibra.solvers.compiled.LOAD_SECONDS`.

Protocol (`_common`): one warm-up round (it also fills numba's on-disk caches and the bytecode
caches: PYTHONDONTWRITEBYTECODE is unset in the children), then 5 interleaved rounds, best of 5,
one BLAS thread (OPENBLAS_NUM_THREADS=1 in every child). ``--baseline DIR``
times a second checkout (a directory holding an earlier ``vibra/``, e.g. a ``git worktree``)
in the same rounds, each of its processes beside this checkout's, and reports new / old.

Usage::

    python benchmarks/bench_startup.py                      # results/startup.json
    python benchmarks/bench_startup.py --baseline /tmp/before
    python benchmarks/bench_startup.py --quick              # 1 round, results/quick/
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import Timing, format_ratio, ratio, write_json  # noqa: E402  (pins BLAS threads before numpy)

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
ROUNDS = 1 if "--quick" in sys.argv else 5
#: ``import vibra`` may cost at most this much more than numpy and scipy's own imports (issue 45).
IMPORT_BUDGET_S = 0.3

FLOOR = "import numpy, scipy.sparse, scipy.linalg"

#: Scenes ``vibra validate`` refuses (a misspelt key), timed as fresh processes against ``python -c pass``:
#: issue 45 asks each within 0.3 s of the interpreter's own start-up. The warm-up round fills the
#: cache of the builders' signatures (`vibra._core.cache`) that a refusal reads.
REFUSED = {"chain": ROOT / "tests" / "broken_scenes" / "typo-key.toml",
           "crystal": HERE / "results" / "refused-crystal.toml"}

#: The child that times a first call and the warm ones: argv = kind, accuracy, calls.
SOLVE = r"""
import json, sys, time
import numpy as np
import vibra
sys.path.append(BENCH)
from corpus import chain, random_network  # (after vibra: the checkout under test stays the one imported)
kind, accuracy, calls = sys.argv[1], sys.argv[2], int(sys.argv[3])
if kind == "chain":
    system, n_modes = chain(2_000, spread=1e3), 10
else:
    system, n_modes = random_network(500), 26
seconds, paths, numba = [], [], []
for _ in range(calls):
    start = time.perf_counter()
    modes = system.modes(n_modes, accuracy=accuracy)
    seconds.append(time.perf_counter() - start)
    paths.append(modes.solver)
    numba.append("numba" in sys.modules)
print(json.dumps({"seconds": seconds, "path": paths[0], "numba_after_first": numba[0], "vibra": vibra.__file__}))
"""

#: The child that times the first call of a tiny compiled kernel.
KERNEL = r"""
import json, sys, time
import numpy as np
import vibra
from vibra.solvers.accurate import count_kernels as kernel
a, b, tie = np.ones(3), np.ones(2), np.zeros(3)
start = time.perf_counter()
kernel.walled_factor(a, b, tie)
first = time.perf_counter() - start
start = time.perf_counter()
kernel.walled_factor(a, b, tie)
print(json.dumps({"first": first, "second": time.perf_counter() - start}))
"""


def _environment(checkout: Path | None) -> dict[str, str]:
    """One BLAS thread; bytecode cached (written in the warm-up round, read after), as for an
    installed package: without it every vibra module is compiled from source on every start
    (~0.13 s here), which no user pays but numpy's and scipy's imports never do."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    if checkout is not None:  # an earlier checkout: its vibra/ first on the path
        env["PYTHONPATH"] = os.pathsep.join([str(checkout), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return env


def _wall(command: list[str], env: dict[str, str], cwd: Path, *, refused: bool = False) -> Callable[[], float]:
    """A fresh process running `command` in `cwd`: its wall time, start to exit (`refused`: it must
    exit with status 1, as ``vibra validate`` on a broken scene does)."""
    def run() -> float:
        start = time.perf_counter()
        done = subprocess.run(command, env=env, cwd=cwd, check=not refused, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE if refused else None, text=True)
        if refused and done.returncode != 1:
            raise RuntimeError(f"{command} exited with {done.returncode}, not 1 (a refused scene): {done.stderr}")
        return time.perf_counter() - start
    return run


def _child(code: str, args: list[str], env: dict[str, str], cwd: Path) -> Callable[[], dict[str, Any]]:
    """A fresh process running `code` with `args` in `cwd`: the JSON it prints."""
    code = f"BENCH = {str(HERE)!r}\n" + code

    def run() -> dict[str, Any]:
        result = subprocess.run([sys.executable, "-c", code, *args], env=env, cwd=cwd, check=True,
                                capture_output=True, text=True)
        return dict(json.loads(result.stdout.strip().splitlines()[-1]))
    return run


def methods(checkout: Path | None) -> dict[str, Callable[[], Any]]:
    """Every measurement of one checkout (None: this one), by name. Each process starts in the
    checkout's directory (``python -c`` puts it first on the path: its vibra is imported)."""
    env = _environment(checkout)
    cwd = ROOT if checkout is None else checkout
    vibra = shutil.which("vibra", path=str(Path(sys.executable).parent)) if checkout is None else None
    command = [vibra] if vibra else [sys.executable, "-c", "import sys; from vibra.cli import main; sys.exit(main())"]
    return {
        "python -c pass": _wall([sys.executable, "-c", "pass"], env, cwd),
        "import numpy, scipy": _wall([sys.executable, "-c", FLOOR], env, cwd),
        "import vibra": _wall([sys.executable, "-c", "import vibra"], env, cwd),
        "vibra --help": _wall([*command, "--help"], env, cwd),
        **{f"refused scene: {name}": _wall([*command, "validate", str(path)], env, cwd, refused=True)
           for name, path in REFUSED.items()},
        "chain 2,000, high": _child(SOLVE, ["chain", "high", "10"], env, cwd),
        "network 1,500, high": _child(SOLVE, ["network", "high", "5"], env, cwd),
        "network 1,500, fast": _child(SOLVE, ["network", "fast", "5"], env, cwd),
        "compiled kernel": _child(KERNEL, [], env, cwd),
    }


def collect(plan: dict[str, Callable[[], Any]], rounds: int) -> dict[str, Timing]:
    """The protocol: one warm-up round, then `rounds` interleaved rounds; a child's first and warm
    calls become two series ("<name>: first", "<name>: warm")."""
    for run in plan.values():
        run()
    series: dict[str, list[float]] = {}
    last: dict[str, Any] = {}
    for _ in range(rounds):
        for name, run in plan.items():
            value = run()
            last[name] = value
            if isinstance(value, float):
                series.setdefault(name, []).append(value)
            elif "seconds" in value:
                series.setdefault(f"{name}: first", []).append(value["seconds"][0])
                series.setdefault(f"{name}: warm", []).append(min(value["seconds"][1:]))
            else:
                series.setdefault(f"{name}: first", []).append(value["first"])
    return {name: Timing(name, tuple(values), last.get(name.split(":")[0])) for name, values in series.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one round (results/quick/)")
    parser.add_argument("--baseline", type=Path, default=None,
                        help="an earlier checkout (a directory holding vibra/) timed in the same rounds")
    options = parser.parse_args()
    checkouts: dict[str, Path | None] = {"new": None}
    if options.baseline is not None:
        checkouts["old"] = options.baseline.resolve()
    plan: dict[str, Callable[[], Any]] = {}
    for name in methods(None):  # interleaved: each measurement of both checkouts side by side
        for label, checkout in checkouts.items():
            plan[f"{label} | {name}"] = methods(checkout)[name]
    REFUSED["crystal"].write_text((ROOT / "crystals" / "argon-fcc.toml").read_text().replace(
        "[system]", "[system]\nmisspelt_key = 1", 1))  # a crystal scene refused for a misspelt key
    try:
        timings = collect(plan, ROUNDS)
    finally:
        REFUSED["crystal"].unlink()

    payload: dict[str, Any] = {"checkouts": {k: str(v or ROOT) for k, v in checkouts.items()},
                               "import_budget_s": IMPORT_BUDGET_S, "figures": {}, "ratios": {}}
    for name, timing in timings.items():
        payload["figures"][name] = {**timing.summary(), **(
            {"path": timing.result["path"], "numba_after_first": timing.result["numba_after_first"],
             "vibra": timing.result["vibra"]}
            if isinstance(timing.result, dict) and "path" in timing.result else {})}
        extra = ""
        if isinstance(timing.result, dict) and "path" in timing.result:
            extra = (f"  {timing.result['path']}, numba after the first call: {timing.result['numba_after_first']}"
                     f" ({Path(timing.result['vibra']).parent.parent})")
        print(f"  {name:44s} best {timing.min:7.3f} s  median {timing.median:7.3f} s  max {timing.max:7.3f} s{extra}")

    def report(key: str, a: str, b: str) -> None:
        if a in timings and b in timings:
            r = ratio(timings[a], timings[b])
            r["difference_s"] = timings[a].min - timings[b].min
            payload["ratios"][key] = r
            print(f"  {key:58s} {format_ratio(r)}   ({r['difference_s']:+.3f} s)")

    print("ratios (best of each; per-round range):")
    for label in checkouts:
        floor = f"{label} | import numpy, scipy"
        report(f"{label}: import vibra / import numpy, scipy", f"{label} | import vibra", floor)
        report(f"{label}: vibra --help / import numpy, scipy", f"{label} | vibra --help", floor)
        for name in REFUSED:
            report(f"{label}: refused scene: {name} / python -c pass", f"{label} | refused scene: {name}",
                   f"{label} | python -c pass")
        for case in ("chain 2,000, high", "network 1,500, high", "network 1,500, fast"):
            report(f"{label}: {case}: first / warm", f"{label} | {case}: first", f"{label} | {case}: warm")
    if "old" in checkouts:
        for name in timings:
            if name.startswith("new | ") and name.replace("new | ", "old | ") in timings:
                short = name.removeprefix("new | ")
                report(f"new / old: {short}", name, name.replace("new | ", "old | "))
    budget = payload["ratios"].get("new: import vibra / import numpy, scipy", {}).get("difference_s")
    if budget is not None:
        verdict = "within" if budget <= IMPORT_BUDGET_S else "OVER"
        print(f"import vibra costs {budget:+.3f} s over numpy and scipy: {verdict} the {IMPORT_BUDGET_S} s budget")
    for name in REFUSED:
        over = payload["ratios"].get(f"new: refused scene: {name} / python -c pass", {}).get("difference_s")
        if over is not None:
            verdict = "within" if over <= IMPORT_BUDGET_S else "OVER"
            print(f"a refused {name} scene costs {over:+.3f} s over the interpreter: {verdict} the {IMPORT_BUDGET_S} s budget")
    print(f"wrote {write_json('startup', payload, rounds=ROUNDS)}")


if __name__ == "__main__":
    main()
