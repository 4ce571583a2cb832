"""The cost of a crystal's finite differences, from sizes, before any force call (issue 44).

Truth: the peak memory traced by Python's tracemalloc over a real run (EMT on fcc Al), the
number of force calls the run made, and a calculator that counts its calls (a refused run
makes none).
"""

from __future__ import annotations

import tracemalloc
import warnings

import numpy as np
import pytest
from ase.build import bulk
from ase.calculators.calculator import Calculator, all_changes
from ase.calculators.emt import EMT

from vibra import crystals
from vibra.crystals.fd_cost import check_memory, force_constants_cost
from vibra.solvers import ResourceLimitError


class CountingCalculator(Calculator):
    """Harmonic nearest-neighbour-free forces (zero), counting its calls."""

    implemented_properties = ["energy", "forces"]
    calls = 0

    def calculate(self, atoms=None, properties=("forces",), system_changes=all_changes):
        super().calculate(atoms, properties, system_changes)
        type(self).calls += 1
        self.results = {"energy": 0.0, "forces": np.zeros((len(self.atoms), 3))}


@pytest.mark.parametrize("n, symmetry", [(5, False), (6, True)])
def test_memory_estimate_holds_the_traced_peak(n: int, symmetry: bool) -> None:
    """The model (72 n^2 bytes x 8 arrays + permutations + forces) against tracemalloc's peak.
    Bound 0.5-2x: measured within 10 % on 64-1,000 atoms; the factor 2 leaves room for another
    phonopy or numpy version's temporaries while still catching a model off by its order."""
    atoms = bulk("Al", "fcc", a=4.05)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tracemalloc.start()
        try:
            result = crystals.finite_difference_force_constants(atoms, EMT(), supercell=(n, n, n), symmetry=symmetry,
                                                                force_noise=None)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    cost = force_constants_cost(1, n ** 3, n_ops=48, symmetry=symmetry, steps=2, deterministic=True,
                                n_moves=result.n_displacements)
    assert cost.n_force_calls == result.n_force_calls + result.n_cached
    assert 0.5 < cost.memory / peak < 2.0, (cost.memory, peak)


def test_over_the_memory_limit_is_refused_before_any_force_call_naming_what_fits() -> None:
    CountingCalculator.calls = 0
    atoms = bulk("Al", "fcc", a=4.05)
    with pytest.raises(ResourceLimitError) as error:
        crystals.finite_difference_force_constants(atoms, CountingCalculator(), supercell=(12, 12, 12),
                                                   max_memory=50e6, force_noise=None)
    message = str(error.value)
    assert CountingCalculator.calls == 0
    assert "supercell [12, 12, 12]" in message and "1728-atom supercell" in message
    assert "max_memory" in message and "would fit" in message
    fits = int(message.split("at most ")[-1].split(" cells")[0])
    assert fits > 1
    # the number named fits and one more cell does not (same model, same limit)
    sizes = dict(n_ops=48, symmetry=True, steps=2)
    check_memory(force_constants_cost(1, fits, deterministic=False, **sizes), supercell=[fits, 1, 1], n_unit=1,
                 max_memory=50e6, **sizes)
    with pytest.raises(ResourceLimitError):
        check_memory(force_constants_cost(1, fits + 1, deterministic=False, **sizes), supercell=[fits + 1, 1, 1],
                     n_unit=1, max_memory=50e6, **sizes)


def test_from_ase_takes_the_same_limit_and_inf_lifts_it() -> None:
    CountingCalculator.calls = 0
    atoms = bulk("Al", "fcc", a=4.05)
    with pytest.raises(ResourceLimitError, match="force calls of a 27-atom supercell"):
        crystals.from_ase(atoms, CountingCalculator(), supercell=(3, 3, 3), max_memory=1e5)
    assert CountingCalculator.calls == 0
    crystal = crystals.from_ase(atoms, CountingCalculator(), supercell=(3, 3, 3), max_memory=float("inf"))
    assert crystal.n_atoms == 1 and CountingCalculator.calls > 0


def test_progress_prints_the_estimate_first(capsys: pytest.CaptureFixture[str]) -> None:
    atoms = bulk("Cu", "fcc", a=3.61)
    result = crystals.finite_difference_force_constants(atoms, EMT(), supercell=(3, 3, 3), progress=True,
                                                        force_noise=None, symmetry=False)
    first = capsys.readouterr().err.splitlines()[0]
    assert f"{result.n_force_calls} force calls of a 27-atom supercell" in first, first
    assert "of memory, at least" in first  # EMT is closed-form: a time is given


def test_sizes_multiply_in_python_integers() -> None:
    """A bound on a huge supercell (10^6 cells of 10^3 atoms) is a finite, huge figure (no int64 wrap)."""
    cost = force_constants_cost(1000, 10 ** 6, n_ops=48, symmetry=True, steps=2, deterministic=False)
    assert cost.memory > 1e20 and cost.n_supercell_atoms == 10 ** 9 and cost.seconds is None


def test_the_solvers_memory_limit_set_after_import_reaches_finite_differences_and_sweeps(monkeypatch) -> None:
    """One rule (`budget.memory_limit`): `MEMORY_LIMIT` is read at the call, not copied at import
    (a copy would ignore a user's `vibra.solvers.budget.MEMORY_LIMIT = ...`)."""
    from vibra.pipeline.sweep.cost import check_sweep_memory
    from vibra.solvers import budget

    monkeypatch.setattr(budget, "MEMORY_LIMIT", 1e5)
    sizes = dict(n_ops=48, symmetry=True, steps=2)
    with pytest.raises(ResourceLimitError, match="max_memory"):
        check_memory(force_constants_cost(1, 27, deterministic=False, **sizes), supercell=[3, 3, 3], n_unit=1,
                     max_memory=None, **sizes)
    with pytest.raises(ResourceLimitError, match="max_memory"):
        check_sweep_memory(1000, n_dof=100, n_modes=100, solve=0.0, track=True, lines=1000, distributed=False)
