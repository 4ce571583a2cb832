"""The ``slepc`` path (issue 47 item 3): the lowest modes of an elastic network on SLEPc over MPI.

Truth comes from outside the code under test: scipy's LAPACK ``eigh`` of the dense K~ (the
eigenvalues, and the subspaces through their principal angles), the matrix the hand-off files
hold against K~ itself, and the messages' required content. The MPI runs skip, with the reason,
where mpiexec or a Python with slepc4py is missing (`distributed.slepc.unavailable`); CI installs
them (.ci/run: ``apt-get install python3-slepc4py libopenblas0-serial``).

The network: ubiquitin's heavy atoms (networks/ubiquitin/1ubi.pdb, 602 sites, 1,806 dofs), ANM
within 7 Å, seeded masses in 12..16: a free network with exactly six rigid-body modes.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp

from vibra import networks, normal_modes, solvers
from vibra.solvers import registry
from vibra.solvers.common import mass_weighted
from vibra.solvers.distributed import slepc as slepc_module
from vibra.solvers.distributed import SlepcUnavailableError, slepc_path, unavailable

ROOT = Path(__file__).resolve().parents[2]
N_MODES = 26  # the 6 rigid-body modes and 20 more
EPS = np.finfo(float).eps

REASON = unavailable()
needs_mpi = pytest.mark.skipif(REASON is not None, reason=f"the slepc path cannot run here: {REASON}")


@pytest.fixture(scope="module")
def network() -> tuple[sp.csr_matrix, np.ndarray]:
    structure = networks.from_pdb(ROOT / "networks" / "ubiquitin" / "1ubi.pdb", "protein")
    masses = np.random.default_rng(7).uniform(12.0, 16.0, structure.n_sites)
    system = networks.anm(structure.positions, cutoff=7.0, masses=masses)
    return sp.csr_matrix(system.hessian()), system.mass_matrix()


@pytest.fixture(scope="module")
def truth(network: tuple[sp.csr_matrix, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Every eigenpair of the dense K~ (scipy, LAPACK syevd)."""
    K, mass = network
    return la.eigh(mass_weighted(K, mass).toarray())


@needs_mpi
def test_two_ranks_give_the_lowest_modes_of_the_dense_solve(monkeypatch: pytest.MonkeyPatch, network, truth) -> None:
    K, mass = network
    values, vectors = truth
    monkeypatch.setenv("VIBRA_MPI_RANKS", "2")
    modes = normal_modes(K, mass, n_modes=N_MODES, solver="slepc")
    assert modes.solver == "slepc"
    norm = float(np.abs(values).max())
    assert np.sum(values < 1e-10 * norm) == 6  # (the truth: six rigid-body modes, then a gap)
    # Eigenvalues: both solves are backward stable, each value within ~n eps ||K~|| of the exact
    # one (n = 1,806: 4e-13 ||K~||) plus the Krylov residual's square over the gap, far less;
    # relative to the smallest nonzero value (||K~|| / lambda_7 ~ 2e3 here) that is ~1e-9 at
    # worst, so 1e-10 (the target) holds with the bound's n eps taken as ~sqrt(n) eps,
    # as measured (3e-13); the rigid ones, absolutely, within 1e-12 ||K~||
    got = modes.omega_squared
    assert np.all(np.abs(got[:6]) <= 1e-12 * norm)
    np.testing.assert_allclose(got[6:], values[6:N_MODES], rtol=1e-10, atol=0)
    # Subspaces (Davis-Kahan): sin(angle) <= ||R|| / gap, the gap to the first mode left out;
    # the residual bound is the one slepc reports per mode (checked below against K~)
    Kt = mass_weighted(K, mass)
    residual = float(np.linalg.norm(Kt @ modes.vectors - modes.vectors * got, axis=0).max())
    gap = values[N_MODES] - values[N_MODES - 1]
    bound = np.sqrt(N_MODES) * residual / gap + 1e-12
    assert np.max(la.subspace_angles(modes.vectors, vectors[:, :N_MODES])) <= bound
    assert np.max(la.subspace_angles(modes.vectors[:, :6], vectors[:, :6])) <= bound
    # the modes are mass-orthonormal shapes, as any network solve returns
    np.testing.assert_allclose(modes.shapes.T @ (mass[:, None] * modes.shapes), np.eye(N_MODES), atol=1e-12)
    assert residual <= slepc_module.RESIDUAL_RTOL * norm


@needs_mpi
def test_one_rank_agrees_and_an_indefinite_k_moves_the_shift(network, truth) -> None:
    K, mass = network
    values, _ = truth
    Kt = mass_weighted(K, mass)
    lowered = sp.csr_matrix(Kt - 0.5 * values[6] * sp.identity(Kt.shape[0]))  # six eigenvalues now below zero
    accounts: list[dict] = []
    result = slepc_path(lowered, n_modes=N_MODES, vectors=False, n_ranks=1, on_account=accounts.append)
    assert result.vectors is None and result.solver == "slepc"
    # the factor's inertia showed eigenvalues below the first shift: the second lies below Gershgorin's bound
    assert accounts[0]["sigma"] < -0.5 * values[6] and accounts[0]["inertia"] == [0, 0]
    expected = values[:N_MODES] - 0.5 * values[6]
    np.testing.assert_allclose(result.eigenvalues, expected, rtol=0, atol=1e-10 * float(np.abs(values).max()))


@needs_mpi
def test_the_inputs_are_written_whole_and_removed(network) -> None:
    K, mass = network
    Kt = sp.csr_matrix(mass_weighted(K, mass))
    seen: dict[str, object] = {}

    def look(folder: Path) -> None:
        seen["folder"] = folder
        seen["names"] = sorted(p.name for p in folder.iterdir())
        request = json.loads((folder / "request.json").read_text())
        arrays = [np.load(folder / f"{name}.npy") for name in ("data", "indices", "indptr")]
        seen["matrix"] = sp.csr_matrix(tuple(arrays), shape=(request["n"], request["n"]))  # type: ignore[arg-type]
        seen["request"] = request

    slepc_path(Kt, n_modes=8, vectors=True, n_ranks=1, on_folder=look)
    # only the complete files (no temporary name of the atomic writer), the request last
    assert seen["names"] == ["data.npy", "indices.npy", "indptr.npy", "request.json"]
    assert (seen["matrix"] != Kt).nnz == 0  # type: ignore[union-attr]  # bit for bit
    assert seen["request"]["n_modes"] == 8 and seen["request"]["ranks"] == 1  # type: ignore[index]
    assert not Path(seen["folder"]).exists()  # type: ignore[arg-type]


def test_a_failed_write_leaves_no_file_and_no_folder(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("VIBRA_SLEPC_TMPDIR", str(tmp_path))
    monkeypatch.setattr(slepc_module, "launch_settings", lambda: (["mpiexec"], sys.executable))
    real_save = np.save

    def failing_save(handle, array):  # the second array's write fails half way
        if array.dtype == np.int64 and array.shape[0] != 41:
            handle.write(b"\x93NUMPY partial")
            raise OSError("disk full")
        real_save(handle, array)

    monkeypatch.setattr(slepc_module.np, "save", failing_save)
    with pytest.raises(OSError, match="disk full"):
        slepc_path(sp.identity(40, format="csr"), n_modes=3, vectors=False, n_ranks=1)
    assert list(tmp_path.iterdir()) == []  # the folder, its complete file and the partial one all gone


def test_missing_tools_name_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    K = sp.identity(40, format="csr")
    monkeypatch.setenv("VIBRA_MPIEXEC", "no-such-mpiexec --flag")
    with pytest.raises(SlepcUnavailableError, match=r"'no-such-mpiexec' \(VIBRA_MPIEXEC\) is not on the PATH; "
                       r"install it: apt-get install python3-slepc4py"):
        normal_modes(K, np.ones(40), n_modes=3, solver="slepc")
    monkeypatch.setenv("VIBRA_MPIEXEC", sys.executable)  # (any program on the path passes that check)
    monkeypatch.setenv("VIBRA_SLEPC_PYTHON", "/no/such/python3")
    with pytest.raises(SlepcUnavailableError, match=r"'/no/such/python3' \(VIBRA_SLEPC_PYTHON\) is not there"):
        normal_modes(K, np.ones(40), n_modes=3, solver="slepc")
    assert "VIBRA_SLEPC_PYTHON" in str(unavailable())
    assert issubclass(SlepcUnavailableError, ImportError) and issubclass(SlepcUnavailableError, RuntimeError)


@pytest.mark.skipif(REASON is not None and "VIBRA_MPIEXEC" in REASON, reason=f"no MPI launcher: {REASON}")
def test_a_python_without_slepc4py_is_named(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("VIBRA_SLEPC_PYTHON", sys.executable)  # vibra's own environment: no petsc4py there
    if _imports(sys.executable, "slepc4py"):
        pytest.skip("this environment has slepc4py itself")
    with pytest.raises(SlepcUnavailableError,
                       match=r"cannot import petsc4py/slepc4py .*apt-get install python3-slepc4py"):
        slepc_path(sp.identity(40, format="csr"), n_modes=3, vectors=False, n_ranks=1)
    assert "cannot import petsc4py/slepc4py" in str(unavailable())


def _imports(python: str, module: str) -> bool:
    import subprocess

    return subprocess.run([python, "-c", f"import {module}"], capture_output=True, check=False).returncode == 0


def test_bad_requests_are_refused_before_any_run(monkeypatch: pytest.MonkeyPatch) -> None:
    K = sp.identity(40, format="csr")
    with pytest.raises(ValueError, match=r"solver='slepc' .* give n_modes below n_dof - 1 = 39"):
        normal_modes(K, np.ones(40), solver="slepc")
    with pytest.raises(ValueError, match=r"solver='slepc'"):
        normal_modes(K, np.ones(40), band=(0.0, 1.0), solver="slepc")
    monkeypatch.setenv("VIBRA_MPI_RANKS", "two")
    with pytest.raises(ValueError, match=r"VIBRA_MPI_RANKS is 'two'; expected a positive integer"):
        normal_modes(K, np.ones(40), n_modes=3, solver="slepc")


def test_the_path_is_only_taken_when_named_and_its_estimate_comes_from_sizes() -> None:
    K = sp.identity(4000, format="csr")
    assert solvers.plan(K, np.ones(4000), n_modes=6, vectors=True, band=None, solver="auto",
                        spring_factor=None).path != "slepc"
    plan = solvers.plan(K, np.ones(4000), n_modes=6, vectors=True, band=None, solver="slepc", spring_factor=None)
    assert plan.path == "slepc" and plan.solver == "slepc"
    small, large = (registry.estimate("slepc", n, k=26, vectors=True, nnz=100 * n, width=n) for n in (10**4, 10**5))
    assert 0 < small.seconds < large.seconds and 0 < small.memory < large.memory


@needs_mpi
def test_a_scene_names_the_slepc_path() -> None:
    import tomllib

    from vibra.pipeline.plan.build import build_system
    from vibra.pipeline.scene import Scene

    path = ROOT / "networks" / "ubiquitin" / "ubiquitin-anm.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["compute"]["solver"] = "slepc"
    scene = Scene.from_dict(data, source=path)
    assert scene.compute.solver == "slepc"
    system = build_system(scene)
    modes = system.modes(scene.compute.n_modes, solver=scene.compute.solver)
    values = la.eigh(mass_weighted(sp.csr_matrix(system.hessian()), system.mass_matrix()).toarray(), eigvals_only=True)
    assert modes.solver == "slepc"
    np.testing.assert_allclose(modes.omega_squared[6:], values[6:26], rtol=1e-10, atol=0)  # (as above)
