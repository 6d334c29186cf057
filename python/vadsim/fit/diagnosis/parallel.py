"""Where a diagnosis' fits run: here, in local worker processes or on a Dask cluster.

Each fit rebuilds its comparison engine from the :class:`~vadsim.fit.diagnosis.evidence.
Context` alone (features, keys, folds, warm starts), so a fit's result does not depend on
where it ran or in which order: one worker, several processes and a Dask cluster give the
same diagnosis to the digit (tests/python/test_diagnose_parallel.py).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from vadsim._executors import dask_pool, local_processes
from vadsim._interrupt import finished
from vadsim.compare import CampaignEvaluator
from vadsim.fit.diagnosis.evidence import Context
from vadsim.fit.diagnosis.hypotheses import Job
from vadsim.fit.hypothesis_fit import HypothesisFit, fit_hypothesis

__all__ = ["JOB_THREADS", "Tick", "bar_tick", "fit_all", "fit_task", "on_bar", "run_job"]

def run_job(ctx: Context, ev: CampaignEvaluator, coarse_ev: CampaignEvaluator, job: Job,
             say: Callable[[str], None] = lambda _m: None) -> HypothesisFit:
    """One job: a probe on the coarse engine alone; a full fit on ``ev`` with its grids
    on the coarse engine."""
    if job.probe:
        fit = fit_hypothesis(coarse_ev, job.hyp, job.start, job.stages, ctx.probe_folds,
                             list(ctx.probe_eids), say, job.alternatives)
    else:
        fit = fit_hypothesis(ev, job.hyp, job.start, job.stages, ctx.folds, list(ctx.eids),
                             say, job.alternatives, coarse=(coarse_ev, list(ctx.probe_eids)))
    fit.probe = job.probe
    return fit


JOB_THREADS = 2
"""Threads of each job process' engines: one event's run integrates (without the GIL)
while another's features are measured (with it).

Why 2 and not 1: a job alone in the pool -- the last of a step's fits, typically the
longest -- then uses both cores, and two jobs side by side lose little. Measured on the
10-event benchmark campaign (12 hydraulic-force points, 2 idle cores): alone 383 ms a
point with 1 thread, 247-270 ms with 2; two processes side by side 364-375 ms with 1 thread
each, 389-403 ms with 2; four diagnosis tests in two pytest processes 309 s with 1, 283 s
with 2. The threads do not change a result (an evaluation is a function
of its inputs: tests/python/fit/diagnosis/test_parallel.py)."""


def fit_task(ctx: Context, job: Job) -> HypothesisFit:
    """One hypothesis' fit in its own process (the feature code holds the GIL, so a process
    per job; :data:`JOB_THREADS` threads in it)."""
    with (ctx.evaluator(False, JOB_THREADS) as ev,
          ctx.evaluator(True, JOB_THREADS) as coarse_ev):
        return run_job(ctx, ev, coarse_ev, job)


Tick = Callable[..., None]
"""One fit done, optionally with a status line for the progress bar (``tick("pair screen:
57 of 143 pairs probed")``)."""


def bar_tick(b: Any) -> Tick:
    """A :data:`Tick` on progress bar ``b``: one more fit, and the status if given."""
    def tick(*status: str) -> None:
        b.update(1)
        if status:
            b.set_postfix_str(status[0])
    return tick


def on_bar(say: Callable[[str], None], b: Any) -> Callable[[str], None]:
    """``say``, and each line as bar ``b``'s status: the bar has no total (how many fits a
    diagnosis makes depends on what it finds: 25 on a one-effect campaign, several hundred
    when it screens every pair), so the status says what it is doing."""
    def both(line: str) -> None:
        say(line)
        b.set_postfix_str(line if len(line) <= 80 else line[:79] + "...")
    return both


def fit_all(ctx: Context, jobs: list[Job], ev: CampaignEvaluator,
             coarse_ev: CampaignEvaluator, say: Callable[[str], None],
             tick: Tick = lambda *_status: None) -> list[HypothesisFit]:
    """Fit every job: on the Dask cluster of ``ctx.scheduler``, else in worker processes when
    there are several workers, else here. Each job rebuilds its engines from ``ctx`` alone
    (warm starts included), so where it runs does not change its result."""
    if not ctx.scheduler and (ev.workers <= 1 or len(jobs) <= 1):
        fits = []
        for j in jobs:
            fits.append(run_job(ctx, ev, coarse_ev, j, say))
            tick()
        return fits
    # model-side candidates first: they take longest
    order = sorted(range(len(jobs)),
                   key=lambda i: jobs[i].hyp.candidates[-1].side != "model")
    pool = (dask_pool(ctx.scheduler) if ctx.scheduler
            else local_processes(min(ev.workers, len(jobs))))
    out: dict[int, HypothesisFit] = {}
    try:
        with pool.guard():
            futures = {pool.executor.submit(fit_task, ctx, jobs[i]): i for i in order}
            for fut in finished(futures):
                f = fut.result()
                out[futures[fut]] = f
                ev.n_evals += f.n_evals  # the job's engines ran elsewhere: count them here
                tick()
                say(f"{f.key}: held-out RMS {f.heldout_rms:.3f}, score {f.score:.1f}")
    finally:
        pool.close()
    return [out[i] for i in range(len(jobs))]
