"""Ctrl-C stops vadsim's work wherever it runs (issue 36, item 4): the CLI's single runs, thread
pools (the core polls a process-wide stop request), process pools and a map's chunks.

Each case runs in a child process given work that would take hours (a million excitation
cycles), is sent SIGINT once it is computing, and must exit with the KeyboardInterrupt's exit
(130 for the CLI) and no traceback. The timeouts only catch a hang: before the fix, the CLI's
single run, a thread pool and a process pool each went on to the end of their runs.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pytest
import vadsim
from _children import SIGINT_PRELUDE
from vadsim import _core

LONG = 1_000_000
"""Cycles of a run that would take hours: a run that is not stopped is a hang."""

HANG_S = 120
"""Longest wait for an interrupted child to exit (only a hang guard)."""


def _cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process and its threads (from /proc)."""
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _interrupt_when_busy(proc: subprocess.Popen[str], cpu_s: float = 1.5) -> None:
    """SIGINT once the child, after its imports (it prints "ready" then), has computed
    ``cpu_s`` more CPU seconds: its runs are under way. Counting from the start instead raced
    with the imports where no bytecode is cached (a fresh install with
    PYTHONDONTWRITEBYTECODE: the signal arrived inside scipy's import). A child that exits
    first fails the test."""
    try:
        assert proc.stdout is not None and proc.stdout.readline() == "ready\n", \
            proc.communicate()
        start = _cpu_s(proc.pid)
        while _cpu_s(proc.pid) - start < cpu_s:
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.05)
    except BaseException:
        proc.kill()
        raise
    proc.send_signal(signal.SIGINT)


def _child(code: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-c", SIGINT_PRELUDE + textwrap.dedent(code)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait(proc: subprocess.Popen[str]) -> tuple[str, str]:
    """The child's output once it exits; killed (and the test failed) if it hangs."""
    try:
        return proc.communicate(timeout=HANG_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise


def test_sigint_stops_vadsim_run_with_exit_code_130():
    """Issue 36: ``vadsim run`` ignored Ctrl-C until its runs ended (34-39 s), because even a
    single flow runs in a worker thread."""
    proc = _child(f"""
        import sys
        from vadsim.cli import main
        print("ready", flush=True)
        sys.exit(main(["run", "--flow", "200", "--cycles", "{LONG}", "--analyse", "10"]))
    """)
    _interrupt_when_busy(proc)
    out, err = _wait(proc)
    assert proc.returncode == 130, err
    assert "vadsim: interrupted" in err and "Traceback" not in err, err


def test_sigint_stops_runs_in_a_thread_pool():
    """Issue 36: ``simulate`` in a thread pool went on 11-15 s after Ctrl-C."""
    proc = _child(f"""
        from concurrent.futures import ThreadPoolExecutor
        import vadsim
        print("ready", flush=True)
        try:
            with ThreadPoolExecutor(2) as pool, vadsim.stop_on_interrupt(pool):
                list(pool.map(lambda q: vadsim.simulate("7in-cde", q, cycles={LONG},
                                                        analyse_cycles=10, record="none"),
                              [200.0, 250.0, 300.0]))
        except KeyboardInterrupt:
            print("stopped", vadsim._core.interrupt_requested())
    """)
    _interrupt_when_busy(proc)
    out, err = _wait(proc)
    assert proc.returncode == 0 and out.split() == ["stopped", "False"], err


def test_sigint_stops_a_process_pool_and_its_workers():
    proc = _child(f"""
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor
        import vadsim

        def run(q):
            return vadsim.simulate("7in-cde", q, cycles={LONG}, analyse_cycles=10,
                                   record="none").scenario

        if __name__ == "__main__":
            ctx = mp.get_context("fork")
            try:
                with ProcessPoolExecutor(2, mp_context=ctx) as pool, \\
                        vadsim.stop_on_interrupt(pool):
                    futures = [pool.submit(run, q) for q in (200.0, 250.0)]
                    print("ready", flush=True)
                    [f.result() for f in futures]
            except KeyboardInterrupt:
                print("stopped", len(mp.active_children()))
    """)
    # the workers compute, not the parent: wait for the parent to have started them
    assert proc.stdout is not None and proc.stdout.readline() == "ready\n"
    while len(_children_of(proc.pid)) < 2:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    workers = _children_of(proc.pid)
    proc.send_signal(signal.SIGINT)
    out, err = _wait(proc)
    assert proc.returncode == 0 and out.split() == ["stopped", "0"], err
    assert not any(os.path.exists(f"/proc/{pid}") for pid in workers)


def _children_of(pid: int) -> list[int]:
    path = f"/proc/{pid}/task/{pid}/children"
    return [int(p) for p in open(path).read().split()] if os.path.exists(path) else []


def test_sigint_stops_a_map_on_threads(tmp_path):
    """Issue 36: a map went on 4-6 s after Ctrl-C; its finished chunks stay in the store."""
    proc = _child(f"""
        import sys
        from vadsim.cli import main
        print("ready", flush=True)
        sys.exit(main(["map", "--flows", "150", "300", "50", "--param", "kS", "--values",
                       "2e5", "5e5", "--steps", "3", "--cycles", "{LONG}", "--analyse", "10",
                       "--workers", "2", "--quiet", "--out", {str(tmp_path / "m.nc")!r},
                       "--store", {str(tmp_path / "m.parts")!r}]))
    """)
    _interrupt_when_busy(proc)
    out, err = _wait(proc)
    assert proc.returncode == 130, err
    assert "Traceback" not in err, err


def test_a_stop_request_stops_a_run_in_any_thread_and_is_withdrawn():
    """The core's stop request is read by runs in worker threads, where Python runs no signal
    handler; withdrawn, runs go to their end again."""
    caught: list[BaseException] = []

    def run() -> None:
        try:
            vadsim.simulate("7in-cde", 200.0, cycles=LONG, analyse_cycles=10, record="none")
        except BaseException as exc:  # noqa: BLE001 -- the test inspects it
            caught.append(exc)

    worker = threading.Thread(target=run)
    try:
        worker.start()
        _core.request_interrupt()
        assert _core.interrupt_requested()
        worker.join(HANG_S)
    finally:
        _core.clear_interrupt()
    assert not worker.is_alive()
    assert len(caught) == 1 and isinstance(caught[0], KeyboardInterrupt)
    assert any("t =" in note or "step" in note for note in caught[0].__notes__)
    assert not _core.interrupt_requested()
    r = vadsim.simulate("7in-cde", 200.0, cycles=40, analyse_cycles=20, record="none")
    assert r.scenario >= 1


def test_an_exception_other_than_ctrl_c_does_not_raise_the_stop_request():
    from concurrent.futures import ThreadPoolExecutor

    with pytest.raises(ValueError), ThreadPoolExecutor(1) as pool, \
            vadsim.stop_on_interrupt(pool):
        raise ValueError("not an interrupt")
    assert not _core.interrupt_requested()


def test_sigint_delivered_to_a_worker_thread_still_stops_vadsim_run():
    """The kernel may deliver a process' SIGINT to any of its threads. Delivered to a worker
    running the core, it left the main thread asleep in a blocking wait until a run ended (a
    measured ``vadsim run`` of two flows took 508 s to exit): the main thread must wait in
    short slices. The signal is sent to a worker thread here, so the case is not left to
    chance."""
    proc = _child(f"""
        import signal, sys, threading, time
        from vadsim.cli import main

        def poke():
            while True:
                workers = [t for t in threading.enumerate()
                           if t.name.startswith("ThreadPoolExecutor")]
                if len(workers) == 2:
                    break
                time.sleep(0.05)
            time.sleep(1.0)  # the main thread is waiting for the runs by now
            print("poke", flush=True)
            signal.pthread_kill(workers[0].ident, signal.SIGINT)

        threading.Thread(target=poke, daemon=True).start()
        sys.exit(main(["run", "--flow", "200", "250", "--cycles", "{LONG}", "--analyse",
                       "10", "--workers", "2"]))
    """)
    out, err = _wait(proc)
    assert "poke" in out and proc.returncode == 130, err
    assert "vadsim: interrupted" in err and "Traceback" not in err, err


def test_a_second_ctrl_c_while_the_runs_stop_does_not_withdraw_the_stop_request():
    """``timeout -s INT`` sends SIGINT to the command and again to its process group, and an
    impatient user presses Ctrl-C twice: a second KeyboardInterrupt that came while the first
    was waiting for the runs to stop withdrew the stop request early and left the runs going
    (a measured ``vadsim run`` hung until killed). The pool here raises it from its
    ``shutdown``, where the second signal lands."""
    from concurrent.futures import ThreadPoolExecutor

    seen: list[bool] = []

    class Pool(ThreadPoolExecutor):
        def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
            seen.append(_core.interrupt_requested())
            if len(seen) == 1:
                raise KeyboardInterrupt  # the second Ctrl-C
            super().shutdown(wait=wait, cancel_futures=cancel_futures)

    pool = Pool(1)
    with pytest.raises(KeyboardInterrupt), vadsim.stop_on_interrupt(pool):
        raise KeyboardInterrupt
    assert seen[:2] == [True, True]  # waited again, the request still in force
    assert not _core.interrupt_requested()
