"""Time a full diagnosis of a 10-event campaign on the local cores.

Writes a 10-event 7in campaign (200-650 gal/min, 8 s per event, 0.3 g noise) with a
concealed effect, loads it back from disk and runs ``vadsim.fit.diagnosis.diagnose`` with every
candidate (23 variants) and the default settings (nuisance constants WOB scale and theta0,
forward selection). Effects: ``hydraulic`` (a force f_ref = 64 N/kg at 400 gal/min, n = 2, on
the anvil), ``pair`` (that force and 100 N/kg of anvil friction), ``wob`` (no effect, the tool
saw 1.1 x the stated WOB), ``none``.

    python bench/bench_diagnose.py [--effect hydraulic|pair|wob|none] [--workers N]
                                   [--steady auto|full] [--scheduler tcp://HOST:PORT]

Budgets on 2 cores: 120 s for ``hydraulic``, 300 s for ``pair``. ``--steady full`` runs
every cycle of every run (what the diagnosis took before runs stopped at their orbit).
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import tempfile
import time
from collections.abc import Iterator

from vadsim.campaigns import load_campaign, save_campaign
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnosis import diagnose
from vadsim.model.change import ModelChange

FLOWS = (200.0, 250.0, 300.0, 350.0, 400.0, 450.0, 500.0, 550.0, 600.0, 650.0)


def _hydraulic() -> ModelChange:
    return CANDIDATES["hydraulic_force[anvil]"].change({"f_ref": 64.0, "n": 2.0})


EFFECTS = {
    "hydraulic": _hydraulic,
    "pair": lambda: _hydraulic().combine(CANDIDATES["anvil_friction"].change({"force": 100.0})),
    "wob": lambda: ModelChange(scales={"wob": 1.1}),
    "none": ModelChange,
}


TARGETS_S = {"hydraulic": 120.0, "pair": 300.0}
"""The budgets of the single-effect and the two-effect diagnosis on 2 cores."""


@contextlib.contextmanager
def _steady_default(mode: str) -> Iterator[None]:
    """Every run of the diagnosis in ``mode``: the campaign's own settings are the
    diagnosis' to make, so the default of :class:`RunSettings` is swapped for the time of
    the call (worker processes are forked inside it and inherit the swap)."""
    import vadsim.model.settings as vsettings

    old = vsettings.RunSettings.__init__.__defaults__
    names = list(inspect.signature(vsettings.RunSettings.__init__).parameters)[1:]
    assert old is not None
    new = list(old)
    new[names[-len(old):].index("steady")] = mode
    vsettings.RunSettings.__init__.__defaults__ = tuple(new)
    try:
        yield
    finally:
        vsettings.RunSettings.__init__.__defaults__ = old


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--effect", default="hydraulic", choices=sorted(EFFECTS))
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--steady", choices=("auto", "full"), default="auto",
                    help="runs stop at their periodic orbit (auto) or integrate every cycle")
    ap.add_argument("--scheduler", default=None, help="a Dask scheduler's address")
    args = ap.parse_args()
    camp = synthetic_campaign("7in-cde", FLOWS, change=EFFECTS[args.effect](), cycles=300,
                              analyse_cycles=200,
                              duration_s=8.0, noise_g=0.3, seed=7, name="bench-10")
    with tempfile.TemporaryDirectory() as tmp:
        camp = load_campaign(save_campaign(camp, tmp + "/camp"))
        t0 = time.perf_counter()
        with _steady_default(args.steady):
            d = diagnose(camp, workers=args.workers, scheduler=args.scheduler,
                         progress=lambda m: print(" ", m, flush=True))
        dt = time.perf_counter() - t0
    print(d.summary())
    target = TARGETS_S.get(args.effect)
    verdict = "" if target is None else (
        f" ({'within' if dt <= target else 'OVER'} the {target:.0f} s budget)")
    print(f"diagnosis of {len(camp.events)} events ({d.n_evals} evaluations), "
          f"steady={args.steady}: {dt:.0f} s{verdict}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
