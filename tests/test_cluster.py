"""vibra.cluster: which cluster a `client=` argument means, and running tasks on it.

Truth: the operating system (worker processes have their own pids), Python's own operator
results, and the documented messages.
"""

from __future__ import annotations

import io
import operator
import os
import sys
import time

import pytest

from vibra import cluster


@pytest.mark.parametrize("client", [None, "local", "tcp://10.0.0.5:8786", "tls://head:8786", "head.example:8786"])
def test_check_client_accepts_the_documented_forms(client) -> None:
    cluster.check_client(client)


@pytest.mark.parametrize("client, error, match", [
    ("lokal", ValueError, r"client is 'lokal'; expected 'local' or a scheduler address like 'tcp://host:8786'"),
    ("tcp://", ValueError, r"client is 'tcp://'"),
    ("host:port", ValueError, r"client is 'host:port'"),
    (8786, TypeError, r"client must be None, 'local', a scheduler address or a dask\.distributed\.Client, got int"),
])
def test_check_client_refuses_malformed_values(client, error, match) -> None:
    with pytest.raises(error, match=match):
        cluster.check_client(client)


def test_missing_dask_names_the_extra(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(ImportError, match=r'pip install "vibra\[distributed\]"'):
        cluster.require_distributed()
    with pytest.raises(ImportError, match=r"vibra\[distributed\]"):
        with cluster.connect("local"):
            pass


def test_connect_none_is_refused() -> None:
    with pytest.raises(ValueError, match=r"client is None; run serially"):
        with cluster.connect(None):
            pass


def test_local_cluster_has_separate_single_threaded_worker_processes() -> None:
    with cluster.connect("local", n_workers=2) as client:
        info = client.scheduler_info()["workers"]
        pids = set(client.run(os.getpid).values())
        threads = {w["nthreads"] for w in info.values()}
    assert len(info) == 2 and len(pids) == 2 and os.getpid() not in pids and threads == {1}
    assert client.status == "closed"  # started and closed by vibra


def test_open_client_is_left_open(dask_client) -> None:
    with cluster.connect(dask_client) as client:
        assert client is dask_client
    assert dask_client.status == "running"


def test_unreachable_address_raises_within_the_timeout(client_timeouts) -> None:
    with pytest.raises(cluster.ClusterError, match=r"no Dask scheduler answered at 'tcp://127\.0\.0\.1:9' within 1 s"):
        with cluster.connect("tcp://127.0.0.1:9", timeout=1.0):
            pass
    assert client_timeouts == [1.0]  # Dask was told the timeout (no clock: STYLE.md, tests)


def test_run_tasks_keeps_order_and_failures_apart(dask_client) -> None:
    seen: list[int] = []
    lines: list[tuple[int, int, str]] = []
    arguments = [(6, 3), (1, 0), (9, 3), (5, 0), (8, 2)]
    results, failures = cluster.run_tasks(
        dask_client, operator.floordiv, arguments, labels=[f"{a}//{b}" for a, b in arguments],
        on_result=lambda i, value: seen.append(i), progress=lambda *line: lines.append(line))
    assert results == [2, None, 3, None, 4]
    assert [(f.index, f.label, type(f.error)) for f in failures] == [
        (1, "1//0", ZeroDivisionError), (3, "5//0", ZeroDivisionError)]
    assert failures[0].describe().startswith("1//0: ZeroDivisionError:")
    assert sorted(seen) == [0, 2, 4]
    assert [done for done, _, _ in lines] == [1, 2, 3, 4, 5] and {t for _, t, _ in lines} == {5}
    assert sum(label.endswith(": failed") for _, _, label in lines) == 2


def test_an_error_in_the_callback_cancels_the_rest(dask_client) -> None:
    def stop(i, value):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        cluster.run_tasks(dask_client, time.sleep, [(0.0,)] + [(0.5,)] * 6, labels=["sleep"] * 7, on_result=stop)
    time.sleep(0.2)
    assert not [k for k in dask_client.who_has() if str(k).startswith("vibra-")]   # nothing left behind


def test_task_progress_writes_a_line_per_task() -> None:
    stream = io.StringIO()
    bar = cluster.TaskProgress(12, stream=stream)
    bar(3, 12, "atom 1 displaced by +1h along y")
    assert stream.getvalue().startswith("[ 3/12] atom 1 displaced by +1h along y (")


@pytest.mark.parametrize("option", [None, False, "dask"])
def test_quiet_progress_options_give_no_callback(option) -> None:
    assert cluster.progress_callback(option, 3) is None


def test_bad_progress_option_is_refused() -> None:
    with pytest.raises(ValueError, match=r"progress is 'loud'; expected None, True, False, 'dask' or a callable"):
        cluster.progress_callback("loud", 3)


def test_default_workers_is_the_usable_cores() -> None:
    assert cluster.default_workers() == len(os.sched_getaffinity(0))


def test_dask_progress_bar_option_runs_to_the_end(dask_client) -> None:
    results, failures = cluster.run_tasks(dask_client, operator.add, [(1, 2), (3, 4)], labels=["a", "b"],
                                          progress="dask")
    assert results == [3, 7] and failures == []
