"""Where parallel work runs: local threads or processes, or an existing Dask cluster.

Why this module exists: maps (:mod:`vadsim.studies.sweep`) and diagnoses
(:mod:`vadsim.fit.diagnose`) both send independent pieces of work to a pool, and both take a
Dask scheduler's address instead (``scheduler="tcp://HOST:PORT"``, ``--scheduler``). The
executor of a Dask client is a :class:`concurrent.futures.Executor` like a local pool, so the
code that submits work and collects results is the same for both; only how the pool is made
and closed differs, and that is here, once.
"""

from __future__ import annotations

import multiprocessing as mp
import os
from collections.abc import Callable
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor

__all__ = ["Pool", "dask_pool", "local_processes", "local_threads"]

Pool = tuple[Executor, Callable[[], None], int]
"""An executor, the function that closes it, and how many pieces of work to keep in flight
on it (a few more than it runs at once, so that no worker waits)."""


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

    return ex, close, max(4, 2 * sum(client.nthreads().values()))


def local_threads(workers: int | None) -> Pool:
    """A pool of ``workers`` threads (None: one per core): for work that releases the GIL
    (the core's runs)."""
    n = workers or os.cpu_count() or 1
    ex = ThreadPoolExecutor(max_workers=n)

    def close() -> None:
        ex.shutdown(wait=False, cancel_futures=True)

    return ex, close, 2 * n


def local_processes(workers: int) -> Pool:
    """A pool of ``workers`` processes: for work that holds the GIL (the feature code).
    Forked where the platform can: the workers inherit the imported modules and need no
    importable ``__main__`` (a user's script without a main guard works)."""
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)

    def close() -> None:
        ex.shutdown(wait=True, cancel_futures=True)

    return ex, close, 2 * workers
