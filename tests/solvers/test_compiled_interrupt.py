"""Compiled loops over many values return to Python about once a second (issue 44): Ctrl-C stops
a solve, and the batches give the same bits as one call.

Truth: one call of the kernel over all values (the batches must reproduce it bit for bit: each
value is computed alone), and a real SIGINT sent to a child process running a long bisection
(it must end with KeyboardInterrupt well before the work would have finished).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from vibra.solvers import compiled
from vibra.solvers.accurate import gk_bisection


def test_batches_cover_every_value_once_in_whole_multiples() -> None:
    for k, seconds, multiple in [(1000, 0.01, 8), (7, 10.0, 16), (0, 1.0, 1), (10**6, 1e-9, 64)]:
        parts = compiled.batches(k, seconds, multiple)
        covered = [i for first, stop in parts for i in range(first, stop)] if k < 10**5 else None
        if covered is not None:
            assert covered == list(range(k))
        assert all((stop - first) % multiple == 0 for first, stop in parts[:-1])
        if parts and seconds * (parts[0][1] - parts[0][0]) > compiled.INTERRUPT_S:
            assert parts[0][1] - parts[0][0] <= multiple  # only when one multiple alone exceeds the bound


def test_bisection_in_batches_gives_the_bits_of_one_call(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(7)
    d, e = rng.uniform(0.5, 2.0, 3000), rng.uniform(0.5, 2.0, 2999)
    whole = gk_bisection.bidiagonal_values_by_bisection(d, e, 5, 300)
    monkeypatch.setattr(compiled, "INTERRUPT_S", 1e-6)  # one multiple of lanes x threads per call
    batched = gk_bisection.bidiagonal_values_by_bisection(d, e, 5, 300)
    assert len(compiled.batches(300, gk_bisection.BISECTION_S * 3000, 8)) > 1
    np.testing.assert_array_equal(batched, whole)


def test_ring_kernels_in_batches_give_the_bits_of_one_call(monkeypatch: pytest.MonkeyPatch) -> None:
    import vibra

    n = 400
    rng = np.random.default_rng(3)
    ring = vibra.System.from_springs(np.arange(n, dtype=float), rng.uniform(1, 2, n),
                                     np.c_[np.arange(n), (np.arange(n) + 1) % n], rng.uniform(1, 3, n))
    whole = ring.modes(n_modes=12, solver="accurate", vectors=False)
    monkeypatch.setattr(compiled, "INTERRUPT_S", 1e-9)
    batched = ring.modes(n_modes=12, solver="accurate", vectors=False)
    assert whole.path == batched.path
    np.testing.assert_array_equal(batched.omega, whole.omega)


def test_sigint_stops_a_long_bisection() -> None:
    """200,000 sites, 4,000 values: ~400 s of bisection on one thread; SIGINT after the kernel has
    started must end the child with KeyboardInterrupt long before (the hang guard: 120 s)."""
    script = textwrap.dedent("""
        import sys, numpy as np
        from vibra.solvers.accurate import gk_bisection
        rng = np.random.default_rng(1)
        d, e = rng.uniform(0.5, 2.0, 200_000), rng.uniform(0.5, 2.0, 199_999)
        gk_bisection.bidiagonal_values_by_bisection(d, e, 0, 8)   # numba loaded, kernel compiled
        print("started", flush=True)
        try:
            gk_bisection.bidiagonal_values_by_bisection(d, e, 0, 4000)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(3)
        print("finished", flush=True)
    """)
    env = dict(os.environ, NUMBA_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, env=env)
    try:
        assert child.stdout is not None
        assert child.stdout.readline().strip() == "started"
        time.sleep(1.0)  # inside the long call
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=120)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 3 and "interrupted" in out, (child.returncode, out, err[-2000:])
