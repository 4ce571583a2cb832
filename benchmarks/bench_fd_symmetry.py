"""Symmetry-reduced finite-difference Hessians against every Cartesian displacement (issue 46).

Benzene (ASE's g2 geometry, D6h), ASE's EMT calculator and vibra's valence force field, step
0.01 Angstrom, 2-point stencil with the Richardson 2h step (the default), force_noise=None (no
probe): `finite_difference_hessian(..., symmetry=True)` (25 force calls) against
``symmetry=False`` (145), timed by the protocol of _common.py (warm-up, interleaved rounds,
min/median/max), in one process with BLAS pinned to one thread; a third row adds a 20 ms sleep
to every EMT force call, a stand-in for an expensive calculator. Also reported: the largest
|H_reduced - H_full| over the summed error estimates of the two runs. The fixed cost of the
reduction is the point-group detection (~60 ms for benzene on this machine), which the cheap
calculators (~2 ms per force call) do not repay fully.

Writes results/bench_fd_symmetry.json and .md (a table for benchmarks/RESULTS.md).
Run:  python benchmarks/bench_fd_symmetry.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import ROUNDS, format_ratio, interleaved, ratio, write_json, write_markdown  # noqa: E402,I001

import numpy as np  # noqa: E402


def main() -> None:
    from ase.calculators.emt import EMT

    from vibra import molecules as mol
    from vibra.molecules.named import molecule_atoms

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one round")
    args = parser.parse_args()
    rounds = 1 if args.quick else ROUNDS
    atoms = molecule_atoms("C6H6")
    rows = []
    class SlowEMT(EMT):  # type: ignore[misc]
        """EMT plus 20 ms per force call: a stand-in for an expensive calculator (an SCF)."""

        def calculate(self, *args, **kwargs):  # type: ignore[no-untyped-def]
            super().calculate(*args, **kwargs)
            time.sleep(0.02)

    calculators = (("EMT", EMT()), ("valence force field", mol.ValenceForceField(mol.valence_model(atoms))),
                   ("EMT + 20 ms per call", SlowEMT()))
    for label, calc in calculators:
        def reduced(calc=calc):
            return mol.finite_difference_hessian(atoms, calc, force_noise=None)

        def full(calc=calc):
            return mol.finite_difference_hessian(atoms, calc, force_noise=None, symmetry=False)

        print(f"benzene, {label}:", flush=True)
        timings = interleaved({"symmetry=True": reduced, "symmetry=False": full}, rounds)
        r, f = timings["symmetry=True"].result, timings["symmetry=False"].result
        rows.append({
            "calculator": label, "calls_reduced": r.n_force_calls, "calls_full": f.n_force_calls,
            "reduced": timings["symmetry=True"].summary(), "full": timings["symmetry=False"].summary(),
            "ratio": ratio(timings["symmetry=True"], timings["symmetry=False"]),
            "worst_over_estimates": float((np.abs(r.hessian - f.hessian) / (r.error + f.error)).max()),
            "symmetry": r.symmetry,
        })
    write_json("bench_fd_symmetry", {"rows": rows}, rounds)
    write_markdown("bench_fd_symmetry", ["calculator", "force calls", "best, reduced", "best, full",
                                         "time ratio reduced / full", "worst abs(H_r - H_f) / (E_r + E_f)"],
                   [[row["calculator"], f"{row['calls_reduced']} / {row['calls_full']}",
                     f"{row['reduced']['min_s']:.3f} s", f"{row['full']['min_s']:.3f} s", format_ratio(row["ratio"]),
                     f"{row['worst_over_estimates']:.2f}"] for row in rows], align="---:")


if __name__ == "__main__":
    main()
