"""A function run in a forked child process (`in_forked_child`): what it put on its queue, and how it ended."""

from __future__ import annotations

import multiprocessing
from typing import Any, Callable

import pytest

#: Skips a test where this platform cannot fork (the hazards the tests show are the fork start method's).
NEEDS_FORK = pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(),
                                reason="needs the fork start method")


def in_forked_child(target: Callable[..., None], timeout: float = 120.0) -> tuple[int | None, Any]:
    """Fork, run ``target(queue)`` in the child, and return (its exit status, the first thing it put on
    the queue, or None where it put nothing): -15 is a child terminated by SIGTERM."""
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=target, args=(queue,))
    child.start()
    child.join(timeout=timeout)
    return child.exitcode, (queue.get(timeout=5) if child.exitcode == 0 else None)
