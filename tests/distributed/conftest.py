"""Fixtures for the distributed tests: real Dask schedulers and worker processes on 127.0.0.1."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import distributed
import pytest

from helpers.distributed import TIMEOUT
from durer.distributed import cluster


@pytest.fixture(scope="session")
def client():
    """A local cluster of two single-threaded worker processes, shared by the session's tests."""
    with cluster(workers=2, log=None) as c:
        yield c


@pytest.fixture
def external_scheduler(tmp_path):
    """`dask scheduler` and two `dask worker` processes started as subprocesses on 127.0.0.1;
    yields the scheduler's address, and kills them all afterwards."""
    scheduler_file = tmp_path / "scheduler.json"
    dask = [str(Path(sys.executable).with_name("dask"))]
    log = open(tmp_path / "cluster.log", "w")
    processes = [subprocess.Popen(
        [*dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
         "--scheduler-file", str(scheduler_file)], stdout=log, stderr=subprocess.STDOUT, start_new_session=True)]
    try:
        deadline = time.monotonic() + TIMEOUT
        while not scheduler_file.exists():
            assert time.monotonic() < deadline, (tmp_path / "cluster.log").read_text()
            time.sleep(0.1)
        for _ in range(2):
            processes.append(subprocess.Popen(
                [*dask, "worker", "--scheduler-file", str(scheduler_file), "--host", "127.0.0.1", "--nthreads", "1",
                 "--no-dashboard", "--no-nanny"], stdout=log, stderr=subprocess.STDOUT, start_new_session=True))
        with distributed.Client(scheduler_file=str(scheduler_file), timeout=TIMEOUT) as c:
            c.wait_for_workers(2, timeout=TIMEOUT)
            address = c.scheduler.address
        yield address
    finally:
        for p in reversed(processes):
            p.terminate()
        for p in processes:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:  # a graceful close can hang on a busy worker
                p.kill()
                p.wait(timeout=30)
        log.close()
