"""Speed versus accuracy of molecular Hessians (issue 4).

1. Finite differences against the analytic valence-force-field Hessian B^T W B (ethanol,
   9 atoms, stretches + bends + torsions): error versus step for the 2- and 4-point central
   stencils, error versus number of force calls, and vibra's own error estimate beside the
   true error.
2. Time to all wavenumbers on the same valence spring model (zig-zag carbon chains of 3, 30
   and 300 atoms): vibra's finite-difference Hessian against its peer doing the same work,
   ASE `Vibrations` (same `ValenceForceField` calculator, same step 0.01 A, same 2-point
   central stencil, ASE's own on-disk displacement cache in a temporary folder), and beside
   them vibra's analytic Hessian B^T W B ("fast" and "high" accuracy). Timed by the protocol
   of _common.py (warm-up, interleaved rounds, min/median/max); the wavenumber difference
   ASE - vibra analytic is set beside vibra's own finite-difference error estimate.

Writes results/bench_hessian.json, .png and .md (a table for benchmarks/RESULTS.md).
Run:  python benchmarks/bench_hessian.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import (RESULTS, ROUNDS, format_ratio, interleaved, new_figure, ratio, save_figure,  # noqa: E402,I001
                     write_json)  # (pins BLAS threads before numpy)

import numpy as np  # noqa: E402

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


def ase_vibrations(atoms, calculator, delta: float, nfree: int) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001
    """ASE `Vibrations` in a temporary cache folder: (signed wavenumbers in cm^-1, mass-weighted
    unit vectors as columns)."""
    from ase import units
    from ase.vibrations import Vibrations

    work = atoms.copy()
    work.calc = calculator
    with tempfile.TemporaryDirectory(prefix="bench-ase-") as folder:
        vib = Vibrations(work, name=str(Path(folder) / "vib"), delta=delta, nfree=nfree)
        vib.run()
        energies, modes = vib.get_vibrations().get_energies_and_modes()
    energies = np.asarray(energies)
    signed = np.where(np.abs(energies.imag) > np.abs(energies.real), -np.abs(energies.imag), energies.real)
    vectors = modes.reshape(len(energies), -1).T * np.sqrt(np.repeat(work.get_masses(), 3))[:, None]
    return signed / units.invcm, vectors / np.linalg.norm(vectors, axis=0)


def ase_vibrations_only(wavenumbers: np.ndarray, vectors: np.ndarray, t: np.ndarray, n_rigid: int) -> np.ndarray:
    """ASE's vibrational wavenumbers, ascending: its rigid-body modes dropped by overlap with the
    translations and rotations `t` (not by position: its finite-difference rotations sit at a
    few cm^-1, among the chain's softest torsions)."""
    overlap = np.sum((t.T @ vectors) ** 2, axis=0)
    vibrations = np.argsort(-overlap, kind="stable")[n_rigid:]
    return np.sort(wavenumbers[vibrations])


FAST, HIGH, FD, PEER = ('vibra analytic "fast"', 'vibra analytic "high"', "vibra finite differences",
                        "ASE Vibrations")


def size_study(sizes: list[int]) -> list[dict]:
    rows = []
    for n in sizes:
        atoms = zigzag_chain(n)
        model = mol.valence_model(atoms, bonds=np.array([[i, i + 1] for i in range(n - 1)]),
                                  stretch=28.0, bend=5.0, torsion=0.5)
        calc = mol.ValenceForceField(model)

        def finite():
            fd = mol.finite_difference_hessian(atoms, calc, step=0.01, stencil=2, estimate_error=False)
            return mol.vibrational_analysis(fd.system()).vibration_wavenumbers_cm1()

        print(f"{n} atoms", flush=True)
        timings = interleaved({
            FAST: lambda: mol.vibrational_analysis(mol.from_atoms(atoms, model), accuracy="fast"),
            HIGH: lambda: mol.vibrational_analysis(mol.from_atoms(atoms, model)).vibration_wavenumbers_cm1(),
            FD: finite,
            PEER: lambda: ase_vibrations(atoms, calc, 0.01, 2),
        })
        analysis = timings[FAST].result
        vibra_cm1 = analysis.vibration_wavenumbers_cm1()
        rigid = np.asarray(analysis.rigid)
        t = mol.rigid_body_vectors(atoms.positions, atoms.get_masses())
        ase_vib = ase_vibrations_only(*timings[PEER].result, t, int(rigid.sum()))
        # vibra's own estimate of the finite-difference error of a 2-point, 0.01 A Hessian
        # (Richardson + round-off, first order on each mode): what should explain |ASE - vibra|
        estimate = mol.finite_difference_hessian(atoms, calc, step=0.01, stencil=2)
        fd_error = ASE.omega_to_cm1(estimate.omega_errors(analysis.modes))[~rigid]
        explained = np.abs(ase_vib - vibra_cm1) <= fd_error + 2e-7 * np.abs(vibra_cm1)
        rows.append({
            "n_atoms": n, "timings": {label: timing.summary() for label, timing in timings.items()},
            "vibra_analytic_s": timings[FAST].min, "vibra_analytic_high_s": timings[HIGH].min,
            "vibra_fd_s": timings[FD].min, "ase_vibrations_s": timings[PEER].min,
            "ase_over_vibra_fd": ratio(timings[PEER], timings[FD]),
            "ase_over_vibra": ratio(timings[PEER], timings[FAST]),
            "max_diff_fast_high_cm1": float(np.abs(timings[HIGH].result - vibra_cm1).max()),
            "max_diff_ase_cm1": float(np.abs(ase_vib - vibra_cm1).max()),
            "max_diff_ase_vibra_fd_cm1": float(np.abs(ase_vib - timings[FD].result).max()),
            "max_fd_error_estimate_cm1": float(fd_error.max()),
            "ase_diff_within_fd_estimate": bool(explained.all()),
            "n_vibrations_outside_estimate": int((~explained).sum()),
            "max_diff_vibra_fd_cm1": float(np.abs(timings[FD].result - vibra_cm1).max()),
            "max_wavenumber_cm1": float(vibra_cm1.max()),
        })
        r = rows[-1]
        print(f"   ASE / vibra fd {format_ratio(r['ase_over_vibra_fd'])}, ASE / vibra analytic "
              f"{format_ratio(r['ase_over_vibra'], 1)}; max |ASE - vibra| {r['max_diff_ase_cm1']:.2e} cm^-1, "
              f"|ASE - vibra fd| {r['max_diff_ase_vibra_fd_cm1']:.2e} cm^-1, fd estimate up to "
              f"{fd_error.max():.2e} cm^-1, {int((~explained).sum())} vibration(s) outside it", flush=True)
    return rows


def plot(steps: dict, sizes: list[dict]) -> Path:
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
    n = np.array([r["n_atoms"] for r in sizes])
    for label, marker in ((FAST, "o-"), (HIGH, "D-"), (FD, "s-"), (PEER, "^-")):
        best = np.array([r["timings"][label]["min_s"] for r in sizes])
        slowest = np.array([r["timings"][label]["max_s"] for r in sizes])
        line, = ax_time.loglog(n, best, marker, label=label + (" (2-point, 0.01 A)" if label in (FD, PEER) else ""))
        ax_time.errorbar(n, best, yerr=[np.zeros_like(best), slowest - best], fmt="none", ecolor=line.get_color(),
                         capsize=3)
    for r in sizes:
        ax_time.annotate(f"ASE/fd {r['ase_over_vibra_fd']['of_min']:.1f}x\nASE/fast {r['ase_over_vibra']['of_min']:.0f}x",
                         (r["n_atoms"], r["timings"][PEER]["min_s"]), textcoords="offset points", xytext=(-30, 8),
                         fontsize=9)
    # room for the labels above and for the legend below the lines
    ax_time.set_ylim(min(r["timings"][FAST]["min_s"] for r in sizes) / 30, 10 * max(r["timings"][PEER]["max_s"] for r in sizes))
    ax_time.set_xlabel("atoms (zig-zag chain)")
    ax_time.set_ylabel("wall time (s): best of the rounds, bar to the slowest")
    ax_time.set_title("time to all wavenumbers, same calculator")
    ax_time.legend(fontsize=8, loc="lower right")
    return save_figure(fig, "bench_hessian")


def markdown(steps: dict, sizes: list[dict]) -> Path:
    lines = ["### Molecular Hessians: finite differences vs analytic (bench_hessian.py)", "",
             f"Step study on {steps['molecule']} ({steps['n_atoms']} atoms, valence force field with torsions):", "",
             "| stencil | step (A) | force calls | rel. Hessian error | vibra's estimate | max wavenumber error (cm^-1) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in steps["rows"]:
        lines.append(f"| {r['stencil']} | {r['step']:g} | {r['force_calls']} | {r['hessian_error']:.2e} | "
                     f"{r['estimated_error']:.2e} | {r['wavenumber_error_cm1']:.2e} |")
    lines += ["", "Time to all wavenumbers on the same spring model (best of the rounds, median in brackets); "
              "ASE Vibrations and vibra fd both 2-point, delta 0.01 A, same calculator:", "",
              "| atoms | vibra analytic fast (s) | vibra analytic high (s) | vibra fd (s) | ASE Vibrations (s) | ASE / vibra fd (round range) | ASE / vibra analytic fast (round range) | max abs(ASE - vibra) (cm^-1) | vibra's fd error estimate, max (cm^-1) | vibrations outside the estimate |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in sizes:
        t = r["timings"]
        cells = " | ".join(f"{t[k]['min_s']:.3g} ({t[k]['median_s']:.3g})" for k in (FAST, HIGH, FD, PEER))
        lines.append(f"| {r['n_atoms']} | {cells} | {format_ratio(r['ase_over_vibra_fd'])} | "
                     f"{format_ratio(r['ase_over_vibra'], 1)} | {r['max_diff_ase_cm1']:.2e} | "
                     f"{r['max_fd_error_estimate_cm1']:.2e} | {r['n_vibrations_outside_estimate']} |")
    target = RESULTS / "bench_hessian.md"
    target.write_text("\n".join(lines) + "\n")
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: few steps, small molecules")
    parser.add_argument("--replot", action="store_true", help="redraw the PNG and table from the JSON, no timing")
    args = parser.parse_args()
    if args.replot:
        saved = json.loads((RESULTS / "bench_hessian.json").read_text())
        print("figure:", plot(saved["step_study"], saved["size_study"]))
        print("table:", markdown(saved["step_study"], saved["size_study"]))
        return
    steps = [1e-3, 1e-2] if args.quick else [1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1]
    sizes = [3, 30] if args.quick else [3, 30, 300]
    start = time.perf_counter()
    step_result = step_study(steps)
    size_result = size_study(sizes)
    print("figure:", plot(step_result, size_result))
    print("table:", markdown(step_result, size_result))
    write_json("bench_hessian", {"step_study": step_result, "size_study": size_result, "quick": args.quick,
                                 "peer": "ase.vibrations.Vibrations(delta=0.01, nfree=2), same calculator, "
                                         "cache in a temporary folder",
                                 "units": {"omega": ASE.name, "wavenumber": "cm^-1"}}, ROUNDS)
    print(f"total {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
