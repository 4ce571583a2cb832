"""Speed versus accuracy of molecular Hessians (issue 4).

1. Finite differences against the analytic valence-force-field Hessian B^T W B (ethanol,
   9 atoms, stretches + bends + torsions): error versus step for the 2- and 4-point central
   stencils, error versus number of force calls, and vibra's own error estimate beside the
   true error.
2. vibra's analytic Hessian + Eckart analysis against ASE `Vibrations` (2-point, delta 0.01 A)
   on the same valence spring model (zig-zag carbon chains of 3, 30 and 300 atoms, ASE given
   the `ValenceForceField` calculator): wall-time ratio and wavenumber difference in one run;
   vibra's finite-difference path on the same calculator is timed too.

Writes results/bench_hessian.json, .png and .md (a table for benchmarks/RESULTS.md).
Run with OPENBLAS_NUM_THREADS=1; ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from _common import RESULTS, best_time, write_json  # noqa: E402

from vibra import molecules as mol  # noqa: E402
from vibra.units import ASE  # noqa: E402


def step_study(steps: list[float]) -> dict:
    from ase.build import molecule

    atoms = molecule("CH3CH2OH")
    model = mol.valence_model(atoms, torsion=0.1)
    exact_system = mol.from_atoms(atoms, model)
    exact = exact_system.hessian().toarray()
    exact_cm1 = mol.vibrational_analysis(exact_system).vibration_wavenumbers_cm1()
    calc = mol.ValenceForceField(model)
    rows = []
    for stencil in (2, 4):
        for step in steps:
            result = mol.finite_difference_hessian(atoms, calc, step=step, stencil=stencil)
            plain = mol.finite_difference_hessian(atoms, calc, step=step, stencil=stencil, estimate_error=False)
            analysis = mol.vibrational_analysis(plain.system())
            rows.append({
                "stencil": stencil, "step": step, "force_calls": plain.n_force_calls,
                "force_calls_with_estimate": result.n_force_calls,
                "hessian_error": float(np.abs(plain.hessian - exact).max() / np.abs(exact).max()),
                "estimated_error": float(result.error.max() / np.abs(exact).max()),
                "wavenumber_error_cm1": float(np.abs(analysis.vibration_wavenumbers_cm1() - exact_cm1).max()),
            })
            print(f"stencil {stencil} step {step:8.1e}: rel. Hessian error {rows[-1]['hessian_error']:.2e} "
                  f"(estimated {rows[-1]['estimated_error']:.2e}), max |d wavenumber| "
                  f"{rows[-1]['wavenumber_error_cm1']:.2e} cm^-1, {plain.n_force_calls} force calls")
    return {"molecule": "CH3CH2OH", "n_atoms": len(atoms), "rows": rows}


def zigzag_chain(n: int):
    from ase import Atoms

    bond, angle = 1.54, np.radians(112.0)
    dx, dy = bond * np.sin(angle / 2), bond * np.cos(angle / 2)
    positions = [(i * dx, dy * (i % 2), 0.0) for i in range(n)]
    return Atoms(f"C{n}", positions=positions)


def size_study(sizes: list[int]) -> list[dict]:
    from vibra import crosscheck as cc

    rows = []
    for n in sizes:
        atoms = zigzag_chain(n)
        model = mol.valence_model(atoms, bonds=np.array([[i, i + 1] for i in range(n - 1)]),
                                  stretch=28.0, bend=5.0, torsion=0.5)
        calc = mol.ValenceForceField(model)

        def analytic():
            return mol.vibrational_analysis(mol.from_atoms(atoms, model), accuracy="fast")

        def analytic_high():
            return mol.vibrational_analysis(mol.from_atoms(atoms, model)).vibration_wavenumbers_cm1()

        def finite():
            fd = mol.finite_difference_hessian(atoms, calc, estimate_error=False)
            return mol.vibrational_analysis(fd.system()).vibration_wavenumbers_cm1()

        repeat = 3 if n <= 30 else 1
        t_vibra, analysis = best_time(analytic, repeat=repeat)
        vibra_cm1 = analysis.vibration_wavenumbers_cm1()
        t_high, high_cm1 = best_time(analytic_high, repeat=repeat)
        t_fd, fd_cm1 = best_time(finite, repeat=repeat)
        t_ase, (ase_cm1, ase_vectors) = best_time(lambda: cc._run_ase(atoms, calc, 0.01, 2), repeat=repeat)
        # ASE's rigid-body modes matched by overlap with the translations and rotations (as in
        # vibra.crosscheck), not dropped by position: its fd rotations sit at a few cm^-1,
        # among the chain's softest torsions
        rigid = np.asarray(analysis.rigid)
        t = mol.rigid_body_vectors(atoms.positions, atoms.get_masses())
        ase_vib = cc._match(ase_cm1, ase_vectors, t, rigid)[0][~rigid]
        # vibra's own estimate of the finite-difference error of a 2-point, 0.01 A Hessian
        # (Richardson + round-off, first order on each mode): what should explain |ASE - vibra|
        estimate = mol.finite_difference_hessian(atoms, calc, step=0.01, stencil=2)
        fd_error = ASE.omega_to_cm1(estimate.omega_errors(analysis.modes))[~rigid]
        explained = np.abs(ase_vib - vibra_cm1) <= fd_error + 2e-7 * np.abs(vibra_cm1)
        rows.append({
            "n_atoms": n, "vibra_analytic_s": t_vibra, "vibra_analytic_high_s": t_high,
            "max_diff_fast_high_cm1": float(np.abs(high_cm1 - vibra_cm1).max()), "vibra_fd_s": t_fd, "ase_vibrations_s": t_ase,
            "ase_over_vibra": t_ase / t_vibra, "ase_over_vibra_fd": t_ase / t_fd,
            "max_diff_ase_cm1": float(np.abs(ase_vib - vibra_cm1).max()),
            "max_fd_error_estimate_cm1": float(fd_error.max()),
            "ase_diff_within_fd_estimate": bool(explained.all()),
            "n_vibrations_outside_estimate": int((~explained).sum()),
            "max_diff_vibra_fd_cm1": float(np.abs(fd_cm1 - vibra_cm1).max()),
            "max_wavenumber_cm1": float(vibra_cm1.max()),
        })
        print(f"{n:4d} atoms: vibra analytic fast {t_vibra:.3g} s, high {t_high:.3g} s, vibra fd {t_fd:.3g} s, ASE {t_ase:.3g} s "
              f"(ASE/vibra {t_ase / t_vibra:.1f}x); max |ASE - vibra| {rows[-1]['max_diff_ase_cm1']:.2e} cm^-1, "
              f"fd estimate up to {fd_error.max():.2e} cm^-1, {int((~explained).sum())} vibration(s) outside it")
    return rows


def plot(steps: dict, sizes: list[dict]) -> Path:
    from vibra.charts._style import new_figure, save_figure

    fig, (ax_step, ax_calls, ax_time) = new_figure(1, 3, figsize=(16.0, 5.0))
    colours = {2: "tab:blue", 4: "tab:red"}
    for stencil in (2, 4):
        rows = [r for r in steps["rows"] if r["stencil"] == stencil]
        h = [r["step"] for r in rows]
        ax_step.loglog(h, [r["hessian_error"] for r in rows], "o-", color=colours[stencil],
                       label=f"{stencil}-point, true error")
        ax_step.loglog(h, [r["estimated_error"] for r in rows], "x--", color=colours[stencil],
                       label=f"{stencil}-point, vibra's estimate")
        ax_calls.semilogy([r["force_calls"] for r in rows], [r["wavenumber_error_cm1"] for r in rows], "o",
                        color=colours[stencil], label=f"{stencil}-point (one point per step)")
        best = min(rows, key=lambda r: r["wavenumber_error_cm1"])
        ax_calls.annotate(f"best: h = {best['step']:g} A", (best["force_calls"], best["wavenumber_error_cm1"]),
                          textcoords="offset points", xytext=(8, -4), fontsize=10)
    ax_step.set_xlabel("finite-difference step h (Angstrom)")
    ax_step.set_ylabel("max |H_fd - H_exact| / max |H_exact|")
    ax_step.set_title(f"Hessian error, {steps['molecule']} ({steps['n_atoms']} atoms)")
    ax_step.legend()
    ax_calls.set_xlabel("force calls")
    ax_calls.set_ylabel("max wavenumber error (cm$^{-1}$)")
    ax_calls.set_title("wavenumber error vs cost")
    calls = sorted({r["force_calls"] for r in steps["rows"]})
    ax_calls.set_xticks(calls)
    ax_calls.set_xlim(calls[0] - 30, calls[-1] + 60)
    ax_calls.legend()
    n = [r["n_atoms"] for r in sizes]
    ax_time.loglog(n, [r["vibra_analytic_s"] for r in sizes], "o-", label='vibra analytic B$^T$WB, "fast"')
    ax_time.loglog(n, [r["vibra_analytic_high_s"] for r in sizes], "D-", label='vibra analytic, "high" accuracy')
    ax_time.loglog(n, [r["vibra_fd_s"] for r in sizes], "s-", label="vibra finite differences")
    ax_time.loglog(n, [r["ase_vibrations_s"] for r in sizes], "^-", label="ASE Vibrations")
    for r in sizes:
        ax_time.annotate(f"x{r['ase_over_vibra']:.0f}", (r["n_atoms"], r["ase_vibrations_s"]),
                         textcoords="offset points", xytext=(-10, 6), fontsize=10)
    ax_time.set_ylim(top=4 * max(r["ase_vibrations_s"] for r in sizes))  # room for the labels
    ax_time.set_xlabel("atoms (zig-zag chain)")
    ax_time.set_ylabel("wall time (s)")
    ax_time.set_title('time to all wavenumbers (labels: ASE / vibra "fast")')
    ax_time.legend()
    return save_figure(fig, RESULTS / "bench_hessian.png")


def markdown(steps: dict, sizes: list[dict]) -> Path:
    lines = ["### Molecular Hessians: finite differences vs analytic (bench_hessian.py)", "",
             f"Step study on {steps['molecule']} ({steps['n_atoms']} atoms, valence force field with torsions):", "",
             "| stencil | step (A) | force calls | rel. Hessian error | vibra's estimate | max wavenumber error (cm^-1) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in steps["rows"]:
        lines.append(f"| {r['stencil']} | {r['step']:g} | {r['force_calls']} | {r['hessian_error']:.2e} | "
                     f"{r['estimated_error']:.2e} | {r['wavenumber_error_cm1']:.2e} |")
    lines += ["", "Analytic Hessian vs ASE Vibrations (2-point, delta 0.01 A) on the same spring model:", "",
              "| atoms | vibra analytic fast (s) | vibra analytic high (s) | vibra fd (s) | ASE Vibrations (s) | ASE / vibra | max abs(ASE - vibra) (cm^-1) | vibra's fd error estimate, max (cm^-1) | vibrations outside the estimate |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in sizes:
        lines.append(f"| {r['n_atoms']} | {r['vibra_analytic_s']:.3g} | {r['vibra_analytic_high_s']:.3g} | {r['vibra_fd_s']:.3g} | "
                     f"{r['ase_vibrations_s']:.3g} | {r['ase_over_vibra']:.1f} | {r['max_diff_ase_cm1']:.2e} | "
                     f"{r['max_fd_error_estimate_cm1']:.2e} | {r['n_vibrations_outside_estimate']} |")
    target = RESULTS / "bench_hessian.md"
    target.write_text("\n".join(lines) + "\n")
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: few steps, small molecules")
    args = parser.parse_args()
    steps = [1e-3, 1e-2] if args.quick else [1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1]
    sizes = [3, 30] if args.quick else [3, 30, 300]
    start = time.perf_counter()
    step_result = step_study(steps)
    size_result = size_study(sizes)
    write_json("bench_hessian", {"step_study": step_result, "size_study": size_result, "quick": args.quick,
                                 "units": {"omega": ASE.name, "wavenumber": "cm^-1"}})
    print("figure:", plot(step_result, size_result))
    print("table:", markdown(step_result, size_result))
    print(f"total {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
