"""Resource guard of the solver paths: memory and time estimated before any allocation.

`estimate` gives, for one solver path and one request, the memory the path allocates beyond
its input and the time it takes, from operation counts (the cost of each path below) and the
rates in this module. `guard` refuses a request whose estimate exceeds the limits, with the
figures and the cheaper requests that answer the question; `Progress` reports long solves.

Limits (module-level settings; `normal_modes(max_memory=..., max_seconds=..., progress=...)`
overrides them per call):

- `MEMORY_LIMIT`: bytes a solve may allocate; None (the default) means the memory available
  now: the smallest of ``MemAvailable`` (/proc/meminfo), the room under the address-space
  limit (``ulimit -v``, RLIMIT_AS) and under the cgroup memory limit (v2 ``memory.max``, v1
  ``memory.limit_in_bytes``) (`available_memory`, `memory_sources`).
- `TIME_LIMIT_S`: estimated seconds above which a solve is refused (600 s by default, as a
  scene's `vibra.pipeline.scene.limits.DEFAULT_TIME_LIMIT_S`; ``max_seconds=float("inf")`` runs anyway).
- `PROGRESS_AFTER_S`: solves estimated to take longer than this (5 s) report their progress
  on stderr: a line when they start (the estimate), one per stage, one when done.

Costs (n dofs, k modes wanted, b half-bandwidth; rates measured on one ~3 GHz core with
OpenBLAS, rounded so that estimates err on the high side by a small factor), memory beyond
the input, then time:

- dense: 8 n^2 (K~; twice with vectors) + 8 n k; 5e-11 n^3 (values), 1.5e-10 n^3 (vectors).
- accurate-bisection: 1e-6 n k with vectors, 5e-7 n k without (compiled bisection, dstein,
  certificates), + 2e-6 n k where dstebz takes the values (`gk_bisection.compiled_bisection_pays`).
- tridiagonal, accurate-bidiagonal: O(n), 8 n^2 with all vectors (LAPACK allocates them);
  1e-8 n^2 for all values (dqds / MRRR), + 1e-7 n k with vectors. accurate-bidiagonal adds
  the certificates of every value (`triplets`): ~1.3 kB per site, 1e-8 n^2.
- banded (a ring: b = 2): 24 (b + 1) n, + 8 n^2 with vectors; 2e-9 (b + 1) n^2 + 1e-8 n^2.
- sparse, accurate-ritz: (ncv + 2k + 3) n words + the factor (O(n) tridiagonal, ~20 nnz
  otherwise); 2e-8 n ncv per Lanczos run, + 1.0e-8 n^2 for a 3-D network's factor (a sparse
  Cholesky: PARDISO or CHOLMOD; 4 times that for SuperLU's LU where neither loads).
- accurate-ring at "high" from a standard solver (`ring.counted`): the band solve's (all values)
  or shift-invert's (a few), + 5e-9 n k: two double-double counts of K - x M per value.
- accurate-ring (a ring's values): ~40 n words; 1e-8 n^2 (dqds of the cut chain; for the
  lowest k of a long ring, compiled bisection, 5e-7 n k, when cheaper) + 2e-8 n k
  (measured 1.4-2.4e-8 on two cores: roots of its spring form, ~2.5 double-double counts of 2n
  nodes per value, 8 points at a time in SIMD lanes) + at most 5e5 sites of mpmath counts
  (2e-5 s each); with vectors (the lowest k), a Golub-Kahan LU per mode, ~2e-6 n k.
- accurate-rayleigh: 32 n^2; as dense with vectors. accurate-jacobi: 24 n (n_terms + n).
- accurate-checked: time as dense with vectors (the usual case: no refinement); memory the
  larger of that and accurate-jacobi's (a refinement may run).
- Refinement on the accurate paths with a spring factor (checked, jacobi, rayleigh, a long
  ring's band): the singular-triplet step, at most `golub_kahan.TRIPLET_SECONDS` (10 s), and on
  rings up to 6,000 sites the Sturm counts of their certificates, 2e-6 n^2 (`refinement_seconds`).
- A `band` request is estimated as `dispatch.BAND_MODES_ESTIMATE` (64) modes (its count is unknown
  before the solve).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from typing import Callable, TextIO

from vibra.solvers.common import BAND_LIMIT, RING_DENSE_LIMIT
from vibra.solvers.accurate.chain.gk_bisection import DSTEBZ_S, compiled_bisection_pays
from vibra.solvers.accurate.golub_kahan import HIGH_ROWS, triplet_seconds
from vibra.solvers.standard.cholmod import sparse_backend

#: Bytes a solve may allocate; None means the memory available when the solve starts.
MEMORY_LIMIT: float | None = None

#: Estimated seconds above which a solve is refused (override: ``max_seconds=``).
TIME_LIMIT_S = 600.0

#: Solves estimated to take longer than this report progress on stderr.
PROGRESS_AFTER_S = 5.0

# Seconds per unit of work (see the table in the module docstring).
# (the measurements behind them: benchmarks/RESULTS.md, "Figures formerly in code comments")
DENSE_VALUES_S = 5e-11        # per n^3: Householder tridiagonalisation + MRRR values
DENSE_VECTORS_S = 1.5e-10     # per n^3: the same with back-transformed vectors
TRIDIAGONAL_S = 1e-8          # per n^2: dqds / MRRR values of a tridiagonal or bidiagonal
TRIDIAGONAL_VECTORS_S = 1e-7  # per n k: MRRR / inverse-iteration vectors, written out
BANDED_S = 2e-9               # per (b + 1) n^2: band reduction
LANCZOS_S = 2e-8              # per n k (ncv): one shift-invert Lanczos run
SPARSE_FACTOR_S = 1.0e-8      # per n^2: a 3-D network's factor and its solves (a sparse Cholesky; RESULTS.md)
SUPERLU_SLOWER = 4.0          # SuperLU's LU against a sparse Cholesky (PARDISO, CHOLMOD) there
JACOBI_S = 5e-10              # per n^3: one-sided Jacobi SVD
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


def estimate(path: str, n: int, *, k: int, vectors: bool, width: int = 1, n_terms: int = 0,
             nnz: int = 0, accuracy: str = "high", one_dimensional: bool = False, chain: bool = False,
             ring_route: str | None = None) -> Estimate:
    """Memory and time of `path` computing `k` of `n` modes (with vectors or not) at `accuracy`
    (which bound-tightening steps are counted: `refinement_seconds`)."""
    n2 = float(n) * n
    vector_bytes = 8.0 * n * k if vectors else 0.0
    what = f"{'all ' if k == n else ''}{k} mode{'s' if k != 1 else ''} of {n} dofs" + (
        ", with vectors" if vectors else ", frequencies only")
    if path in ("dense", "gpu"):  # (the GPU path checks the device's own memory before allocating)
        memory = 8.0 * n2 * (2 if vectors else 1) + vector_bytes + 8.0 * 26 * n
        seconds = (DENSE_VECTORS_S * k / n + DENSE_VALUES_S) * n2 * n if vectors else DENSE_VALUES_S * n2 * n
    elif path in ("tridiagonal", "accurate-bidiagonal"):
        # LAPACK stemr and the dqds + MRRR pairing allocate all n vectors unless a subset is asked.
        memory = 8.0 * 12 * n + (8.0 * n2 if vectors and k == n else vector_bytes)
        if path == "accurate-bidiagonal":  # dqds of all values, each certified (`triplets`)
            memory += CERTIFY_BYTES * n
            values_s = (TRIDIAGONAL_S + CERTIFY_S) * n2
        else:
            values_s = TRIDIAGONAL_S * (n2 if k == n else 60.0 * n * k)
        seconds = values_s + (TRIDIAGONAL_VECTORS_S * n * k if vectors else 0.0)
    elif path in ("banded", "accurate-ring-band"):
        memory = 8.0 * (width + 1) * n * 3 + (8.0 * n2 + vector_bytes if vectors else 0.0)
        # the band's reduction to tridiagonal, then its values as on the tridiagonal path (a
        # subset by bisection; figures: benchmarks/RESULTS.md, "Figures formerly in code comments")
        values_s = TRIDIAGONAL_S * (n2 if k == n else 60.0 * n * k)
        seconds = BANDED_S * (width + 1) * n2 + values_s + (DENSE_VECTORS_S * n2 * n if vectors else 0.0)
    elif path in ("sparse", "accurate-ritz"):
        # ARPACK's restarted basis for a narrow band (a chain, a ring reordered: a cheap
        # factor); the block Krylov basis (up to max(10 k, 200) columns, `krylov.block_eigs`)
        # for any other
        columns = max(2 * k + 1, 20) if width <= BAND_LIMIT else min(n, max(10 * k, 200))
        # the basis + the factor: O(n) for a tridiagonal K~ (pttrf), ~20 nnz (SuperLU fill) else
        memory = 8.0 * (columns + 2 * k + 3) * n + (8.0 * 4 * n if width <= 1 else 12.0 * 20 * max(nnz, n))
        seconds = LANCZOS_S * n * columns * 10 + 1e-9 * n * k * k
        if width > 16:  # a 3-D network: its factor's cost grows as n^2 (nested dissection)
            seconds += SPARSE_FACTOR_S * n2 * (SUPERLU_SLOWER if sparse_backend(n) == "superlu" else 1.0)
    elif path == "accurate-bisection":
        # Sturm bisection (dstebz) on the 2n Golub-Kahan tridiagonal, inverse iteration (dstein),
        # the certificates' double-double residuals in blocks (measured peak ~430 n bytes)
        memory = 8.0 * 64 * n + vector_bytes
        seconds = (BISECTION_VECTORS_S if vectors else BISECTION_VALUES_S) * n * k
        if not compiled_bisection_pays(n, k):  # the values by dstebz (no numba to load), 2e-6 n k
            seconds += DSTEBZ_S * n * k
    elif path == "accurate-ring" and ring_route == "sparse":
        # shift-invert's values, bracketed by ~2 k double-double counts per level (two levels seen)
        cost = estimate("sparse", n, k=k, vectors=vectors, width=width, nnz=nnz)
        memory, seconds = cost.memory, cost.seconds + RING_S * float(n) * k
    elif path == "accurate-ring" and ring_route == "banded":
        # the band solver's values, bracketed by two double-double counts of K - x M each (a
        # double eigenvalue's two by the same two)
        cost = estimate("banded", n, k=k, vectors=False, width=width)
        memory, seconds = cost.memory + 8.0 * 12 * n, cost.seconds + RING_COUNTED_S * float(n) * k
    elif path in ("accurate-ring", "accurate-walled"):
        # the cut chain's values (dqds, or bisection for the lowest k + 1), then each value's
        # roots and counts (a chain on walls: its values' counts, no roots)
        memory = 8.0 * 40 * n + vector_bytes
        each = BISECTION_VALUES_S  # (the poles: values only)
        poles = TRIDIAGONAL_S * n2 if k >= n - 1 else min(TRIDIAGONAL_S * n2, each * n * (k + 1.0))
        seconds = poles + RING_S * float(n) * k
        if accuracy == "certified":  # (mpmath counts: "high" stops at 1e-10, which the dd counts meet)
            seconds += MP_COUNT_S * min(RING_MP_SITES, RING_MP_EXPECTED * n)
        if vectors and path == "accurate-walled" and k >= n - 1:  # all of them: stemr's (tridiagonal)
            memory += 8.0 * 12 * n
            seconds += TRIDIAGONAL_VECTORS_S * n * k
        elif vectors:  # each mode's sparse LU of the 2n Golub-Kahan matrix (`golub_kahan.singular_vectors`)
            seconds += TRIPLET_UNIT_S * TRIPLET_ROW * 2.0 * n * k
    elif path in ("pencil-jacobi", "pencil-cholesky"):
        # M's and K's equilibrated Cholesky factors, then gejsv on n x n (or eigh of L^-1 K L^-T)
        memory = 8.0 * n2 * 6
        seconds = (JACOBI_S + DENSE_VECTORS_S) * n2 * n if path == "pencil-jacobi" else DENSE_VECTORS_S * 2 * n2 * n
    elif path in ("accurate-rayleigh",):
        # K~ (its vectors in place), divide and conquer's 2 n^2 work space, the mass-weighted K
        memory = 8.0 * n2 * 4
        seconds = DENSE_VECTORS_S * n2 * n
    elif path == "accurate-checked":
        fast = estimate("dense", n, k=min(k + 1, n), vectors=True)
        refined = estimate("accurate-jacobi", n, k=k, vectors=vectors, n_terms=n_terms)
        memory, seconds = max(fast.memory, refined.memory), fast.seconds
    elif path in ("skew-symmetric", "hamiltonian", "companion"):
        # the first-order form of 2n: two Hermitian solves (skew), one or two geev (measured
        # 1.0-1.6e-9 and 2.1-3.2e-9 (2n)^3 s at n = 100..400); complex vectors of 2n, twice
        memory = 200.0 * n2
        seconds = {"skew-symmetric": 2.0, "hamiltonian": 2.2, "companion": 4.4}[path] * 1e-8 * n2 * n
    else:  # accurate-jacobi
        rows = max(n_terms, n)
        memory = 8.0 * rows * n * 3 + (8.0 * n2 if vectors else 0.0)
        seconds = JACOBI_S * rows * n * n
    if n_terms and path in ("accurate-checked", "accurate-jacobi", "accurate-rayleigh", "accurate-ritz"):
        seconds += refinement_seconds(n, n_terms, k=k, accuracy=accuracy, one_dimensional=one_dimensional,
                                      chain=chain and path == "accurate-ritz")
    if path == "accurate-ring-band":  # a ring's band vectors: its frequencies by `ring.values` too
        seconds += RING_S * n2
    return Estimate(path, memory, seconds, what)


def refinement_seconds(n: int, n_terms: int, *, k: int | None = None, accuracy: str = "high",
                       one_dimensional: bool = False, chain: bool = False) -> float:
    """What the accurate paths may add after their solve (a spring factor given), from sizes:

    - the singular-triplet step (`golub_kahan.refine_triplets`: per loose mode one sparse LU of
      the (n_terms + n) Golub-Kahan matrix, `golub_kahan.triplet_seconds` each): "certified"
      on any system, counted for every one of the k modes asked (any may be loose); "high" only
      where H has at most `golub_kahan.HIGH_ROWS` rows, for the bounds over 1e-10 (rare: counted
      as `HIGH_LOOSE` modes);
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
    elif rows <= HIGH_ROWS:
        triplets = min(modes, HIGH_LOOSE) * triplet_seconds(n, n_terms, one_dimensional=one_dimensional)
    else:
        triplets = 0.0
    counts = RING_COUNTS_S * float(n) * n if n_terms == n and n <= RING_DENSE_LIMIT else 0.0
    return triplets + counts


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


def guard(cost: Estimate, *, n_dof: int, max_memory: float | None, max_seconds: float | None,
          alternatives: list[str]) -> None:
    """Raise `ResourceLimitError` if `cost` exceeds the memory or time limit, naming the way out.

    `max_memory` / `max_seconds` None take `MEMORY_LIMIT` (or the available memory) and
    `TIME_LIMIT_S`; ``float("inf")`` disables a limit.
    """
    memory_limit = max_memory if max_memory is not None else MEMORY_LIMIT
    source = "max_memory"
    if memory_limit is None:
        tightest = tightest_memory()
        if tightest is not None:
            source, memory_limit = f"left under the {tightest[0]}", tightest[1]
    time_limit = max_seconds if max_seconds is not None else TIME_LIMIT_S
    reasons = []
    if memory_limit is not None and cost.memory > memory_limit:
        reasons.append(f"more memory than the {describe_bytes(memory_limit)} {source}")
    if cost.seconds > time_limit:
        reasons.append(f"longer than max_seconds={time_limit:g}")
    if not reasons:
        return
    options = "; ".join(alternatives) if alternatives else "ask for fewer modes"
    raise ResourceLimitError(
        f"K has {n_dof} dofs: the {cost.path} path ({cost.what}) would need about "
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
