"""Preloaded into the worker processes of a local cluster (`client.cluster`).

Ctrl-C in a terminal sends SIGINT to the whole process group: the client, which cancels the batch
and shuts the cluster down, and its worker processes, which would otherwise die with a traceback
each. They ignore it and are stopped by the client instead.
"""

from __future__ import annotations

import signal


def dask_setup(worker: object) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
