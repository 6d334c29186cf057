"""Blind benchmark of the diagnosis: concealed physics in campaigns it has never seen.

An application of the fit layer (it writes campaigns, diagnoses them and writes a score
sheet through :mod:`vadsim.report`), so it sits above both, beside the reports.

Why this module exists: a diagnosis that names missing physics must be shown to name the
right one, to say "none" when nothing is missing (also when only a nuisance constant such as
the WOB reading is off), to name both effects of a pair, and to improve predictions of data it
did not fit -- and one overall score would hide which kind of campaign it fails on. This
benchmark writes campaigns in the RECORDINGS.md format from classes of scenarios
(:mod:`vadsim.blind.scenarios`: nulls, nuisance-only, effect under a nuisance, pairs, generic
effects, one-sensor effects, the RC bit, five events, 1 g noise, and the ``indep_*`` classes
written by an independent generator, :mod:`vadsim.blind.independent`), through the sensor chain
with noise, under neutral names in shuffled order; the truth and each campaign's class go to
``truth.json``, which the diagnosis never reads (it loads each campaign from disk). It then
runs :func:`vadsim.fit.diagnosis.diagnose` on every campaign and scores per class and overall
(:mod:`vadsim.blind.scoring`): identification, variants, false alarms, parameter errors,
held-out improvement, nuisance recovery, and the acceptance criteria as PASS/FAIL lines.

    vadsim blind --out blind-run                  # every class (44 campaigns)
    vadsim blind --out blind-run --classes pair   # some classes; the rest can follow later
    vadsim blind --list                           # the classes, no run
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vadsim._progress import ProgressArg, bar, reporter
from vadsim.blind.independent import write_campaign as write_independent_campaign
from vadsim.blind.scenarios import (
    CLASSES,
    DEFAULT_FLOWS,
    DEFAULT_SCENARIOS,
    FIVE_FLOWS,
    Scenario,
    candidate_id,
    class_counts,
    scenarios_of,
)
from vadsim.blind.scoring import CRITERIA, normalise_result, normalise_truth, score
from vadsim.blind.truth_regret import regret, regret_of, truth_is_library_point
from vadsim.campaigns import load_campaign, save_campaign
from vadsim.campaigns.synthetic import synthetic_campaign
from vadsim.compare import CampaignEvaluator
from vadsim.fit.diagnosis import diagnose
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import get_preset
from vadsim.model.settings import RunSettings
from vadsim.report.blind import blind_markdown

__all__ = ["CLASSES", "CRITERIA", "DEFAULT_FLOWS", "DEFAULT_SCENARIOS", "FIVE_FLOWS",
           "Scenario", "blind_benchmark", "candidate_id", "class_counts", "detectability",
           "normalise_result", "normalise_truth", "scenarios_of", "score", "write_campaigns"]


def _fingerprint(scenarios: Sequence[Scenario], **settings: Any) -> dict[str, Any]:
    """What decides the written campaigns, the scenarios hashed (no truth in the clear)."""
    text = json.dumps([s.describe() for s in scenarios], sort_keys=True)
    return {**settings, "n_scenarios": len(scenarios),
            "scenarios_sha256": hashlib.sha256(text.encode()).hexdigest()[:16]}


def _check_folder(root: Path, fingerprint: dict[str, Any]) -> None:
    """Write ``benchmark.json``, or refuse a folder written with other settings (its names
    and truths would not be this benchmark's)."""
    path = root / "benchmark.json"
    if path.is_file():
        old = json.loads(path.read_text())
        if old != fingerprint:
            diff = sorted(k for k in set(old) | set(fingerprint)
                          if old.get(k) != fingerprint.get(k))
            raise ValueError(f"{root} holds blind campaigns written with other settings "
                             f"({', '.join(diff)}); use another folder")
        return
    path.write_text(json.dumps(fingerprint, indent=2))


def _write_json(path: Path, data: Any) -> None:
    """Write atomically, so an interrupted benchmark never leaves half a truth file."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=float))
    os.replace(tmp, path)


def write_campaigns(folder: str | os.PathLike[str],
                    scenarios: Sequence[Scenario] = DEFAULT_SCENARIOS, *,
                    classes: Sequence[str] | None = None, seed: int = 2026,
                    duration_s: float | None = None,
                    cycles: float = DEFAULTS.recording_cycles,
                    analyse_cycles: float = DEFAULTS.analyse_cycles,
                    library: Mapping[str, Any] | None = None,
                    progress: ProgressArg = False) -> list[Path]:
    """Write the campaigns of ``classes`` (None: all) under neutral shuffled names; their
    truths and classes to ``truth.json``.

    Why so many parameters: writing the campaigns takes the scenario set (classes, seed,
    duration) and the settings of the synthetic recordings; keyword-only with defaults.

    Names and noise seeds are drawn over all ``scenarios``, so writing some classes now and
    others later into the same folder gives the same campaigns as writing all at once;
    campaigns already written are kept. Scenarios of the independent generator
    (``generator="independent"``) are written by :mod:`vadsim.blind.independent`, which
    settles ``cycles - analyse_cycles`` cycles before each record. ``duration_s`` (None:
    each scenario's) overrides the seconds per event (short test campaigns). ``library``
    maps candidate keys to objects with ``change(values)`` (default
    :data:`vadsim.fit.candidates.CANDIDATES`). Returns the selected campaigns' folders in
    name order.
    """
    scenarios_of(classes, scenarios)  # unknown classes are an error before anything is written
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    _check_folder(root, _fingerprint(scenarios, seed=seed, duration_s=duration_s,
                                     cycles=cycles, analyse_cycles=analyse_cycles))
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(scenarios))
    seeds = rng.integers(2**31, size=len(scenarios))
    truth_path = root / "truth.json"
    truth: dict[str, Any] = json.loads(truth_path.read_text()) if truth_path.is_file() else {}
    say = reporter(progress)
    paths = []
    for slot, i in enumerate(order):
        sc = scenarios[int(i)]
        if classes is not None and sc.class_name not in classes:
            continue
        name = f"blind-{slot + 1:02d}"
        path = root / name
        paths.append(path)
        if name in truth and (path / "campaign.toml").is_file():
            continue
        say(f"writing {name}")
        if sc.generator == "independent":
            write_independent_campaign(path, sc.independent_spec(
                duration_s, settle_cycles=cycles - analyse_cycles), seed=int(seeds[slot]),
                name=name)
        else:
            camp = synthetic_campaign(sc.preset, sc.flows, change=sc.change(library),
                                      cycles=cycles, analyse_cycles=analyse_cycles,
                                      duration_s=duration_s or sc.duration_s,
                                      noise_g=sc.noise_g, seed=int(seeds[slot]), name=name)
            camp.description = "blind benchmark campaign"
            save_campaign(camp, path)
        truth[name] = {**sc.describe(), "duration_s": duration_s or sc.duration_s}
        _write_json(truth_path, truth)
    return sorted(paths)


def detectability(scenario: Scenario, *, library: Mapping[str, Any] | None = None,
                  seed: int = 0, duration_s: float | None = None,
                  cycles: float = DEFAULTS.recording_cycles,
                  analyse_cycles: float = DEFAULTS.analyse_cycles,
                  phases: int = DEFAULTS.diagnosis_phases, workers: int | None = None
                  ) -> dict[float, float]:
    """How visible a scenario's effects are: per event (by flow), the RMS standardised
    residual of the base model with the scenario's nuisance truth against a campaign written
    with the whole truth. Below 1 the event looks like noise; a null gives about 0.2-0.5 at
    0.3 g. No diagnosis is run (seconds per scenario). An independent scenario's campaign
    is written by its generator into a temporary folder and read back."""
    if scenario.generator == "independent":
        with tempfile.TemporaryDirectory() as tmp:
            write_independent_campaign(Path(tmp), scenario.independent_spec(
                duration_s, settle_cycles=cycles - analyse_cycles), seed=seed)
            camp = load_campaign(tmp)
    else:
        camp = synthetic_campaign(scenario.preset, scenario.flows,
                                  change=scenario.change(library), cycles=cycles,
                                  analyse_cycles=analyse_cycles,
                                  duration_s=duration_s or scenario.duration_s,
                                  noise_g=scenario.noise_g, seed=seed)
    settings = RunSettings(get_preset(scenario.preset), cycles=cycles,
                           analyse_cycles=analyse_cycles)
    with CampaignEvaluator(camp, settings, phases=phases, workers=workers) as ev:
        got = ev.evaluate([("nuisance", scenario.nuisance_change())])
    return {ev_.flow_gpm: float(np.sqrt(np.mean(np.square(got[("nuisance", ev_.id)].z))))
            for ev_ in camp.events}


def _concealment(diag: Any) -> dict[str, Any] | None:
    """Per event, the base model's held-out RMS z: how many events the truth leaves nearly
    untouched (None if the diagnosis does not expose them)."""
    try:
        rms = {e: float(np.sqrt(np.mean(np.square(list(z.values())))))
               for e, z in diag.none_fit.heldout.items() if z}
    except (AttributeError, TypeError):
        return None
    vals = np.array(list(rms.values()))
    return {"events_untouched": int(np.sum(vals < 1.0)), "events": int(vals.size),
            "max_event_rms": float(vals.max()) if vals.size else math.nan,
            "event_rms": rms}


def _diagnose_all(camp_dir: Path, res_dir: Path, names: Sequence[str], *, cycles: float,
                  analyse_cycles: float, workers: int | None,
                  diagnose_kwargs: Mapping[str, Any], progress: ProgressArg,
                  finished_only: bool = False) -> dict[str, dict[str, Any]]:
    """Diagnose each campaign from disk, or reuse its ``results/<name>.json`` (with
    ``finished_only``, only reuse: the campaigns not diagnosed yet are left out)."""
    say = reporter(progress)
    res_dir.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict[str, Any]] = {}
    t0 = time.perf_counter()
    progress_bar = bar(progress, len(names), "blind benchmark", "campaign")
    for i, name in enumerate(names):
        out = res_dir / f"{name}.json"
        progress_bar.update()
        if out.is_file():
            results[name] = json.loads(out.read_text())
            continue
        if finished_only:
            continue
        camp = load_campaign(camp_dir / name)  # from disk: the diagnosis sees what a user has
        diag = diagnose(camp, cycles=cycles, analyse_cycles=analyse_cycles, workers=workers,
                        progress=False, **diagnose_kwargs)
        js = diag.as_json()
        js["concealment"] = _concealment(diag)
        _write_json(out, js)
        results[name] = js
        r = normalise_result(js)
        say(f"[{i + 1}/{len(names)}] {name}: {', '.join(r['ids']) or 'none'} ({r['verdict']}; "
            f"{js.get('elapsed_s', 0.0):.0f} s; {time.perf_counter() - t0:.0f} s so far)")
    progress_bar.close()
    return results


def _add_regrets(camp_dir: Path, res_dir: Path, results: dict[str, dict[str, Any]],
                 truth: Mapping[str, Any], *, cycles: float, analyse_cycles: float,
                 workers: int | None, progress: ProgressArg) -> None:
    """Each diagnosed campaign's regret against its truth (:mod:`vadsim.blind.truth_regret`),
    kept in ``results/<name>.regret.json`` beside the diagnosis and added to its result.
    Runs only after every diagnosis: the truth is read for scoring alone."""
    say = reporter(progress)
    for name, js in results.items():
        path = res_dir / f"{name}.regret.json"
        if path.is_file():
            kept = json.loads(path.read_text())
            # the noise as defined now, from the costs kept (a file of an earlier definition)
            js["regret"] = regret_of(kept["rss_truth"], kept["rss_chosen"], kept["n"])
            continue
        if not truth_is_library_point(truth[name]):
            js["regret"] = None  # n/a: no library point is the truth
            continue
        js["regret"] = regret(camp_dir / name, truth[name], js, cycles=cycles,
                              analyse_cycles=analyse_cycles, workers=workers)
        _write_json(path, js["regret"])
        g = js["regret"]
        say(f"{name}: regret {g['regret']:.0f} (noise {g['noise']:.0f})"
            + (" -- a search failure" if g["search_failure"] else ""))


def blind_benchmark(
    folder: str | os.PathLike[str],
    classes: Sequence[str] | None = None,
    *,
    scenarios: Sequence[Scenario] = DEFAULT_SCENARIOS,
    duration_s: float | None = None,
    seed: int = 2026,
    cycles: float = DEFAULTS.recording_cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    workers: int | None = None,
    diagnose_kwargs: Mapping[str, Any] | None = None,
    library: Mapping[str, Any] | None = None,
    finished_only: bool = False,
    regrets: bool = True,
    progress: ProgressArg = True,
) -> dict[str, Any]:
    """Write the concealed campaigns of ``classes`` (None: all), diagnose each from disk,
    score, and write ``scores.json`` and ``scores.md`` into ``folder``.

    Why so many parameters: the benchmark is the scenario set (classes, seed, duration), the
    diagnosis' run settings and its bookkeeping (resume, progress); keyword-only with defaults.

    Finished diagnoses are kept in ``results/`` and reused, so an interrupted benchmark
    resumes and classes run later are added to the same folder; the scores cover every
    campaign of the selected classes. ``diagnose_kwargs`` go to
    :func:`~vadsim.fit.diagnosis.diagnose` as they are (its thresholds, nuisance constants,
    candidates). A folder from the earlier benchmark (``truth.json`` without
    ``benchmark.json``) is diagnosed and scored as it is, in one class "default".
    ``finished_only`` scores the campaigns already diagnosed and runs nothing (the scores
    then say how many of the selected campaigns they cover). ``regrets`` (default on)
    evaluates each campaign's chosen and true models after its diagnosis
    (:mod:`vadsim.blind.truth_regret`; a few seconds a campaign) and scores the search failures.
    """
    root = Path(folder)
    camp_dir = root / "campaigns"
    legacy = (camp_dir / "truth.json").is_file() and not (camp_dir / "benchmark.json").is_file()
    if legacy:
        names = sorted(p.name for p in camp_dir.iterdir() if (p / "campaign.toml").is_file())
    else:
        selected = scenarios_of(classes, scenarios)
        reporter(progress)(f"{len(selected)} campaigns in {camp_dir}")
        names = [p.name for p in write_campaigns(
            camp_dir, scenarios, classes=classes, seed=seed, duration_s=duration_s,
            cycles=cycles, analyse_cycles=analyse_cycles, library=library,
            progress=progress if callable(progress) else False)]
    results = _diagnose_all(camp_dir, root / "results", names, cycles=cycles,
                            analyse_cycles=analyse_cycles, workers=workers,
                            diagnose_kwargs=dict(diagnose_kwargs or {}), progress=progress,
                            finished_only=finished_only)
    truth = json.loads((camp_dir / "truth.json").read_text())  # read only to score
    if regrets and not legacy:  # an earlier folder's campaigns may not load any more
        _add_regrets(camp_dir, root / "results", results, truth, cycles=cycles,
                     analyse_cycles=analyse_cycles, workers=workers, progress=progress)
    sc = score(results, truth, class_order=list(CLASSES))
    sc["settings"] = {"classes": list(classes) if classes is not None else "all",
                      "seed": seed, "duration_s": duration_s, "cycles": cycles,
                      "analyse_cycles": analyse_cycles, "n_campaigns": len(names),
                      "n_diagnosed": len(results),
                      "diagnose_kwargs": {k: repr(v) for k, v in (diagnose_kwargs or {}).items()}}
    _write_json(root / "scores.json", sc)
    (root / "scores.md").write_text(blind_markdown(sc, sc["settings"], CLASSES))
    return sc
