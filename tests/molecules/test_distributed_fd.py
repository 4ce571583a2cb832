"""Finite-difference Hessians on a Dask cluster (vibra.molecules.finite_difference, displacements).

The serial run in this process is the reference: it is checked against ASE's `Vibrations` and
the analytic valence Hessian in tests/molecules/test_molecules.py. Here the cluster must reproduce it bit for
bit (same geometries, same assembly order), survive a killed worker and a killed client, and
name the geometry whose force call failed. The cluster: 2 worker processes, 1 thread each
(`dask_client` in conftest.py). tblite's serial reference runs inside one worker process (the
serial code path, client=None), so that both sides use one OpenMP thread (Dask's nanny sets
OMP_NUM_THREADS=1): a parallel reduction inside the calculator would round differently.
"""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from vibra import molecules as mol
from vibra.cluster import ClusterError
from vibra.molecules.displacements import CacheWarning

TESTS = Path(__file__).resolve().parents[1]
ROOT = TESTS.parent
FIELDS = ("hessian", "error", "truncation", "roundoff", "force_noise", "asymmetry", "residual_force")
# force_noise="auto" (the default) probes a calculator that is not a listed closed-form class (the
# subclasses below are not) with 2 force calls, where the displaced forces ran: one task on the cluster
PROBE_CALLS = 2


def _atoms(name: str):
    return {"H2O": mol.h2o_atoms, "CO2": mol.co2_atoms}[name]()


def _assert_identical(a, b) -> None:
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


class SlowField(mol.ValenceForceField):
    """The valence force field, taking `delay` seconds per force call (a stand-in for DFT).

    With `count_dir`, every calculation leaves one empty file there (calls are counted across
    worker processes).
    """

    def __init__(self, model, delay: float = 0.0, count_dir: str | None = None) -> None:
        super().__init__(model)
        self.delay = delay
        self.count_dir = count_dir

    def calculate(self, atoms=None, properties=("energy",), system_changes=None):  # type: ignore[override]
        super().calculate(atoms, properties, system_changes or [])
        if self.count_dir is not None:
            Path(self.count_dir, uuid.uuid4().hex).touch()
        time.sleep(self.delay)


class PidField(mol.ValenceForceField):
    """The valence force field; every calculation leaves a file named after its process id in `count_dir`."""

    def __init__(self, model, count_dir: str) -> None:
        super().__init__(model)
        self.count_dir = count_dir

    def calculate(self, atoms=None, properties=("energy",), system_changes=None):  # type: ignore[override]
        super().calculate(atoms, properties, system_changes or [])
        Path(self.count_dir, f"{os.getpid()}-{uuid.uuid4().hex}").touch()


class FailingField(mol.ValenceForceField):
    """Raises once atom 1 moves towards +y (the +1h and +2h geometries along y)."""

    def calculate(self, atoms=None, properties=("energy",), system_changes=None):  # type: ignore[override]
        super().calculate(atoms, properties, system_changes or [])
        if self.atoms.positions[1, 1] > 0:
            raise RuntimeError("SCF did not converge")


class LockedField(mol.ValenceForceField):
    """Holds a lock, so it cannot be pickled."""

    def __init__(self, model) -> None:
        super().__init__(model)
        self.lock = threading.Lock()


# ---------------------------------------------------------------- identical to the serial run
@pytest.mark.parametrize("name", ["H2O", "CO2"])
def test_valence_field_on_the_cluster_equals_serial_bit_for_bit(name, dask_client) -> None:
    atoms = _atoms(name)
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    serial = mol.finite_difference_hessian(atoms, calc)
    parallel = mol.finite_difference_hessian(atoms, calc, client=dask_client)
    _assert_identical(serial, parallel)
    # symmetry-reduced plans on the cluster (tests/molecules/test_displacement_symmetry.py): H2O C2v 6 dofs, CO2 D8h 4
    assert parallel.n_force_calls == serial.n_force_calls == 1 + 2 * 2 * {"H2O": 6, "CO2": 4}[name]


@pytest.mark.parametrize("name", ["H2O", "CO2"])
def test_tblite_on_the_cluster_equals_serial_bit_for_bit(name, dask_client) -> None:
    from tblite.ase import TBLite

    atoms = _atoms(name)
    factory = functools.partial(TBLite, method="GFN2-xTB", verbosity=0)
    serial = dask_client.submit(mol.finite_difference_hessian, atoms, factory, stencil=4,
                                estimate_error=False, pure=False).result()
    parallel = mol.finite_difference_hessian(atoms, factory, stencil=4, estimate_error=False, client=dask_client)
    _assert_identical(serial, parallel)  # the noise measured too: the probe ran on a worker both times
    assert np.abs(serial.hessian).max() > 1.0  # a real Hessian (eV/A^2), not zeros
    assert serial.noise_source == parallel.noise_source == "measured"  # SCF noise, found without asking


def test_local_cluster_started_and_closed_by_vibra_equals_serial() -> None:
    atoms = mol.h2o_atoms()
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    serial = mol.finite_difference_hessian(atoms, calc, estimate_error=False)
    local = mol.finite_difference_hessian(atoms, calc, estimate_error=False, client="local", n_workers=2)
    _assert_identical(serial, local)


# ---------------------------------------------------------------- faults
def test_worker_killed_mid_run_still_identical(dask_client) -> None:
    atoms = mol.h2o_atoms()
    model = mol.valence_model(atoms)
    serial = mol.finite_difference_hessian(atoms, mol.ValenceForceField(model))
    pids = dask_client.run(os.getpid)
    victim = sorted(pids.values())[0]
    killed: list[int] = []

    def kill_after_five(done: int, total: int, label: str) -> None:
        if done == 5 and not killed:
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    result = mol.finite_difference_hessian(atoms, SlowField(model, delay=0.05), client=dask_client,
                                           progress=kill_after_five)
    assert killed == [victim]
    _assert_identical(serial, result)
    dask_client.wait_for_workers(2, timeout=60)  # the nanny restarts it; later tests get 2 again
    assert victim not in dask_client.run(os.getpid).values()


def test_killed_client_rerun_computes_only_the_missing_geometries(dask_client, tmp_path) -> None:
    cache, counts = tmp_path / "cache", tmp_path / "counts"
    counts.mkdir()
    address = dask_client.scheduler.address
    script = tmp_path / "client.py"
    script.write_text(textwrap.dedent(f"""
        import os, signal
        from vibra import molecules as mol
        from molecules.test_distributed_fd import SlowField

        def die_after_12(done, total, label):
            if done == 12:
                os.kill(os.getpid(), signal.SIGKILL)   # the client dies; the cluster stays

        if __name__ == "__main__":
            atoms = mol.h2o_atoms()
            calc = SlowField(mol.valence_model(atoms), delay=0.02)
            mol.finite_difference_hessian(atoms, calc, client={address!r}, cache={str(cache)!r},
                                          calculator_key="valence h2o", progress=die_after_12,
                                          symmetry=False)
    """))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), str(TESTS)]))
    run = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, timeout=120)
    assert run.returncode == -signal.SIGKILL, run.stderr.decode()[-2000:]
    assert len(list(cache.glob("*.npy"))) == 12           # written as the results arrived
    assert not list(cache.glob(".*"))                      # no temporary file left
    atoms = mol.h2o_atoms()
    model = mol.valence_model(atoms)
    rerun = mol.finite_difference_hessian(atoms, SlowField(model, count_dir=str(counts)), client=dask_client,
                                          cache=cache, calculator_key="valence h2o", symmetry=False)
    assert (rerun.n_cached, rerun.n_force_calls, rerun.n_noise_calls) == (12, 37 - 12, PROBE_CALLS)
    assert len(list(counts.iterdir())) == 37 - 12 + PROBE_CALLS  # counted in the worker processes
    assert rerun.noise_source == "probed"                  # deterministic: rounding, as the listed class gets
    assert len(list(cache.glob("*.npy"))) == 37
    _assert_identical(mol.finite_difference_hessian(atoms, mol.ValenceForceField(model), symmetry=False), rerun)


def test_noise_probe_runs_on_the_cluster_even_when_every_force_is_cached(dask_client, tmp_path) -> None:
    """The probe goes where the force calls go (a worker), also when the cache holds every geometry."""
    cache, counts = tmp_path / "cache", tmp_path / "counts"
    counts.mkdir()
    atoms = mol.h2o_atoms()
    calc = PidField(mol.valence_model(atoms), str(counts))
    serial = mol.finite_difference_hessian(atoms, calc, cache=cache, calculator_key="valence h2o", symmetry=False)
    here = {p.name.split("-")[0] for p in counts.iterdir()}
    assert here == {str(os.getpid())} and len(list(counts.iterdir())) == 37 + PROBE_CALLS
    for p in counts.iterdir():
        p.unlink()
    again = mol.finite_difference_hessian(atoms, calc, cache=cache, calculator_key="valence h2o", client=dask_client,
                                          symmetry=False)
    assert (again.n_cached, again.n_force_calls, again.n_noise_calls) == (37, 0, PROBE_CALLS)
    workers = {str(pid) for pid in dask_client.run(os.getpid).values()}
    assert len(list(counts.iterdir())) == PROBE_CALLS
    assert {p.name.split("-")[0] for p in counts.iterdir()} <= workers
    _assert_identical(serial, again)


def test_failing_geometry_is_named_and_the_others_stay_in_the_cache(dask_client, tmp_path) -> None:
    atoms = mol.co2_atoms()
    calc = FailingField(mol.valence_model(atoms))
    with pytest.raises(RuntimeError, match=r"2 of 37 force calls failed: calculator failed at atom 1 displaced by "
                       r"\+1h along y: RuntimeError: SCF did not converge; .*atom 1 displaced by \+2h along y.*"
                       r"35 finished force call\(s\) kept in the cache"):
        mol.finite_difference_hessian(atoms, calc, client=dask_client, cache=tmp_path, symmetry=False)
    assert len(list(tmp_path.glob("*.npy"))) == 37 - 2


def test_serial_failure_is_named_too(tmp_path) -> None:
    atoms = mol.co2_atoms()
    with pytest.raises(RuntimeError, match=r"calculator failed at atom 1 displaced by \+1h along y: "
                       r"RuntimeError: SCF did not converge \(17 finished"):
        mol.finite_difference_hessian(atoms, FailingField(mol.valence_model(atoms)), cache=tmp_path, symmetry=False)
    assert len(list(tmp_path.glob("*.npy"))) == 17  # the reference, atom 0 x, y, z and atom 1 x (+-h, +-2h each)


# ---------------------------------------------------------------- the cache
def test_serial_cache_resumes_and_a_corrupt_file_is_recomputed(tmp_path) -> None:
    """The cache keeps the serial result bit for bit; a damaged file is detected and recomputed."""
    atoms = mol.h2o_atoms()
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    first = mol.finite_difference_hessian(atoms, calc, cache=tmp_path, symmetry=False)
    assert (first.n_force_calls, first.n_cached) == (37, 0)
    files = sorted(tmp_path.glob("*.npy"))
    assert len(files) == 37
    assert {oct(f.stat().st_mode & 0o777) for f in files} == {oct(0o666 & ~_umask())}
    files[3].write_bytes(files[3].read_bytes()[:-8])       # truncated
    with pytest.warns(CacheWarning, match="recomputing"):
        again = mol.finite_difference_hessian(atoms, calc, cache=tmp_path, symmetry=False)
    assert (again.n_force_calls, again.n_cached) == (1, 36)
    _assert_identical(first, again)
    four = mol.finite_difference_hessian(atoms, calc, cache=tmp_path, stencil=4, estimate_error=False, symmetry=False)
    assert (four.n_force_calls, four.n_cached) == (0, 37)  # +-h and +-2h of every dof: all there


def test_cache_key_separates_steps_geometries_and_calculators(tmp_path) -> None:
    atoms = mol.h2o_atoms()
    model = mol.valence_model(atoms)
    mol.finite_difference_hessian(atoms, mol.ValenceForceField(model), cache=tmp_path, estimate_error=False)
    other_step = mol.finite_difference_hessian(atoms, mol.ValenceForceField(model), cache=tmp_path, step=0.02,
                                               estimate_error=False)
    assert other_step.n_cached == 1                        # only the reference geometry is shared
    moved = atoms.copy()
    moved.positions[0, 0] += 1e-9
    assert mol.finite_difference_hessian(moved, mol.ValenceForceField(model), cache=tmp_path,
                                         estimate_error=False).n_cached == 0
    stiffer = mol.valence_model(atoms, stretch=2.0 * mol.H2O_STRETCH)
    assert mol.finite_difference_hessian(atoms, mol.ValenceForceField(stiffer), cache=tmp_path,
                                         estimate_error=False).n_cached == 0


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# ---------------------------------------------------------------- bad input
def test_unreachable_scheduler_fails_within_the_timeout_and_writes_nothing(tmp_path, client_timeouts) -> None:
    atoms = mol.h2o_atoms()
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    with pytest.raises(ClusterError, match=r"no Dask scheduler answered at 'tcp://127\.0\.0\.1:9' within 1 s"):
        mol.finite_difference_hessian(atoms, calc, client="tcp://127.0.0.1:9", timeout=1.0,
                                      cache=tmp_path / "cache")
    assert client_timeouts == [1.0]
    assert not (tmp_path / "cache").exists()


@pytest.mark.parametrize("client, error, match", [
    ("nowhere", ValueError, r"client is 'nowhere'; expected 'local' or a scheduler address"),
    (42, TypeError, r"client must be None, 'local', a scheduler address or a dask\.distributed\.Client, got int"),
])
def test_malformed_client_is_refused_before_any_force_call(client, error, match) -> None:
    atoms = mol.h2o_atoms()
    calc = SlowField(mol.valence_model(atoms), delay=10.0)  # would take minutes if called
    with pytest.raises(error, match=match):
        mol.finite_difference_hessian(atoms, calc, client=client)


def test_unpicklable_calculator_needs_a_factory_on_a_cluster_and_a_key_for_the_cache(tmp_path) -> None:
    atoms = mol.h2o_atoms()
    calc = LockedField(mol.valence_model(atoms))
    with pytest.raises(TypeError, match=r"cannot be pickled .* pass a factory instead"):
        mol.finite_difference_hessian(atoms, calc, client="local")
    with pytest.raises(TypeError, match=r"the cache needs calculator_key="):
        mol.finite_difference_hessian(atoms, calc, cache=tmp_path)
    serial = mol.finite_difference_hessian(atoms, calc)      # serially it is used directly
    keyed = mol.finite_difference_hessian(atoms, calc, cache=tmp_path, calculator_key="valence h2o")
    _assert_identical(serial, keyed)


def test_default_cache_key_is_the_same_in_every_process() -> None:
    """A rerun (a new process, another hash seed) must find the files of the killed run."""
    code = ("import functools; from vibra import molecules as mol; "
            "from vibra.molecules.displacements import CalculatorSource; from tblite.ase import TBLite; "
            "a = mol.h2o_atoms(); "
            "print(CalculatorSource(mol.ValenceForceField(mol.valence_model(a))).digest(), "
            "CalculatorSource(functools.partial(TBLite, method='GFN2-xTB')).digest())")
    outputs = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                              env=dict(os.environ, PYTHONHASHSEED=seed, PYTHONPATH=str(ROOT))).stdout
               for seed in ("1", "2")}
    assert len(outputs) == 1 and len(outputs.pop().split()) == 2


def test_from_calculator_passes_client_and_cache_on(dask_client, tmp_path) -> None:
    atoms = mol.co2_atoms()
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    serial = mol.from_calculator(atoms, calc, symmetry=False)
    parallel = mol.from_calculator(atoms, calc, client=dask_client, cache=tmp_path, symmetry=False)
    np.testing.assert_array_equal(serial.hessian().toarray(), parallel.hessian().toarray())
    assert len(list(tmp_path.glob("*.npy"))) == 1 + 6 * 3


def test_a_cache_file_declaring_a_huge_array_is_recomputed_without_reading_it(tmp_path) -> None:
    """The header is read first (issue 44): a file declaring 10^9 forces is skipped, never allocated."""
    atoms = mol.h2o_atoms()
    calc = mol.ValenceForceField(mol.valence_model(atoms))
    first = mol.finite_difference_hessian(atoms, calc, cache=tmp_path, symmetry=False)
    target = sorted(tmp_path.glob("*.npy"))[5]
    header = {"descr": "<f8", "fortran_order": False, "shape": (10**9, 3)}
    with open(target, "wb") as handle:
        np.lib.format.write_array_header_1_0(handle, header)
        handle.write(b"\0" * 64)                           # 64 bytes where 24 GB are declared
    with pytest.warns(CacheWarning, match=r"declares float64 \(1000000000, 3\), not \(3, 3\) float64 forces"):
        again = mol.finite_difference_hessian(atoms, calc, cache=tmp_path, symmetry=False)
    assert (again.n_force_calls, again.n_cached) == (1, 36)
    _assert_identical(first, again)
