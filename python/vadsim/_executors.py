"""Where parallel work runs: local threads or processes, or an existing Dask cluster.

Why this module exists: maps (:mod:`vadsim.studies.sweep`) and diagnoses
(:mod:`vadsim.fit.diagnosis`) both send independent pieces of work to a pool, and both take a
Dask scheduler's address instead (``scheduler="tcp://HOST:PORT"``, ``--scheduler``). The
executor of a Dask client is a :class:`concurrent.futures.Executor` like a local pool, so the
code that submits work and collects results is the same for both; how a pool is made, closed
and stopped on Ctrl-C differs, and that is here, once.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import time
from collections.abc import Callable
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor
from contextlib import AbstractContextManager
from dataclasses import dataclass

from vadsim import _core
from vadsim._interrupt import stop_on_interrupt

__all__ = ["DASK_STOP_S", "Pool", "dask_pool", "local_processes", "local_threads"]

DASK_STOP_S = 0.2
"""How long a Dask cluster's runs are given to see a stop request (they poll it every 2000
steps) before it is withdrawn for later work."""


@dataclass(frozen=True)
class Pool:
    """An executor and what goes with it."""

    executor: Executor
    close: Callable[[], None]
    """Shuts the executor (and a Dask client) down."""
    slots: int
    """How many pieces of work to keep in flight (a few more than run at once, so that no
    worker waits)."""
    guard: Callable[[], AbstractContextManager[None]]
    """A context for the block that waits on the pool: on Ctrl-C it stops the pool's runs,
    then re-raises (:func:`vadsim.stop_on_interrupt`)."""


def dask_pool(address: str) -> Pool:
    """A pool on the Dask cluster whose scheduler is at ``address`` (``tcp://host:8786``).

    Raises
    ------
    ValueError
        For an address that is not a non-empty string.
    OSError
        When no scheduler answers there (Dask's own error, with the address).
    """
    if not isinstance(address, str) or not address.strip():
        raise ValueError(f"scheduler = {address!r} must be a Dask scheduler's address, e.g. "
                         "'tcp://10.0.0.5:8786'")
    from dask.distributed import Client

    client = Client(address)
    ex = client.get_executor()

    def close() -> None:
        ex.shutdown(wait=False)
        client.close()

    def stop_cluster_runs() -> None:
        # the workers' runs poll their process's stop request: set it there, give the runs a
        # moment, then withdraw it for later work
        with contextlib.suppress(Exception):
            client.run(_core.request_interrupt)
            time.sleep(DASK_STOP_S)
            client.run(_core.clear_interrupt)

    return Pool(ex, close, max(4, 2 * sum(client.nthreads().values())),
                lambda: stop_on_interrupt(on_interrupt=stop_cluster_runs))


def local_threads(workers: int | None) -> Pool:
    """A pool of ``workers`` threads (None: one per core): for work that releases the GIL
    (the core's runs)."""
    n = workers or os.cpu_count() or 1
    ex = ThreadPoolExecutor(max_workers=n)

    def close() -> None:
        ex.shutdown(wait=False, cancel_futures=True)

    return Pool(ex, close, 2 * n, lambda: stop_on_interrupt(ex))


def local_processes(workers: int) -> Pool:
    """A pool of ``workers`` processes: for work that holds the GIL (the feature code).
    Forked where the platform can: the workers inherit the imported modules and need no
    importable ``__main__`` (a user's script without a main guard works)."""
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)

    def close() -> None:
        ex.shutdown(wait=True, cancel_futures=True)

    return Pool(ex, close, 2 * workers, lambda: stop_on_interrupt(ex))
