"""The ``slepc`` path: the lowest modes of a large sparse K~ on SLEPc over MPI, in a separate program.

vibra's environment need not hold PETSc: the solve runs as
``mpiexec -n R <python> slepc_worker.py FOLDER``, where <python> is a Python with petsc4py and
slepc4py (Debian: ``/usr/bin/python3`` after ``apt-get install python3-slepc4py``, which brings
OpenMPI's ``mpiexec``). This side writes K~ = M^-1/2 K M^-1/2 into a fresh temporary folder
(three ``.npy`` CSR arrays, each written atomically, `vibra._core.filesystem.atomic_write`, then
``request.json`` last), runs the worker, reads the eigenpairs back, checks every residual again
here (`common.absolute_figures` on K~ itself) and removes the folder, whatever happened.

Why ``.npy`` and not PETSc's binary format: numpy writes and reads it on both sides with no
PETSc here, and each rank memory-maps the arrays and reads only its own block of rows (a
parallel read on a shared file system), where PETSc's binary file would need a writer of our
own and is read through rank 0.

Where it runs is configured by the environment, not by arguments, so that ``solver="slepc"``
serves `normal_modes`, `System.modes` and scene files (``compute.solver = "slepc"``) alike:

- ``VIBRA_MPI_RANKS``: processes (default 1);
- ``VIBRA_MPIEXEC``: the launcher and its options, split on spaces (default ``mpiexec``; on a
  cluster ``srun`` or ``mpiexec --hostfile hosts``);
- ``VIBRA_SLEPC_PYTHON``: the Python with slepc4py (default ``/usr/bin/python3``);
- ``VIBRA_SLEPC_TMPDIR``: where the hand-off folder goes (default the system's temporary folder;
  on a cluster a folder every node sees).
"""

from __future__ import annotations

import glob
import json
import os
import shlex
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any, Callable, TypedDict

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from vibra._core.filesystem import atomic_write
from vibra.solvers.common import SolveResult, absolute_figures, norm_upper, small_pencil

__all__ = ["SlepcUnavailableError", "INSTALL", "WORKER", "RESIDUAL_RTOL", "TOLERANCE", "SHIFT", "launch_settings",
           "ranks", "slepc_cost", "slepc_path", "unavailable", "write_inputs"]

#: The program each MPI rank runs (by path; it imports nothing from vibra).
WORKER = Path(__file__).with_name("slepc_worker.py")

#: What to install where the path cannot run (Debian / Ubuntu; a cluster: its petsc and slepc modules).
INSTALL = "apt-get install python3-slepc4py (Debian's petsc4py, slepc4py and OpenMPI's mpiexec)"

#: SLEPc's convergence tolerance: each pair's error estimate relative to its transformed eigenvalue
#: 1 / (lambda - sigma); 1e-12 leaves the residuals near eps ||K~|| (measured: ~1e-15 ||K~||).
TOLERANCE = 1e-12

#: The largest residual ||K~ v - lambda v|| / ||K~|| accepted (checked here, on K~ itself). A
#: backward-stable solve gives ~n eps; 1e-9 still bounds each eigenvalue's error by the residual
#: (Weyl) at 1e-9 ||K~|| and, through the gap, far below it (r^2 / gap).
RESIDUAL_RTOL = 1e-9


#: The shift, -SHIFT ||K~||_inf: below the spectrum of a semidefinite K~ and below the lowest
#: nonzero eigenvalue of a 3-D network (~n^-2/3 ||K~||: 1e-4 at 10^6 dofs), yet far enough from the
#: zero modes that the shifted solves stay accurate: cond(K~ - sigma) = 1e6, so each solve's
#: rounding (~eps cond) leaves residuals near 1e-14 ||K~|| (measured on ubiquitin's ANM: a shift
#: of 1e4 eps ||K~||, the one-process path's, left 2e-8 whatever SLEPc's tolerance; 1e-8 left 6e-12;
#: 1e-6 and 1e-4 about 1e-14). A free chain, whose lowest values sit far below, has its own paths.
SHIFT = 1e-6


# ---- the cost model (`slepc_cost`), calibrated on benchmarks/bench_slepc.py here (RESULTS.md, "SLEPc over
# MPI"): 2 cores shared with other work, Debian's PETSc 3.18, MUMPS 5.5 on OpenBLAS, one rank
LAUNCH_S = 1.5           # per run: mpiexec, the worker's Python, petsc4py and slepc4py starting (measured 1.5 s)
HANDOFF_S = 2e-9         # per byte of the hand-off files, written and read back
FACTOR_S = 1.2e-8        # per n^2: MUMPS's LDL^T of a 3-D network's K~ - sigma (measured 1.8e-8 at 9e3 dofs, 9e-9 at 1e5)
SOLVE_S = 2e-7           # per n^(4/3) and shifted solve (2 ncv + k of them: Krylov-Schur's restarts, the refinement;
                         # measured 3.3e-7 at 9e3 dofs, 1.1e-7 at 1e5)
FACTOR_BYTES = 800.0     # per n^(4/3): the factor and the Krylov basis, all ranks together (3.7 GB peak at 1e5 dofs)
RANK_BYTES = 1.2e8       # per rank: a Python with petsc4py and slepc4py loaded (~100 MB measured)


class SlepcUnavailableError(ImportError, RuntimeError):
    """``solver="slepc"`` was asked for, but mpiexec or a Python with slepc4py is missing (the
    message names which, and what to install). An `ImportError` and a `RuntimeError`, as
    `vibra.solvers.standard.gpu.GPUUnavailableError`."""


def ranks() -> int:
    """MPI processes of the ``slepc`` path: ``VIBRA_MPI_RANKS`` (default 1).

    Raises ValueError naming the variable when it is not a positive integer."""
    text = os.environ.get("VIBRA_MPI_RANKS", "1").strip()
    if not text.isdigit() or int(text) < 1:
        raise ValueError(f"VIBRA_MPI_RANKS is {text!r}; expected a positive integer (MPI processes)")
    return int(text)


def launch_settings() -> tuple[list[str], str]:
    """(the launcher command, the worker's Python) from the environment (`VIBRA_MPIEXEC`,
    `VIBRA_SLEPC_PYTHON`), each checked to exist: `SlepcUnavailableError` naming the install."""
    launcher = shlex.split(os.environ.get("VIBRA_MPIEXEC", "mpiexec"))
    python = os.environ.get("VIBRA_SLEPC_PYTHON", "/usr/bin/python3")
    if not launcher or shutil.which(launcher[0]) is None:
        raise SlepcUnavailableError(f"solver='slepc' needs an MPI launcher: {launcher[0] if launcher else '(empty)'!r} "
                                    f"(VIBRA_MPIEXEC) is not on the PATH; install it: {INSTALL}")
    if shutil.which(python) is None:
        raise SlepcUnavailableError(f"solver='slepc' needs a Python with slepc4py: {python!r} (VIBRA_SLEPC_PYTHON) "
                                    f"is not there; install it: {INSTALL}")
    return launcher, python


def slepc_cost(n: int, nnz: int, k: int, n_ranks: int) -> tuple[float, float]:
    """(bytes, seconds) of the lowest k modes of a 3-D network of n dofs and nnz stored entries on
    `n_ranks` ranks of this machine, from sizes alone: the start, the hand-off (12 nnz + 8 n k bytes
    written, 8 n k read), MUMPS's two factors and the shifted solves; no speed-up counted for ranks
    (measured: none on 2 shared cores; on a cluster see docs/distributed.md); memory the factor
    and the parent's copies (the CSR arrays, the vectors, the residual check)."""
    n_f = float(n)
    handoff = 12.0 * nnz + 16.0 * n_f * k
    solves = 2.0 * max(2 * k + 1, k + 32) + k
    # two factors: the shifted matrix's, and that of Sylvester's count after the solve
    seconds = LAUNCH_S + HANDOFF_S * handoff + 2.0 * FACTOR_S * n_f * n_f + SOLVE_S * n_f ** (4.0 / 3.0) * solves
    memory = FACTOR_BYTES * n_f ** (4.0 / 3.0) + RANK_BYTES * n_ranks + 12.0 * nnz + 3 * 8.0 * n_f * k
    return memory, seconds


def unavailable() -> str | None:
    """Why the ``slepc`` path cannot run here (one line, naming what to install), or None when it
    can: the launcher and the worker's Python found, and that Python importing petsc4py and
    slepc4py (a subprocess, ~0.3 s)."""
    try:
        _, python = launch_settings()
    except SlepcUnavailableError as error:
        return str(error)
    probe = subprocess.run([python, "-c", "import petsc4py, slepc4py"], env=_environment(1), capture_output=True,
                           text=True, check=False)
    if probe.returncode != 0:
        return (f"solver='slepc': {python} cannot import petsc4py/slepc4py (VIBRA_SLEPC_PYTHON); install them: "
                f"{INSTALL}")
    return None


def _environment(n_ranks: int) -> dict[str, str]:
    """The worker's environment: Debian's PETSc and SLEPc found where no alternative link points at
    them (``/usr/lib/petsc`` comes only with the -dev packages), one BLAS thread per rank, and
    OpenMPI allowed to run as root (a container, CI) and to start more ranks than cores."""
    environment = dict(os.environ)
    for name, link, pattern in (("PETSC_DIR", "/usr/lib/petsc", "/usr/lib/petscdir/petsc*/*-real"),
                                ("SLEPC_DIR", "/usr/lib/slepc", "/usr/lib/slepcdir/slepc*/*-real")):
        if name not in environment and not os.path.isdir(link):
            found = sorted(glob.glob(pattern))
            if found:
                environment[name] = found[-1]
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        environment[name] = "1"
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        environment.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
        environment.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    if n_ranks > (os.cpu_count() or 1):
        environment.setdefault("OMPI_MCA_rmaps_base_oversubscribe", "1")
    # a rank waiting for another yields its core instead of spinning (measured on 2 shared
    # cores: 2 ranks' Krylov-Schur phase 37 s spinning, 19 s yielding); a cluster's dedicated
    # cores may set it to 0
    environment.setdefault("OMPI_MCA_mpi_yield_when_idle", "1")
    return environment


def _save(folder: Path, name: str, array: NDArray[Any]) -> None:
    def write(temporary: Path) -> None:
        with open(temporary, "wb") as handle:
            np.save(handle, array)
    atomic_write(folder / name, write)


class SlepcRequest(TypedDict):
    """The request `write_inputs` hands the worker (``request.json``): K~'s size, how many modes, over
    how many ranks, SLEPc's settings (tolerance, iterations, subspace size, the shift sigma, in the
    units of omega^2) and K~'s norm and Gershgorin lower bound (units of omega^2)."""

    n: int
    n_modes: int
    ranks: int
    tolerance: float
    max_it: int
    ncv: int
    sigma: float
    norm: float
    gershgorin_lower: float


def write_inputs(folder: Path, Kt: sp.csr_matrix, *, n_modes: int, n_ranks: int) -> SlepcRequest:
    """K~'s CSR arrays and the request into `folder`, each file atomically (the request last: its
    presence means the rest is complete); returns the request."""
    n = Kt.shape[0]
    norm = norm_upper(Kt)  # ||K~||_inf >= ||K~||_2
    absolute = abs(Kt)
    radius = np.asarray(absolute.sum(axis=1)).ravel() - np.abs(Kt.diagonal())
    request: SlepcRequest = {
        "n": n, "n_modes": n_modes, "ranks": n_ranks, "tolerance": TOLERANCE, "max_it": 1000,
        "ncv": max(2 * n_modes + 1, n_modes + 32),
        "sigma": -SHIFT * norm, "norm": norm,
        "gershgorin_lower": float((Kt.diagonal() - radius).min()) if n else 0.0,
    }
    _save(folder, "indptr.npy", Kt.indptr.astype(np.int64))
    _save(folder, "indices.npy", Kt.indices.astype(np.int64))
    _save(folder, "data.npy", Kt.data.astype(np.float64))
    atomic_write(folder / "request.json", lambda temporary: temporary.write_text(json.dumps(request)))
    return request


def slepc_path(Kt: sp.spmatrix, *, n_modes: int, vectors: bool, n_ranks: int | None = None,
               on_folder: Callable[[Path], None] | None = None,
               on_account: Callable[[dict[str, Any]], None] | None = None) -> SolveResult:
    """The lowest `n_modes` eigenpairs of the sparse K~ by SLEPc over `n_ranks` MPI processes.

    Parameters
    ----------
    Kt : (n, n) scipy.sparse matrix
        The mass-weighted stiffness K~, symmetric, in the units of omega^2.
    n_modes : int
        How many of the lowest modes (a free network's zero modes among them).
    vectors : bool
        Keep the mass-weighted vectors in the result (they are computed and checked either way).
    n_ranks : int, optional
        MPI processes; default `ranks()` (``VIBRA_MPI_RANKS``).
    on_folder : callable, optional
        Called with the hand-off folder once the inputs are written (the tests look at it).
    on_account : callable, optional
        Called with the worker's account (``result.json``: its stages' seconds, restarts,
        SLEPc's residuals, the shift and the factor's inertia; the benchmark records it).

    Returns
    -------
    SolveResult
        Reporting solver "slepc"; `error` the residual of each pair, measured here.

    Raises
    ------
    SlepcUnavailableError
        No launcher, no worker Python, or that Python has no slepc4py (the install line).
    RuntimeError
        The worker failed (its one-line reason), or a residual measured here exceeds
        `RESIDUAL_RTOL` ||K~||.
    """
    Kt = sp.csr_matrix(Kt)
    if not Kt.has_sorted_indices:  # (a sorted copy: the caller's matrix is left as it was)
        Kt = Kt.sorted_indices()
    n_ranks = ranks() if n_ranks is None else int(n_ranks)
    launcher, python = launch_settings()
    parent = os.environ.get("VIBRA_SLEPC_TMPDIR") or None
    folder = Path(tempfile.mkdtemp(prefix="vibra-slepc-", dir=parent))
    try:
        write_inputs(folder, Kt, n_modes=n_modes, n_ranks=n_ranks)
        if on_folder is not None:
            on_folder(folder)
        command = [*launcher, "-n", str(n_ranks), python, str(WORKER), str(folder)]
        finished = subprocess.run(command, env=_environment(n_ranks), capture_output=True, text=True, check=False)
        values, basis, account = _read_result(folder, finished)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    if on_account is not None:
        on_account(account)
    # Rayleigh-Ritz on the returned basis (as the one-process path does): the shifted solves near
    # the zero modes leave each vector a little of the null space (residual ~1e-8 ||K~|| measured),
    # which the basis itself holds, so the k x k step removes it; O(nnz k + n k^2)
    values, rotation = small_pencil(basis.T @ (Kt @ basis), basis.T @ basis)
    basis = basis @ rotation
    result = absolute_figures(Kt, values, basis, "slepc", floor=4.0)
    norm = norm_upper(Kt) or 1.0
    worst = int(np.argmax(result.error)) if result.error.size else 0
    if result.error.size and result.error[worst] > RESIDUAL_RTOL * norm:
        raise RuntimeError(f"slepc: mode {worst} has residual {result.error[worst] / norm:.3g} ||K~|| measured here, "
                           f"over {RESIDUAL_RTOL:g} (SLEPc reported {account['residuals'][worst] / norm:.3g})")
    if not vectors:
        result.vectors = None
    return result


def _read_result(folder: Path, finished: subprocess.CompletedProcess[str]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """The worker's eigenpairs and account, or the error that says why there are none."""
    if "No module named" in finished.stderr and ("petsc4py" in finished.stderr or "slepc4py" in finished.stderr):
        raise SlepcUnavailableError(f"solver='slepc': the worker's Python cannot import petsc4py/slepc4py "
                                    f"(VIBRA_SLEPC_PYTHON); install them: {INSTALL}")
    error = folder / "error.json"
    if error.is_file():
        raise RuntimeError(f"slepc: {json.loads(error.read_text())['error']}")
    if finished.returncode != 0 or not (folder / "result.json").is_file():
        # the worker's own lines (a Python or PETSc error), not the launcher's banner of dashes
        said = [line.strip() for line in finished.stderr.splitlines()
                if "Error" in line or line.startswith("[") and "]" in line[:6]]
        tail = " | ".join(said[-3:] or finished.stderr.strip().splitlines()[-3:])
        raise RuntimeError(f"slepc: the MPI run exited with status {finished.returncode}: {tail or '(no output)'}")
    account = json.loads((folder / "result.json").read_text())
    values = np.load(folder / "values.npy")
    basis = np.array(np.load(folder / "vectors.npy", mmap_mode="r"))
    return values, basis, account
