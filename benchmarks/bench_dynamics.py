"""Time integration of an alpha-FPUT chain: vibra's compiled loop against a plain numpy loop.

    python benchmarks/bench_dynamics.py [--quick]

Issue 33's speed target: 10^6 velocity-Verlet steps of a 64-site alpha-FPUT chain (fixed ends,
alpha = 0.25, started in mode 1 with amplitude 1, dt = 0.05) in under 2 s on one core, and the
same physics as a plain numpy loop 20x slower or more. Methods, in one process, by the protocol
of STYLE.md (warm-up, interleaved rounds, best of N, BLAS threads pinned to 1 by _common):

- ``vibra verlet``: `vibra.dynamics.integrate(..., forces=fput forces, integrator="verlet",
  record_every=1000)`: the numba loop (K in CSR, bond forces, kick and drift fused);
- ``vibra yoshida4`` and ``vibra blanes-moan``: the same steps with the 4th-order schemes
  (3 and 6 force evaluations a step), for the cost of their accuracy;
- ``numpy loop``: velocity Verlet written with numpy array operations (np.diff for the bond
  elongations, one temporary per operation), recording every 1000 steps: what a user writes
  without a compiler. It is timed over 10^5 steps and scaled by 10 (it is ~40x slower); its
  states are compared with vibra's over the same 10^5 steps (same algorithm, same order of
  operations per site: they agree to rounding).

Each row gives the relative energy error max |H(t) - H(0)| / H(0) over the 10^6 steps.
Writes results/dynamics.json.
"""

from __future__ import annotations

import argparse

from _common import ROUNDS, format_ratio, interleaved, ratio, write_json  # noqa: I001  (sets BLAS threads)

import numpy as np

from vibra import dynamics

N_SITES, ALPHA, DT, EVERY = 64, 0.25, 0.05, 1000


def numpy_loop(x0: np.ndarray, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Velocity Verlet for m u'' = (u_{i+1} - 2u_i + u_{i-1}) + alpha [(u_{i+1} - u_i)^2 - (u_i - u_{i-1})^2]."""
    x = x0.copy()
    v = np.zeros_like(x)
    padded = np.zeros(x.size + 2)

    def force(u: np.ndarray) -> np.ndarray:
        padded[1:-1] = u
        d = np.diff(padded)
        tension = d + ALPHA * d * d
        return tension[1:] - tension[:-1]

    f = force(x)
    records = [x.copy()]
    for step in range(1, n_steps + 1):
        v += 0.5 * DT * f
        x += DT * v
        f = force(x)
        v += 0.5 * DT * f
        if step % EVERY == 0:
            records.append(x.copy())
    return np.array(records), v


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10^5 steps instead of 10^6")
    args = parser.parse_args()
    n_steps = 10**5 if args.quick else 10**6
    numpy_steps = n_steps // 10
    system, forces = dynamics.fput(N_SITES, alpha=ALPHA)
    x0 = np.sin(np.pi * np.arange(1, N_SITES + 1) / (N_SITES + 1))
    v0 = np.zeros(N_SITES)

    def vibra_run(integrator: str, steps: int = n_steps) -> dynamics.Trajectory:
        return dynamics.integrate(system, x0, v0, DT, steps, forces=forces, integrator=integrator,
                                  record_every=EVERY)

    methods = {
        "vibra verlet": lambda: vibra_run("verlet"),
        "vibra yoshida4": lambda: vibra_run("yoshida4"),
        "vibra blanes-moan": lambda: vibra_run("blanes-moan"),
        f"numpy loop ({numpy_steps} steps)": lambda: numpy_loop(x0, numpy_steps),
    }
    print(f"alpha-FPUT, {N_SITES} sites, {n_steps} steps of dt = {DT}", flush=True)
    timings = interleaved(methods)
    numpy_timing = timings[f"numpy loop ({numpy_steps} steps)"]
    scaled = type(numpy_timing)("numpy loop (scaled)", tuple(s * n_steps / numpy_steps for s in numpy_timing.seconds),
                                None)
    short = vibra_run("verlet", numpy_steps)
    agreement = float(np.max(np.abs(short.positions - numpy_timing.result[0])))
    rows = []
    for label in ("vibra verlet", "vibra yoshida4", "vibra blanes-moan"):
        t = timings[label]
        drift = float(np.max(np.abs(t.result.energy / t.result.energy[0] - 1.0)))
        r = ratio(scaled, t)
        rows.append({"method": label, **t.summary(), "numpy_loop_over_this": r, "energy_error": drift,
                     "microseconds_per_step": t.min / n_steps * 1e6})
        print(f"{label:22s} {t.min:7.3f} s ({t.min / n_steps * 1e9:6.0f} ns/step)  numpy loop / this "
              f"{format_ratio(r, 1)}  energy error {drift:.1e}", flush=True)
    rows.append({"method": "numpy loop", **scaled.summary(), "timed_steps": numpy_steps,
                 "scaled_by": n_steps / numpy_steps, "max_position_difference_to_vibra": agreement,
                 "microseconds_per_step": scaled.min / n_steps * 1e6})
    print(f"numpy loop (scaled)    {scaled.min:7.3f} s; its states vs vibra verlet over {numpy_steps} steps: "
          f"max |dx| = {agreement:.1e}", flush=True)
    payload = {"problem": {"sites": N_SITES, "alpha": ALPHA, "ends": "fixed", "dt": DT, "steps": n_steps,
                           "record_every": EVERY, "start": "mode 1, amplitude 1, at rest"},
               "peer": "velocity Verlet as a plain numpy loop (timed over a tenth of the steps, scaled)",
               "results": rows}
    print(f"wrote {write_json('dynamics', payload, ROUNDS)}")


if __name__ == "__main__":
    main()
