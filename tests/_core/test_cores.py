"""The cores this process may use (`vibra._core.cores`): the affinity mask, where Linux has one."""

from __future__ import annotations

import os

import pytest

from vibra._core.cores import available_cores
from vibra.cluster import default_workers
from vibra.pipeline.report import available_cores as report_cores


@pytest.mark.skipif(not hasattr(os, "sched_getaffinity"), reason="no affinity mask on this platform")
def test_the_affinity_mask_counts() -> None:
    assert available_cores() == len(os.sched_getaffinity(0))


def test_one_answer_for_every_pool() -> None:
    assert default_workers() == report_cores() == available_cores() >= 1
