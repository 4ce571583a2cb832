"""A function run in a forked child process (`in_forked_child`): what it put on its queue, and how it ended."""

from __future__ import annotations

import multiprocessing
import queue as queues
import time
from typing import Any, Callable

import pytest

#: Skips a test where this platform cannot fork (the hazards the tests show are the fork start method's).
NEEDS_FORK = pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(),
                                reason="needs the fork start method")


def in_forked_child(target: Callable[..., None], timeout: float = 120.0) -> tuple[int | None, Any]:
    """Fork, run ``target(queue)`` in the child, and return (its exit status, the first thing it put on
    the queue, or None where it put nothing): -15 is a child terminated by SIGTERM, None one still
    running after `timeout` seconds (then killed, so that a hung child cannot hang the tests)."""
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=target, args=(queue,))
    child.start()
    deadline = time.monotonic() + timeout
    result = None
    while result is None:
        try:  # (read before join: a large item blocks the child until read)
            result = queue.get(timeout=0.2)
        except queues.Empty:
            if not child.is_alive():
                try:
                    result = queue.get(timeout=1.0)  # (what it put just before it ended)
                except queues.Empty:
                    pass
                break
            if time.monotonic() > deadline:
                break
    child.join(timeout=5)
    status = child.exitcode
    if child.is_alive():
        child.kill()
        child.join()
    return status, result
