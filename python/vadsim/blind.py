"""Blind benchmark of the diagnosis: concealed physics in campaigns it has never seen.

An application of the fit layer (it writes campaigns, diagnoses them and writes a score
sheet through :mod:`vadsim.report`), so it sits above both, beside the reports.

Why this module exists: a diagnosis that names missing physics must be shown to name the
right one, to say "none" when nothing is missing, and to improve predictions of data it did
not fit. This benchmark writes campaigns in the RECORDINGS.md format from the model plus one
concealed effect (every candidate at two magnitudes, and none), through the sensor chain
with noise, under neutral names in shuffled order; the truth goes to ``truth.json``, which the
diagnosis never reads (it loads each campaign from disk). It then runs
:func:`vadsim.fit.diagnose.diagnose` on every campaign and scores:

* identification rate over the campaigns with an effect (overall and per candidate);
* false-alarm rate over the null campaigns;
* parameter error of correct identifications (relative, per parameter);
* held-out improvement ``1 - after / before`` of the held-out RMS standardised residual;
* concealment: per campaign, how many events the effect leaves nearly untouched (RMS
  standardised residual of the base model < 1) and how large it is elsewhere.

    vadsim blind --out blind-run        # the full benchmark (about an hour on 2 cores)
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vadsim._progress import ProgressArg, bar, reporter
from vadsim.campaigns import load_campaign, save_campaign
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.fit.candidates import CANDIDATES
from vadsim.fit.diagnose import diagnose
from vadsim.report.blind import blind_markdown

__all__ = ["DEFAULT_SCENARIOS", "Scenario", "blind_benchmark"]


@dataclass(frozen=True)
class Scenario:
    """One concealed truth: a candidate key and its values, or ``"none"``."""

    key: str
    values: dict[str, float]

    @property
    def id(self) -> str:
        """The candidate id a diagnosis should report."""
        return "none" if self.key == "none" else CANDIDATES[self.key].id


DEFAULT_SCENARIOS: tuple[Scenario, ...] = (
    Scenario("hydraulic_force[anvil]", {"c": 1.5e-4}),
    Scenario("hydraulic_force[anvil]", {"c": 4.0e-4}),
    Scenario("contact_law", {"hc_alpha": 1.0}),
    Scenario("contact_law", {"hc_alpha": 2.0}),
    Scenario("anvil_friction", {"force": 60.0}),
    Scenario("anvil_friction", {"force": 150.0}),
    Scenario("string_radiation", {"c": 6.0e4}),
    Scenario("string_radiation", {"c": 1.5e5}),
    Scenario("axial_lateral", {"gain": 3.0, "f_lat_hz": 60.0}),
    Scenario("axial_lateral", {"gain": 4.0, "f_lat_hz": 150.0}),
    Scenario("sensor_chain", {"f_res_hz": 700.0, "q": 8.0}),
    Scenario("sensor_chain", {"f_res_hz": 400.0, "q": 5.0}),
    *(Scenario("none", {}) for _ in range(5)),
)
"""Every candidate at two magnitudes (chosen so that the effect shows at some of the 7in
tool's operating points and not at others) and five null campaigns."""

DEFAULT_FLOWS = (200.0, 250.0, 300.0, 350.0, 400.0, 450.0, 500.0, 550.0, 600.0, 650.0)


def write_campaigns(folder: str | os.PathLike[str], scenarios: Sequence[Scenario],
                    *, preset: str = "7in-cde", flows: Sequence[float] = DEFAULT_FLOWS,
                    duration_s: float = 8.0, noise_g: float = 0.3, seed: int = 2026,
                    cycles: float = 300, analyse_cycles: float = 200) -> list[Path]:
    """Write one campaign per scenario under neutral shuffled names; the truth to
    ``truth.json``. Returns the campaign folders in name order."""
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(scenarios))
    truth: dict[str, Any] = {}
    paths = []
    for slot, i in enumerate(order):
        sc = scenarios[int(i)]
        name = f"blind-{slot + 1:02d}"
        kw: dict[str, Any] = {}
        if sc.key != "none":
            ch = CANDIDATES[sc.key].change(sc.values)
            kw = dict(extras=ch.extras, law=ch.law, overrides=ch.overrides or None,
                      measurement=ch.measurement)
        camp = synthetic_campaign(preset, flows, cycles=cycles, analyse_cycles=analyse_cycles,
                                  duration_s=duration_s, noise_g=noise_g,
                                  seed=int(rng.integers(2**31)), name=name, **kw)
        camp.description = "blind benchmark campaign"
        path = root / name
        save_campaign(camp, path)
        paths.append(path)
        truth[name] = {"id": sc.id, "key": sc.key, "values": sc.values,
                       "parameters": (CANDIDATES[sc.key].public_parameters(sc.values)
                                      if sc.key != "none" else {})}
    (root / "truth.json").write_text(json.dumps(truth, indent=2))
    return paths


def _concealment(diag) -> dict[str, Any]:
    rms = {e: float(np.sqrt(np.mean(np.square(list(z.values())))))
           for e, z in diag.baseline.heldout.items() if z}
    vals = np.array(list(rms.values()))
    return {"events_untouched": int(np.sum(vals < 1.0)), "events": int(vals.size),
            "max_event_rms": float(vals.max()) if vals.size else math.nan,
            "event_rms": rms}


def score(results: dict[str, dict[str, Any]], truth: dict[str, dict[str, Any]]
          ) -> dict[str, Any]:
    """Scores of diagnoses (``as_json`` outputs by campaign name) against the truth."""
    effect = [n for n in results if truth[n]["id"] != "none"]
    null = [n for n in results if truth[n]["id"] == "none"]
    per: dict[str, list[bool]] = {}
    perr: dict[str, list[float]] = {}
    gains: list[float] = []
    rows = []
    for n in sorted(results):
        r, t = results[n], truth[n]
        ok = r["missing_physics"] == t["id"]
        if t["id"] != "none":
            per.setdefault(t["id"], []).append(ok)
        errs: dict[str, float] = {}
        if ok and t["id"] != "none":
            for k, v in t["values"].items():
                got = r["parameters"].get(k)
                if got is not None and v != 0:
                    errs[k] = abs(float(got) / v - 1.0)
                    perr.setdefault(f"{t['id']}.{k}", []).append(errs[k])
            b, a = r["heldout_error_before"], r["heldout_error_after"]
            gains.append(1.0 - a / b if b > 0 else math.nan)
        rows.append({"campaign": n, "truth": t["id"], "truth_parameters": t["parameters"],
                     "found": r["missing_physics"], "parameters": r["parameters"],
                     "correct": ok, "parameter_error": errs,
                     "heldout_before": r["heldout_error_before"],
                     "heldout_after": r["heldout_error_after"],
                     "concealment": r.get("concealment"), "elapsed_s": r.get("elapsed_s")})
    ident = [r["correct"] for r in rows if r["truth"] != "none"]
    false_alarms = [not r["correct"] for r in rows if r["truth"] == "none"]
    return {
        "identification_rate": float(np.mean(ident)) if ident else math.nan,
        "identification_by_candidate": {k: float(np.mean(v)) for k, v in sorted(per.items())},
        "false_alarms": int(sum(false_alarms)), "null_campaigns": len(null),
        "effect_campaigns": len(effect),
        "parameter_error_median": {k: float(np.median(v)) for k, v in sorted(perr.items())},
        "heldout_improvement_min": float(np.nanmin(gains)) if gains else math.nan,
        "heldout_improvement_median": float(np.nanmedian(gains)) if gains else math.nan,
        "campaigns": rows,
    }


def blind_benchmark(
    folder: str | os.PathLike[str],
    *,
    scenarios: Sequence[Scenario] = DEFAULT_SCENARIOS,
    flows: Sequence[float] = DEFAULT_FLOWS,
    duration_s: float = 8.0,
    noise_g: float = 0.3,
    seed: int = 2026,
    cycles: float = 300,
    analyse_cycles: float = 200,
    workers: int | None = None,
    progress: ProgressArg = True,
) -> dict[str, Any]:
    """Write the concealed campaigns, diagnose each from disk, score, and write
    ``scores.json`` and ``scores.md`` into ``folder``. Finished diagnoses are kept in
    ``results/`` and reused, so an interrupted benchmark resumes."""
    say = reporter(progress)
    root = Path(folder)
    settings = dict(flows=list(flows), duration_s=duration_s, noise_g=noise_g, seed=seed,
                    cycles=cycles, analyse_cycles=analyse_cycles, n_campaigns=len(scenarios))
    camp_dir = root / "campaigns"
    if not (camp_dir / "truth.json").is_file():
        say(f"writing {len(scenarios)} campaigns to {camp_dir}")
        write_campaigns(camp_dir, scenarios, flows=flows, duration_s=duration_s,
                        noise_g=noise_g, seed=seed, cycles=cycles,
                        analyse_cycles=analyse_cycles)
    res_dir = root / "results"
    res_dir.mkdir(parents=True, exist_ok=True)
    names = sorted(p.name for p in camp_dir.iterdir() if (p / "campaign.toml").is_file())
    results: dict[str, dict[str, Any]] = {}
    t0 = time.perf_counter()
    progress_bar = bar(progress, len(names), "blind benchmark", "campaign")
    for i, name in enumerate(names):
        out = res_dir / f"{name}.json"
        progress_bar.update()
        if out.is_file():
            results[name] = json.loads(out.read_text())
            continue
        camp = load_campaign(camp_dir / name)  # from disk: the diagnosis sees what a user has
        diag = diagnose(camp, cycles=cycles, analyse_cycles=analyse_cycles, workers=workers,
                        progress=False)
        js = diag.as_json()
        js["concealment"] = _concealment(diag)
        out.write_text(json.dumps(js, indent=2))
        results[name] = js
        say(f"[{i + 1}/{len(names)}] {name}: {js['missing_physics']} "
            f"({diag.elapsed_s:.0f} s; {time.perf_counter() - t0:.0f} s so far)")
    progress_bar.close()
    truth = json.loads((camp_dir / "truth.json").read_text())  # read only to score
    sc = score(results, truth)
    sc["settings"] = settings
    (root / "scores.json").write_text(json.dumps(sc, indent=2, default=float))
    (root / "scores.md").write_text(blind_markdown(sc, settings))
    return sc
