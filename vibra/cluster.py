"""Work that fans out, on Dask: which cluster to use, and running a list of tasks on it.

vibra has no scheduler of its own (docs/architecture.md, "Scale"): finite-difference displacements
(`vibra.molecules.finite_difference_hessian`) and sweeps (`vibra.pipeline.sweep`) hand their tasks to
``dask.distributed``, an optional extra (``pip install "vibra[distributed]"``).

Where the work runs is one argument, ``client``:

- ``None``: in this process, one task after the other (no Dask needed);
- ``"local"``: a `distributed.LocalCluster` of separate worker processes (one thread each),
  started for the call and closed after it;
- a `distributed.Client`: its cluster, left open (the caller owns it);
- a scheduler address (``"tcp://host:8786"``, ``"tls://..."``): a client connected for the
  call; an address that does not answer within `timeout` seconds raises `ClusterError`
  before any task is submitted or any file is written.

`run_tasks` submits one task per item, collects the results as they finish (calling back
for each, so a cache can be written as results arrive), and keeps the failures apart: one
failing task does not discard the others. A worker process that dies is handled by Dask
itself: its tasks are rescheduled on the remaining workers (up to Dask's
``distributed.scheduler.allowed-failures`` deaths per task, 3 by default).

This module imports nothing from vibra's higher stages, and ``distributed`` only when a
cluster is asked for.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
import uuid
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Callable, Iterator, Sequence, TextIO, TypeVar, Union

from vibra._core.cores import available_cores

if TYPE_CHECKING:
    from distributed import Client

__all__ = ["EXTRA", "ClusterError", "TaskFailure", "TaskProgress", "ProgressOption", "ClientOption",
           "require_distributed", "check_client", "connect", "ClientOnDemand", "run_tasks", "default_workers",
           "progress_callback"]

#: The optional extra that installs Dask.
EXTRA = "vibra[distributed]"

#: What ``progress=`` accepts: None or False (quiet), True (a line per task on stderr),
#: ``"dask"`` (``dask.distributed.progress``: a widget in a notebook, a bar in a terminal), or
#: a callable ``(done, total, label)`` called after each task.
ProgressOption = Union[None, bool, str, Callable[[int, int, str], None]]

#: What ``client=`` accepts: None (this process, serially), ``"local"`` (a local cluster), a
#: scheduler address (``"tcp://host:8786"``), or a ``distributed.Client`` (`check_client`).
ClientOption = Union[None, str, "Client"]

T = TypeVar("T")


class ClusterError(RuntimeError):
    """The cluster could not be reached or used (e.g. no scheduler at the address)."""


@dataclass(frozen=True)
class TaskFailure:
    """One task that raised instead of returning.

    Attributes
    ----------
    index : int
        Position of the task in the submitted list.
    label : str
        What the task computed, in words (e.g. the displacement).
    error : BaseException
        The exception it raised (re-raised on the client by Dask).
    """

    index: int
    label: str
    error: BaseException

    def describe(self) -> str:
        """One line: the label, the exception type and its message."""
        return f"{self.label}: {type(self.error).__name__}: {self.error}"


def require_distributed() -> ModuleType:
    """The ``distributed`` module; ImportError naming the extra when Dask is not installed."""
    try:
        import distributed
    except ImportError as error:
        raise ImportError(
            f"running on a Dask cluster needs dask.distributed, which is not installed ({error}); "
            f"install the extra: pip install \"{EXTRA}\"") from None
    return distributed


def check_client(client: object, name: str = "client") -> None:
    """Check the *form* of a ``client`` argument, without connecting or importing Dask.

    Raises
    ------
    TypeError
        Not None, a string or a ``distributed.Client``.
    ValueError
        A string that is neither ``"local"`` nor a scheduler address (``"tcp://host:8786"``).
    """
    if client is None:
        return
    if isinstance(client, str):
        if client == "local" or _is_address(client):
            return
        raise ValueError(f"{name} is {client!r}; expected 'local' or a scheduler address like 'tcp://host:8786'")
    distributed = sys.modules.get("distributed")  # a Client exists only once Dask is imported
    if distributed is not None and isinstance(client, distributed.Client):
        return
    raise TypeError(f"{name} must be None, 'local', a scheduler address or a dask.distributed.Client, "
                    f"got {type(client).__name__}")


def _is_address(text: str) -> bool:
    scheme, sep, rest = text.partition("://")
    if sep:
        return bool(scheme) and bool(rest)
    host, colon, port = text.rpartition(":")
    return bool(colon) and bool(host) and port.isdigit()


def default_workers() -> int:
    """Worker processes of a local cluster: the cores this process may use."""
    return available_cores()


@contextlib.contextmanager
def connect(client: ClientOption, *, n_workers: int | None = None, timeout: float = 10.0) -> Iterator[Client]:
    """A ``distributed.Client`` for `client` (see the module docstring), closed on exit if opened here.

    Parameters
    ----------
    client : {"local"} or str or distributed.Client
        Where to run (None is refused here: the caller runs serially instead).
    n_workers : int, optional
        Worker processes of a ``"local"`` cluster (default: `default_workers`).
    timeout : float
        Seconds to wait for a scheduler address to answer.

    Raises
    ------
    ImportError
        Dask is not installed (the message names the extra).
    ClusterError
        The scheduler at the address did not answer within `timeout` seconds.
    """
    check_client(client)
    if client is None:
        raise ValueError("client is None; run serially instead of connecting")
    distributed = require_distributed()
    if not isinstance(client, str):
        yield client
        return
    if client == "local":
        workers = default_workers() if n_workers is None else int(n_workers)
        if workers < 1:
            raise ValueError(f"n_workers is {workers}; expected >= 1")
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                           dashboard_address=":0", silence_logs=logging.ERROR)
        try:
            with distributed.Client(cluster) as opened:
                yield opened
        finally:
            cluster.close()
        return
    try:
        opened = distributed.Client(client, timeout=timeout)
    except (OSError, TimeoutError) as error:
        raise ClusterError(f"no Dask scheduler answered at {client!r} within {timeout:g} s ({error}); "
                           "start one (dask scheduler) or use client='local'") from None
    try:
        yield opened
    finally:
        opened.close()


class ClientOnDemand:
    """Where the tasks of one run go: `client` None (this process), or a client `connect`-ed when
    first needed (`get`) and closed with `stack`, so a run whose work is all cached connects to nothing."""

    def __init__(self, client: ClientOption, stack: contextlib.ExitStack, n_workers: int | None,
                 timeout: float) -> None:
        self.client, self.stack, self.n_workers, self.timeout = client, stack, n_workers, timeout
        self.opened: Client | None = None

    def get(self) -> Client:
        if self.opened is None:
            self.opened = self.stack.enter_context(connect(self.client, n_workers=self.n_workers,
                                                           timeout=self.timeout))
        return self.opened


class TaskProgress:
    """A line per finished task on a stream (stderr by default): ``[ 3/37] label: done (1.2 s)``."""

    def __init__(self, total: int, *, stream: TextIO | None = None, prefix: str = "") -> None:
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        self.prefix = prefix
        self.start = time.perf_counter()

    def __call__(self, done: int, total: int, label: str) -> None:
        width = len(str(total))
        elapsed = time.perf_counter() - self.start
        self.stream.write(f"{self.prefix}[{done:>{width}}/{total}] {label} ({elapsed:.1f} s)\n")
        self.stream.flush()


def progress_callback(progress: ProgressOption, total: int, prefix: str = "") -> Callable[[int, int, str], None] | None:
    """The per-task callback for a ``progress=`` option (None for quiet or for ``"dask"``)."""
    if progress is None or progress is False or progress == "dask":
        return None
    if progress is True:
        return TaskProgress(total, prefix=prefix)
    if callable(progress):
        return progress
    raise ValueError(f"progress is {progress!r}; expected None, True, False, 'dask' or a callable "
                     "(done, total, label)")


def run_tasks(client: Client, function: Callable[..., T], arguments: Sequence[tuple[object, ...]], *,
              labels: Sequence[str], on_result: Callable[[int, T], None] | None = None,
              progress: ProgressOption = None, retries: int = 0,
              name: str = "vibra") -> tuple[list[T | None], list[TaskFailure]]:
    """Run ``function(*arguments[i])`` for every i on `client`'s cluster; collect in submission order.

    Parameters
    ----------
    client : distributed.Client
        An open client (see `connect`).
    function : callable
        A module-level function (workers import it by name; vibra must be installed there).
    arguments : sequence of tuple
        One argument tuple per task; each is pickled and sent to a worker.
    labels : sequence of str
        What each task computes, in words (progress lines and failure messages).
    on_result : callable, optional
        ``on_result(i, result)``, called on the client as each task finishes (in completion
        order), e.g. to write a cache; an exception here cancels the remaining tasks.
    progress : bool, str or callable
        See `ProgressOption`.
    retries : int
        Extra attempts of a task that raised (Dask's ``retries=``). Worker deaths are retried
        by Dask regardless of this.
    name : str
        Prefix of the task keys (seen on the Dask dashboard).

    Returns
    -------
    results : list
        ``results[i]`` of each task that returned (None where it failed).
    failures : list of TaskFailure
        The tasks that raised, in submission order.
    """
    total = len(arguments)
    callback = progress_callback(progress, total)
    token = uuid.uuid4().hex[:12]
    futures = [client.submit(function, *args, key=f"{name}-{token}-{i}", pure=False, retries=retries)
               for i, args in enumerate(arguments)]
    index = {future.key: i for i, future in enumerate(futures)}
    results: list[T | None] = [None] * total
    failures: list[TaskFailure] = []
    distributed = require_distributed()
    try:
        if progress == "dask":
            distributed.progress(futures)
        done = 0
        for future in distributed.as_completed(futures):
            i = index[future.key]
            failed = future.status == "error"
            if failed:
                failures.append(TaskFailure(i, labels[i], future.exception()))
            else:
                results[i] = value = future.result()
                if on_result is not None:
                    on_result(i, value)
            done += 1
            future.release()
            if callback is not None:
                callback(done, total, labels[i] + (": failed" if failed else ""))
    except BaseException:
        client.cancel(futures)
        raise
    failures.sort(key=lambda f: f.index)
    return results, failures
