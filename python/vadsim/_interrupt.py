"""Ctrl-C that stops vadsim's parallel work within a second: threads, processes, Dask.

Why this module exists: Python runs signal handlers on the main thread only. A run in a worker
thread never sees Ctrl-C, and leaving a ``with ThreadPoolExecutor()`` block waits for every run
in progress (``vadsim run`` sat 34-39 s on one). So the core keeps a process-wide stop request
(:func:`vadsim._core.request_interrupt`) that every run polls every 2000 steps, in any thread,
and :func:`stop_on_interrupt` sets it when a ``KeyboardInterrupt`` leaves its block, cancels the
pool's queued work, stops its worker processes, waits for the runs to stop (milliseconds),
withdraws the request and lets the ``KeyboardInterrupt`` go on.
"""

from __future__ import annotations

import contextlib
import multiprocessing
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor, Future, ProcessPoolExecutor, wait
from typing import TypeVar

from vadsim import _core

__all__ = ["finished", "result", "stop_on_interrupt"]

T = TypeVar("T")

WAIT_SLICE_S = 0.1
"""How long the main thread sleeps at most while it waits for work (s). The kernel delivers a
process' SIGINT to any of its threads; delivered to a worker, it does not wake a main thread
asleep in a blocking wait, which then sees it only when it wakes (after a whole run). Waiting
in slices, it runs the handler within a slice."""

JOIN_TIMEOUT_S = 5.0
"""How long a terminated worker process is waited for before it is killed (a hang guard)."""


@contextlib.contextmanager
def stop_on_interrupt(pool: Executor | None = None,
                      on_interrupt: Callable[[], None] | None = None) -> Iterator[None]:
    """On ``KeyboardInterrupt`` in the block, stop the work in progress, then re-raise.

    Put it inside the pool's own ``with`` (``with ThreadPoolExecutor() as pool,
    stop_on_interrupt(pool):``) so that it acts before the pool's exit waits for its runs.
    Wait for the results with a timeout in a loop (``concurrent.futures.wait(..., timeout=
    0.1)``), not one blocking call: a SIGINT the kernel delivers to a worker thread reaches
    the main thread only when it next wakes.

    Parameters
    ----------
    pool : concurrent.futures.Executor, optional
        Its queued work is cancelled; a :class:`~concurrent.futures.ProcessPoolExecutor`'s
        worker processes are terminated (their partial work is lost, finished work kept).
    on_interrupt : callable, optional
        Called after the runs stopped, e.g. to stop a Dask cluster's work.

    Raises
    ------
    KeyboardInterrupt
        The one that reached the block, once every run in this process has stopped.
    """
    processes = isinstance(pool, ProcessPoolExecutor)
    before = set(multiprocessing.active_children()) if processes else set()
    try:
        yield
    except KeyboardInterrupt:
        _core.request_interrupt()
        try:
            for _ in range(EXTRA_INTERRUPTS + 1):
                try:
                    _stop(pool, set(multiprocessing.active_children()) - before
                          if processes else set(), on_interrupt)
                    break
                except KeyboardInterrupt:
                    # another Ctrl-C (or timeout's second SIGINT) while the runs stop: they
                    # stop anyway; withdrawing the request now would leave them going
                    continue
        finally:
            _core.clear_interrupt()
        raise


EXTRA_INTERRUPTS = 3
"""Further Ctrl-Cs :func:`stop_on_interrupt` lets pass while it waits for the runs to stop;
one more gives up waiting (work that does not poll the stop request may never end)."""


def _stop(pool: Executor | None, children: set[multiprocessing.process.BaseProcess],
          on_interrupt: Callable[[], None] | None) -> None:
    """Terminate ``children``, cancel the pool's queued work and wait for its runs, then call
    ``on_interrupt``; each step may be repeated."""
    if children:
        _terminate(children)
    if pool is not None:
        pool.shutdown(wait=True, cancel_futures=True)
    if on_interrupt is not None:
        on_interrupt()


def result(future: Future[T]) -> T:
    """``future.result()``, waited for in slices of :data:`WAIT_SLICE_S` so that Ctrl-C is
    seen at once whichever thread the signal was delivered to."""
    while not future.done():
        wait([future], timeout=WAIT_SLICE_S)
    return future.result()


def finished(futures: Iterable[Future[T]]) -> Iterator[Future[T]]:
    """The futures as they finish (``as_completed``), waited for in slices of
    :data:`WAIT_SLICE_S` (see :func:`result`)."""
    pending = set(futures)
    while pending:
        done, pending = wait(pending, timeout=WAIT_SLICE_S, return_when=FIRST_COMPLETED)
        yield from done


def _terminate(children: set[multiprocessing.process.BaseProcess]) -> None:
    for child in children:
        with contextlib.suppress(OSError, ValueError):
            child.terminate()
    for child in children:
        with contextlib.suppress(OSError, ValueError, AssertionError):
            child.join(JOIN_TIMEOUT_S)
            if child.is_alive():
                child.kill()
