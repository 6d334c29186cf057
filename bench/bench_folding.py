"""Folding a 1024 Hz record recovers the full-resolution cycle waveform: how well, and at what
cost.

For each flow: a synthetic 8 s record of the 7in CDE tool (the model itself, x1 and x5 at
1024 Hz with a random sampling phase, 250 g range, 0.3 g noise) is folded by excitation phase
starting from a frequency 0.1 % off (:func:`vadsim.signals.folding.fold`, refined); the same
run's noise-free fine grid (20480 Hz) is folded at its exact frequency through the same analog
chain (:func:`vadsim.signals.folding.fold_fine`). Both folds are aligned as the features
align them (:func:`vadsim.signals.fold_waveform.spike_origin`: x1's spike at the centre of a
bin) and compared bin by bin. Then the features of the record
(:func:`vadsim.compare.recorded_features`) are compared with those of the base model
(:func:`vadsim.compare.measure_event`), and measure_event is timed with and without folding.
Last, the comparison engine's residuals of the base model on the folded keys and on the others,
for campaigns written by the same model and by one with a 30 % stronger excitation.

    python bench/bench_folding.py          # about a minute on 2 cores
"""

from __future__ import annotations

import math
import time
import timeit

import numpy as np
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import (
    CampaignEvaluator,
    event_residuals,
    measure_event,
    recorded_features,
    run_event,
)
from vadsim.model.result import G
from vadsim.model.settings import RunSettings
from vadsim.signals.fold_waveform import spike_origin
from vadsim.signals.folding import fold, fold_fine
from vadsim.signals.sensor import SIMULATION_OVERSAMPLING

FLOWS = (200.0, 400.0, 600.0, 650.0)
DURATION_S, CYCLES, ANALYSE = 8.0, 300, 200  # synthetic_campaign's defaults: 100 settling cycles


def _fold_error(flow: float) -> None:
    camp = synthetic_campaign("7in-cde", [flow], duration_s=DURATION_S, noise_g=0.3,
                              cycles=CYCLES, analyse_cycles=ANALYSE, seed=3)
    ev = camp.events[0]
    assert ev.data is not None
    base = RunSettings("7in-cde")
    n_an = math.ceil(DURATION_S * base.f_exc_hz(flow))
    r = base.with_changes(cycles=CYCLES - ANALYSE + n_an, analyse_cycles=n_an).run(
        flow, record="window", output_rate_hz=SIMULATION_OVERSAMPLING * 1024)
    a = ev.data["x1_g"].to_numpy()
    t0 = float(ev.data["time_s"].iloc[0])
    start = time.process_time()
    probe = fold(a, 1024.0, r.f_exc_hz * 1.001, t0=t0)
    took = time.process_time() - start
    rec = fold(a, 1024.0, probe.f_hz, t0=t0, period=probe.period, refine=0.0,
               origin=spike_origin(probe))
    fine = fold_fine(r.t, r.a[:, 0] / G, r.f_exc_hz, rec.period, range_g=250.0)
    full = fold_fine(r.t, r.a[:, 0] / G, r.f_exc_hz, rec.period, range_g=250.0,
                     origin=spike_origin(fine))
    diff = rec.mean - full.mean
    window_peak = float(np.mean(np.abs(a[: a.size // 205 * 205]).reshape(-1, 205).max(axis=1)))
    print(f"{flow:5.0f} gal/min: period {rec.period}, explained {rec.explained:.3f}, "
          f"f error {rec.f_hz / r.f_exc_hz - 1:+.1e} (from +1e-3), filled {rec.filled:.2f}, "
          f"folded max {np.nanmax(np.abs(rec.mean)):.1f} g vs fine-grid fold "
          f"{np.max(np.abs(full.mean)):.1f} g (plain 1024 Hz 200 ms peaks {window_peak:.1f} g), "
          f"RMS difference {np.sqrt(np.nanmean(diff ** 2)):.2f} g, max |difference| "
          f"{np.nanmax(np.abs(diff)):.1f} g, within-bin sd {rec.within_sd:.2f} g, "
          f"fold {took * 1e3:.0f} ms CPU")


def _engine(flow: float) -> None:
    camp = synthetic_campaign("7in-cde", [flow], duration_s=DURATION_S, noise_g=0.3,
                              cycles=CYCLES, analyse_cycles=ANALYSE, seed=3)
    ev = camp.events[0]
    settings = RunSettings("7in-cde", cycles=CYCLES, analyse_cycles=ANALYSE)
    r = run_event(camp, ev, settings)
    start = time.process_time()
    rec = recorded_features(camp, ev, settings.f_exc_hz(flow))
    rec_s = time.process_time() - start
    sim = measure_event(camp, ev, r)
    z = event_residuals(sim, rec)
    folded = [v for k, v in z.items() if "_fold" in k or "_q" in k]
    # CPU time of this process, the least of 7: the machine is shared, wall time is not ours
    off = timeit.repeat(lambda: measure_event(camp, ev, r, folded=False), number=1, repeat=7,
                        timer=time.process_time)
    on = timeit.repeat(lambda: measure_event(camp, ev, r, folded=True), number=1, repeat=7,
                       timer=time.process_time)
    print(f"{flow:5.0f} gal/min: {len(folded)} folded/distribution keys, RMS z "
          f"{np.sqrt(np.mean(np.square(folded))):.2f}; recorded_features {rec_s * 1e3:.0f} ms; "
          f"measure_event {min(off) * 1e3:.0f} ms CPU without folding, "
          f"{min(on) * 1e3:.0f} ms with")


def _evidence() -> None:
    """RMS standardised residual of the base model, folded keys against the others, for a
    campaign written by the base model and one written with Fo 30 % higher."""
    settings = RunSettings("7in-cde", cycles=CYCLES, analyse_cycles=ANALYSE)
    flows = (200.0, 300.0, 400.0, 500.0, 650.0)
    for label, over in (("same model", {}), ("Fo x 1.3", {"Fo": 1.3 * settings.param("Fo")})):
        camp = synthetic_campaign("7in-cde", flows, duration_s=DURATION_S, noise_g=0.3,
                                  cycles=CYCLES, analyse_cycles=ANALYSE, seed=1, overrides=over)
        with CampaignEvaluator(camp, settings, workers=2) as ev:
            cells = []
            for e, b in ev.base().items():
                new = np.array(["_fold" in k or "_q" in k for k in ev.keys[e]])
                kind = sorted({k.split("_")[1] for k in np.array(ev.keys[e])[new]})
                cells.append(f"{e} {kind[0] if len(kind) == 1 else kind}: "
                             f"{np.sqrt(np.mean(b.z[new] ** 2)):.2f} / "
                             f"{np.sqrt(np.mean(b.z[~new] ** 2)):.2f}")
        print(f"{label}: RMS z folded-or-distribution / other keys, per event: "
              + "; ".join(cells))


def main() -> None:
    print("fold of an 8 s 1024 Hz record vs the noise-free fine-grid fold:")
    for q in FLOWS:
        _fold_error(q)
    print("\nengine, base model vs its own synthetic record:")
    for q in FLOWS:
        _engine(q)
    print("\nevidence (flows 200, 300, 400, 500, 650 gal/min):")
    _evidence()


if __name__ == "__main__":
    main()
