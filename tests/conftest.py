"""Shared pytest configuration: seeded randomness, hypothesis profile."""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile

import numpy as np
import pytest
from hypothesis import settings

# The suite runs the compiled kernels through numba, in this process and in every interpreter it
# starts: no ahead-of-time copy is used or built in the background (vibra.solvers.aot), so no test
# depends on whether a copy from an earlier run sits in the user's cache. tests/solvers/test_aot.py
# builds one in a temporary folder and checks it against numba, bit for bit.
os.environ["VIBRA_AOT"] = "0"
# What vibra derives from its own sources and keeps between processes (vibra._core.cache: the scene
# schema's builder signatures) goes to a folder of this run, shared by the interpreters it starts:
# no test reads a cache an earlier version of the sources left, none writes to the user's.
os.environ["VIBRA_CACHE_DIR"] = tempfile.mkdtemp(prefix="vibra-test-cache-")
atexit.register(shutil.rmtree, os.environ["VIBRA_CACHE_DIR"], ignore_errors=True)

settings.register_profile("ci", max_examples=60, deadline=None, derandomize=True)
settings.register_profile("dev", max_examples=30, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: tests are reproducible."""
    return np.random.default_rng(20261122)


@pytest.fixture(scope="session")
def dask_client():
    """A Dask client on a local cluster of 2 separate worker processes, 1 thread each (shared by the session)."""
    import logging

    import distributed  # in the test extra: these tests run in CI, never skip

    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=":0", silence_logs=logging.ERROR)
    client = distributed.Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


@pytest.fixture()
def client_timeouts(monkeypatch):
    """The ``timeout=`` of every ``distributed.Client`` opened during the test (the real client is
    still opened: a refused connection is the library's own). A test checks that its timeout
    reached Dask instead of timing the call: a wall-clock bound fails on a loaded machine."""
    import distributed

    seen: list[object] = []
    real = distributed.Client

    class Recording(real):  # type: ignore[misc, valid-type]
        def __init__(self, *args, **kwargs):
            seen.append(kwargs.get("timeout"))
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(distributed, "Client", Recording)
    return seen


@pytest.fixture()
def codata_phonopy():
    """phonopy with scipy's constants for the duration of one test, its defaults restored after
    (its own are older CODATA values: thermal and DOS comparisons would differ by ~1e-7)."""
    from phonopy.physical_units import set_physical_units
    from scipy import constants

    set_physical_units(KB_J=constants.k, PlanckConstant=constants.h / constants.e, Avogadro=constants.Avogadro,
                       AMU=constants.atomic_mass, EV=constants.e)
    try:
        yield
    finally:
        set_physical_units()
