"""Dask clusters for Dürer: a local one of worker processes, or an existing scheduler."""

from __future__ import annotations

import importlib.util
import logging
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, TextIO

#: How long connecting to a scheduler or starting local workers may take, in seconds.
CONNECT_TIMEOUT = 60


def require_distributed() -> Any:
    """The `distributed` module, or ImportError saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise ImportError("distributed rendering needs Dask: pip install 'durer[distributed]'") from None
    return distributed


def default_worker_count() -> int:
    """Worker processes a local cluster gets by default: the cores this process may use (one
    single-threaded render per core renders frames fastest; see docs/distributed.md)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


@contextmanager
def cluster(
    scheduler: str | None = None, workers: int | None = None, *, log: TextIO | None = sys.stderr
) -> Iterator[Any]:
    """A `distributed.Client`: connected to `scheduler` ("tcp://host:8786") if given, else to a new
    local cluster of `workers` single-threaded worker processes on 127.0.0.1 (default: one per
    core), which is shut down, workers and all, when the block ends (also on Ctrl-C). The Dask
    dashboard's link is written to `log` when one runs."""
    distributed = require_distributed()
    if scheduler is not None:
        if not isinstance(scheduler, str) or not scheduler:
            raise ValueError(f"scheduler must be an address such as tcp://host:8786, got {scheduler!r}")
        with distributed.Client(scheduler, timeout=CONNECT_TIMEOUT) as client:
            _announce(client, log)
            yield client
        return
    count = default_worker_count() if workers is None else workers
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    # Dask's own log lines stay quiet (failures reach the caller through the tasks' futures); its
    # shutdown after Ctrl-C would otherwise print the workers' lost-heartbeat tracebacks.
    with distributed.LocalCluster(n_workers=count, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL,
                                  preload=["durer.distributed.worker_setup"]) as local, \
            distributed.Client(local, timeout=CONNECT_TIMEOUT) as client:
        _announce(client, log)
        yield client


def _has_dashboard() -> bool:
    """Whether this process can serve Dask's dashboard: it needs bokeh, which dask[distributed] does
    not bring (without it the scheduler's web server has no /status page)."""
    return importlib.util.find_spec("bokeh") is not None


def _announce(client: Any, log: TextIO | None) -> None:
    if log is None:
        return
    threads = client.nthreads()
    print(f"dask: {client.scheduler.address}, {len(threads)} workers, {sum(threads.values())} threads", file=log)
    if "dashboard" in client.scheduler_info().get("services", {}) and client.run_on_scheduler(_has_dashboard):
        print(f"dask dashboard: {client.dashboard_link}", file=log)


def worker_name() -> str:
    """The address of the Dask worker running the calling task, or "local" outside one."""
    try:
        from distributed import get_worker
    except ImportError:
        return "local"
    try:
        return get_worker().address
    except ValueError:
        return "local"
