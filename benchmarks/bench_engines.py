"""The engine cost estimate against measured runs (issue 46 item 3).

For each molecule and level, `vibra.molecules.engines.engine_cost` (from sizes, before any SCF)
is set beside what the scene's engine path measures: the geometry optimisation to the engine's
minimum plus `electronic_structure` (the finite differences of the dipole and polarisability
with the Richardson step, and PySCF's analytic Hessian), i.e. `vibra.pipeline.plan.electronic
.electronic_run`, each case in a fresh process (so its peak memory, ru_maxrss, is its own; the
estimate includes PySCF's loaded process). Time is the process's CPU time (user + system, one
BLAS thread): the estimate is for one core, and the shared development machine runs several
jobs at once, so wall time there measures the load, not the work (both are recorded). The time
model's constants (`vibra.molecules.engines.choice._TIME_MODEL`) were fitted to single-geometry
and Hessian timings of H2O, CO2 and CH4 (their rows say "yes"); NH3, H2CO and C2H4 were not
used in the fit. An
estimate that misses by more than 3x is a bug (STYLE.md); the ratios are recorded, no time is
asserted.

Writes results/bench_engines.json and .md. Run: python benchmarks/bench_engines.py [--quick]
(quick: the RHF/STO-3G cases only); ``--estimates FILE`` recomputes the estimates of a stored run.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import write_json, write_markdown  # noqa: E402,I001  (pins BLAS threads before numpy)

CASES = [("H2O", "hf", "sto-3g"), ("CH4", "hf", "sto-3g"), ("CO2", "hf", "sto-3g"), ("NH3", "hf", "sto-3g"),
         ("H2CO", "hf", "sto-3g"), ("C2H4", "hf", "sto-3g"),
         ("H2O", "hf", "6-31g*"), ("NH3", "hf", "6-31g*"), ("H2CO", "hf", "6-31g*"),
         ("H2O", "b3lyp", "6-31g*")]
CALIBRATION = {"H2O", "CO2", "CH4"}


def measure(name: str, method: str, basis: str) -> dict:
    """One case in this process: the scene's engine path, timed (CPU and wall) with its peak memory."""
    from vibra.pipeline.plan.build import build_system
    from vibra.pipeline.plan.electronic import electronic_run
    from vibra.pipeline.scene import Scene

    scene = Scene.from_dict({"kind": "molecule", "units": "ASE", "system": {
        "builder": "molecule", "name": name, "engine": "pyscf", "method": method, "basis": basis}},
        source=f"{name}.toml")
    system = build_system(scene)
    wall, cpu = time.perf_counter(), time.process_time()
    electronic = electronic_run(scene, system)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return {"molecule": name, "method": method, "basis": basis, "level": electronic.level, "cpu_s": cpu,
            "wall_s": wall, "measured_peak_bytes": peak, "calibration": name in CALIBRATION}


def with_estimates(rows: list[dict]) -> list[dict]:
    """Each measured row with the estimate of the current cost model beside it."""
    from ase.build import molecule

    from vibra.molecules.engines.choice import EngineChoice, engine_cost

    out = []
    for row in rows:
        cost = engine_cost(EngineChoice("pyscf", row["method"], row["basis"]), molecule(row["molecule"]).numbers)
        out.append({**row, "n_basis": cost.n_basis, "n_atoms": cost.n_atoms, "estimate_s": cost.seconds,
                    "ratio_time": row["cpu_s"] / cost.seconds, "estimate_bytes": cost.memory,
                    "ratio_memory": row["measured_peak_bytes"] / cost.memory})
    return out


def report(rows: list[dict]) -> None:
    rows = with_estimates(rows)
    write_json("bench_engines", {"cases": rows, "note": "one run per case (a cost-model check, not a speed race); "
                                 "time = the process's CPU time"}, rounds=1)
    write_markdown("bench_engines", ["molecule", "level", "basis functions", "estimate (s)", "CPU (s)",
                                     "CPU / estimate", "wall (s)", "peak memory / estimate", "constants fitted on it"],
                   [[row["molecule"], row["level"], f"{row['n_basis']}", f"{row['estimate_s']:.2f}",
                     f"{row['cpu_s']:.2f}", f"{row['ratio_time']:.2f}", f"{row['wall_s']:.1f}",
                     f"{row['ratio_memory']:.2f}", "yes" if row["calibration"] else "no (held out)"] for row in rows])


def main() -> None:
    if "--case" in sys.argv:
        i = sys.argv.index("--case")
        print(json.dumps(measure(*sys.argv[i + 1:i + 4])))
        return
    if "--estimates" in sys.argv:
        stored = json.loads(Path(sys.argv[sys.argv.index("--estimates") + 1]).read_text())
        report([{k: v for k, v in row.items() if k in ("molecule", "method", "basis", "level", "cpu_s", "wall_s",
                                                         "measured_peak_bytes", "calibration")}
                for row in stored["cases"]])
        return
    quick = "--quick" in sys.argv
    rows = []
    for name, method, basis in CASES:
        if quick and basis != "sto-3g":
            continue
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
        out = subprocess.run([sys.executable, __file__, "--case", name, method, basis], capture_output=True,
                             text=True, env=env, check=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(row)
        print(f"{name:5s} {row['level']:14s} CPU {row['cpu_s']:7.2f} s  wall {row['wall_s']:7.2f} s", flush=True)
    report(rows)


if __name__ == "__main__":
    main()
