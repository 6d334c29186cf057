"""Fuzz and determinism tests of vadsim.simulate against the installed package.

Robustness contract: any parameter set, flow and option -- valid, extreme or invalid -- either
simulates (with finite outputs), or raises a *clear* error: ``ValueError`` naming the bad
parameter or option, or ``vadsim.SolverError`` saying at which simulated time it gave up
("t ="). Never a crash, an abort, a hang, another exception type, or a silent NaN.

The bulk of the fuzz runs in subprocesses (this file is also the worker script, see the end of
the file), so that a segfault, an abort or a hang fails one test with the offending case
instead of killing pytest. A smaller hypothesis-driven fuzz runs in-process.

Determinism contract: the same inputs give bitwise-identical outputs, run after run and when
runs execute concurrently in Python threads (the GIL is released during integration).
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import vadsim
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

# --------------------------------------------------------------------------------------------
# Case generation and the oracle (shared by the subprocess worker and the in-process tests)
# --------------------------------------------------------------------------------------------

PARAM_RANGES: dict[str, tuple[str, float, float]] = vadsim.model.presets.param_ranges()
PARAM_RULES: dict[str, str] = {name: rng[0] for name, rng in PARAM_RANGES.items()}
LENGTHS = tuple(row[0] for row in vadsim.model.presets.param_table() if row[1] == "l0")
MAX_LENGTH_M = 1e3  # |L| * l0, and the static deflection wob / k (Params.validate, Model)
EXCITATION_HZ = vadsim._core.EXCITATION_HZ_RANGE  # the flow's range follows from alpha
PRESET_NAMES = ("7in-cde", "7in-rc", "9.5in-pdc")
LAWS = ("kelvin_voigt", "kelvin_voigt_no_tension", "hunt_crossley")
STIFFNESS = ("k3", "k4", "k5", "k6", "k7", "kS", "kI", "kOn", "kOff", "kR")
DAMPING = ("c3", "c4", "c5", "c6", "c7", "cS", "cI", "cOn", "cOff", "cR", "cD")
# Stiffnesses that carry the weight on bit in the static state: zero is refused when wob > 0.
STATIC_LOAD_PATH = ("kR", "kOn", "k3", "k4", "k5", "k6", "k7")
BODIES = ("bit", "anvil", "housing", "motor", "sub", "lwd", "mwd")

# Short runs: every case costs milliseconds, and budgets turn pathological ones into errors.
SHORT = dict(record="none", summary_rate_hz=2000.0, max_steps=150_000, max_events=20_000)
MAX_SUMMARY_SAMPLES = 2e6  # per case: lower summary_rate_hz for very slow excitations

# Inputs that the Python layer names without the "parameter"/"option" prefix of the core.
PY_LEVEL_NAMES = ("flow_gpm", "wob_klbf", "initial_state", "max_steps", "max_events")
NAMED_RE = re.compile(r"\b(?:parameter|option) (\w+)")


def violates_rule(name: str, value: float) -> bool:
    """True if ``value`` is outside the documented range of parameter ``name``
    (``param_ranges``: "non-negative" is 0 or [lo, hi], "optional" nan (unset) or [lo, hi],
    the other rules [lo, hi])."""
    rule, lo, hi = PARAM_RANGES[name]
    if rule == "optional" and math.isnan(value):
        return False
    if not math.isfinite(value):
        return True
    if rule == "non-negative" and value == 0:
        return False
    return not lo <= value <= hi


def flow_range(alpha: float) -> tuple[float, float]:
    """The flows whose excitation alpha Q / (2 pi) lies in EXCITATION_HZ (the core's
    arithmetic, so that the bounds agree to the bit)."""
    return 2.0 * math.pi * EXCITATION_HZ[0] / alpha, 2.0 * math.pi * EXCITATION_HZ[1] / alpha


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(10 ** rng.uniform(math.log10(lo), math.log10(hi)))


def draw_case(rng: np.random.Generator) -> dict:
    """One random case: preset, full parameter dict, flow, options, law, extras, state.

    Categories: ``valid`` (moderate perturbations), ``extreme`` (every parameter scaled by
    10^U(-3, 3)), ``undamped`` (all damping and drag zero), ``unexcited`` (Fo = 0), ``stiff``
    (stiffnesses x 10^U(3, 6)), ``invalid`` (one to three parameters negative, NaN, +-inf or a
    zero mass), ``bad_option`` (one run option out of range) and ``absurd`` (values near the
    limits of double precision).
    """
    category = str(
        rng.choice(
            ["valid", "extreme", "undamped", "unexcited", "stiff", "invalid", "bad_option",
             "absurd"],
            p=[0.2, 0.25, 0.1, 0.1, 0.1, 0.12, 0.08, 0.05],
        )
    )
    preset = str(rng.choice(PRESET_NAMES))
    params = dict(vadsim.PRESETS[preset].params)
    names = list(params)
    flow = _log_uniform(rng, 1.0, 5000.0)
    cycles = int(rng.integers(2, 11))
    options: dict = dict(SHORT, cycles=cycles, analyse_cycles=int(rng.integers(1, cycles + 1)))
    options["method"] = str(rng.choice(["adams", "bdf"]))

    if category == "valid":
        for n in names:
            if n != "hc_n":
                params[n] *= 10 ** rng.uniform(-0.3, 0.3)
        params["hc_n"] = float(rng.uniform(1.0, 3.0))
    elif category == "extreme":
        for n in names:
            # hc_n must lie in [1, 3]: scale it only now and then, or most cases are refused.
            if n != "hc_n" or rng.random() < 0.1:
                params[n] *= 10 ** rng.uniform(-3.0, 3.0)
    elif category == "undamped":
        for n in DAMPING:
            params[n] = 0.0
        params["hc_alpha"] = 0.0
    elif category == "unexcited":
        params["Fo"] = 0.0
        if rng.random() < 0.5:
            params["cD"] = 0.0
    elif category == "stiff":
        for n in STIFFNESS:
            params[n] *= 10 ** rng.uniform(3.0, 6.0)
    elif category == "invalid":
        bad_values = [-1.0, -1e-12, float("nan"), float("inf"), float("-inf"), 0.0, -0.0]
        for n in rng.choice(names, size=int(rng.integers(1, 4)), replace=False):
            params[str(n)] = float(rng.choice(bad_values))
        if rng.random() < 0.3:  # a zero or negative mass for sure
            params[f"m{int(rng.integers(1, 8))}"] = float(rng.choice([0.0, -0.0, -1.44]))
    elif category == "bad_option":
        name, value = [
            ("flow", float(rng.choice([0.0, -200.0, float("nan"), float("inf"), 1e-3, 1e300]))),
            ("cycles", float(rng.choice([0.0, -3.0, float("nan"), float("inf"), 2e6]))),
            ("analyse_cycles", float(cycles + 1 + rng.integers(0, 5))),
            ("analyse_cycles", float(rng.choice([0.0, -1.0, float("nan")]))),
            ("rtol", float(rng.choice([0.0, 1e-16, 0.5, float("nan")]))),
            ("atol", float(rng.choice([0.0, -1e-8, float("nan"), float("inf"), 5e-324,
                                       10.0]))),
            ("max_step", float(rng.choice([-1.0, float("nan"), float("inf"), 5e-324]))),
            ("summary_rate_hz", float(rng.choice([0.0, -5.0, float("nan"), 1e8, 5e-324]))),
            ("max_steps", int(rng.choice([0, -10]))),
            ("max_events", -1),
            ("wob_klbf", float(rng.choice([-1.0, float("nan"), float("inf")]))),
        ][int(rng.integers(0, 11))]
        if name == "flow":
            flow = value
        else:
            options[name] = value
    elif category == "absurd":
        tiny_huge = [1e-300, 5e-324, 1e300, 1.7e308]
        for n in rng.choice(names, size=int(rng.integers(1, 4)), replace=False):
            params[str(n)] = float(rng.choice(tiny_huge))

    if rng.random() < 0.2 and category not in ("bad_option",):
        options["wob_klbf"] = float(vadsim.PRESETS[preset].wob_klbf * 10 ** rng.uniform(-1, 1))
    law = str(rng.choice(LAWS)) if rng.random() < 0.5 else None

    extras = []
    for _ in range(int(rng.choice([0, 0, 0, 1, 2]))):
        kind = str(rng.choice(["hydraulic", "friction", "dashpot"]))
        if kind == "hydraulic":
            extras.append(("hydraulic", {"acts_on": str(rng.choice(["anvil", "bit"])),
                                         "c": float(rng.normal(0.0, 1e-3))}))
        elif kind == "friction":
            extras.append(("friction", {"body": str(rng.choice(BODIES)),
                                        "other": str(rng.choice(BODIES)),
                                        "force": _log_uniform(rng, 1e-2, 1e3),
                                        "v_eps": _log_uniform(rng, 1e-6, 1.0)}))
        else:
            extras.append(("dashpot", {"body": str(rng.choice(BODIES)),
                                       "other": rng.choice([None, *BODIES]),
                                       "k": _log_uniform(rng, 1.0, 1e7),
                                       "c": _log_uniform(rng, 1e-2, 1e4)}))

    initial_state = None
    if rng.random() < 0.15:
        xs = static_positions(params, options.get("wob_klbf"), preset)
        if xs is not None:
            x = xs + rng.normal(0.0, 1e-3, 7)
            v = rng.normal(0.0, 2.0, 7)
            initial_state = [*map(float, x), *map(float, v)]

    # Very slow excitations (tiny alpha, 1 gal/min) span hours: bound the summary grid.
    if math.isfinite(flow) and flow > 0 and _finite_positive(params["alpha"]):
        period = 2 * math.pi / (params["alpha"] * flow)
        an = options["analyse_cycles"]
        if isinstance(an, (int, float)) and math.isfinite(an) and an > 0:
            span = an * period
            rate = options["summary_rate_hz"]
            if math.isfinite(span) and 0 < rate <= 1e7 and span * rate > MAX_SUMMARY_SAMPLES:
                options["summary_rate_hz"] = max(MAX_SUMMARY_SAMPLES / span, 1e-300)

    return {
        "category": category,
        "preset": preset,
        "params": params,
        "flow": flow,
        "options": options,
        "law": law,
        "extras": extras,
        "initial_state": initial_state,
    }


def _finite_positive(v: float) -> bool:
    return math.isfinite(v) and v > 0


def static_positions(params: dict, wob_klbf: float | None, preset: str) -> np.ndarray | None:
    """MODEL.md static on-bottom state, or None if the parameters give none."""
    p = dict(params)
    if wob_klbf is not None:
        p["wob"] = p["wob"] * wob_klbf / vadsim.PRESETS[preset].wob_klbf
    if any(violates_rule(n, v) for n, v in p.items()):
        return None
    if any(p[k] == 0 for k in STATIC_LOAD_PATH):
        return None
    with np.errstate(all="ignore"):
        w, l0 = p["wob"], p["l0"]
        x1 = (p["LR"] - p["L1"]) * l0 + w / p["kR"]
        x3 = x1 + (p["LI"] + p["LOn"] - p["L3"]) * l0 + w / p["kOn"]
        x4 = x3 + w / p["k3"]
        x5 = x4 + w / p["k4"]
        x6 = x5 + w / p["k5"]
        x7 = x6 + w / p["k6"]
        xs = np.array([x1, x1, x3, x4, x5, x6, x7])
    return xs if np.all(np.isfinite(xs)) else None


def run_case(case: dict) -> vadsim.SimulationResult:
    """Run one case through the public API."""
    extras = [vadsim.extra_force(kind, **dict(kw)) for kind, kw in case["extras"]]
    return vadsim.simulate(
        case["preset"],
        case["flow"],
        overrides=case["params"],
        law=case["law"],
        extras=extras,
        initial_state=case["initial_state"],
        **case["options"],
    )


def effective_wob(case: dict) -> float:
    """params["wob"] after the wob_klbf scaling that simulate applies (same arithmetic)."""
    wob = case["params"]["wob"]
    wk = case["options"].get("wob_klbf")
    if wk is None:
        return wob
    with np.errstate(all="ignore"):
        return float(np.float64(wob) * wk / vadsim.PRESETS[case["preset"]].wob_klbf)


def expected_refusals(case: dict) -> tuple[set[str], bool]:
    """The inputs a ValueError may blame for this case, and whether it must be refused.

    Invalid by the documented ranges (param_ranges, the length and static deflection bounds,
    the flow range from alpha, RunOptions.validate) are must-refuse. Also allowed, though the
    ranges alone do not predict it: a zero stiffness on the static load path under a non-zero
    weight on bit (no static state exists).
    """
    bad: set[str] = set()
    params = dict(case["params"])
    params["wob"] = effective_wob(case)
    opts = case["options"]
    for n, v in params.items():
        if violates_rule(n, v) or (n == "wob" and violates_rule(n, case["params"]["wob"])):
            bad.add(n)
    with np.errstate(all="ignore"):
        l0 = np.float64(params["l0"])
        for n in LENGTHS:
            v = params.get(n, math.nan)  # an unset optional length (L_gap) is not in params
            if not abs(v) * l0 <= MAX_LENGTH_M and not (
                    PARAM_RANGES[n][0] == "optional" and math.isnan(v)):
                bad.add(n)
        wob = np.float64(params["wob"])
        for k in STATIC_LOAD_PATH:
            if wob != 0 and params[k] != 0 and not wob / params[k] <= MAX_LENGTH_M:
                bad.add(k)
    flow = case["flow"]
    if not _finite_positive(flow):
        bad.add("flow_gpm")
    elif not violates_rule("alpha", params["alpha"]):
        lo, hi = flow_range(params["alpha"])
        if not lo <= flow <= hi:
            bad.add("flow_gpm")
    cyc = opts["cycles"]
    if not (1e-3 <= cyc <= 1e6):
        bad.add("cycles")
    an = opts["analyse_cycles"]
    if not (1e-3 <= an <= cyc):
        bad.add("analyse_cycles")
    if not (1e-14 <= opts.get("rtol", 1e-6) <= 0.1):
        bad.add("rtol")
    if not (1e-20 <= opts.get("atol", 1e-8) <= 1.0):
        bad.add("atol")
    ms = opts.get("max_step", 0.0)
    if not (ms == 0 or 1e-12 <= ms <= 1e6):
        bad.add("max_step")
    sr = opts["summary_rate_hz"]
    if not (sr == 0 or 1e-3 <= sr <= 1e7):  # 0: no summary
        bad.add("summary_rate_hz")
    if opts["max_steps"] <= 0:
        bad.add("max_steps")
    if opts["max_events"] < 0:
        bad.add("max_events")
    wk = opts.get("wob_klbf")
    if wk is not None and not (math.isfinite(wk) and wk >= 0):
        bad.add("wob_klbf")
    allowed = set(bad)
    if params["wob"] != 0:
        allowed.update(k for k in STATIC_LOAD_PATH if params[k] == 0)
    return allowed, bool(bad)


def classify(case: dict) -> tuple[str, str | None]:
    """Run a case; return (outcome, problem). ``problem`` is None when the contract holds."""
    allowed, must_fail = expected_refusals(case)
    try:
        r = run_case(case)
    except vadsim.SolverError as exc:
        msg = str(exc)
        if "t =" not in msg:
            return "solver_error", f"SolverError message does not say when: {msg!r}"
        if must_fail:
            return "solver_error", f"invalid input reached the integrator: {msg!r}"
        return "solver_error", None
    except ValueError as exc:
        msg = str(exc)
        if not msg.strip():
            return "value_error", "empty ValueError message"
        m = NAMED_RE.search(msg)
        if m:
            name = m.group(1)
        else:
            named = [n for n in PY_LEVEL_NAMES if msg.startswith(n)]
            if not named:
                return "value_error", f"ValueError names nothing: {msg!r}"
            name = named[0]
        if name in allowed:
            return "value_error", None
        if name in ("summary_rate_hz", "output_rate_hz") and "asks for more than" in msg:
            return "value_error", None  # documented cap on the number of grid samples
        return "value_error", f"ValueError blames {name!r}, a valid input: {msg!r}"
    except Exception as exc:  # noqa: BLE001 -- any other exception breaks the contract
        return "other_error", f"{type(exc).__name__}: {exc}"
    if must_fail:
        return "ok", f"invalid input was accepted (bad: {sorted(allowed)})"
    checks = {
        "y_end": np.all(np.isfinite(r.y_end)),
        "poincare": np.all(np.isfinite(r.poincare)),
        "events": np.all(np.isfinite(r.events["time_s"].to_numpy())),
        "impacts >= 0": all(n >= 0 for n in r.impacts.values()),
    }
    if case["options"]["summary_rate_hz"] == 0:
        # No summary asked for: the documented contract is J* = NaN and no windows, never
        # a made-up zero that a caller could mistake for "no impulse".
        checks.update({
            "no summary: impulse_mean is NaN": math.isnan(r.impulse_mean),
            "no summary: impulse_pos is NaN": math.isnan(r.impulse_pos),
            "no summary: no windows": np.size(r.window_peaks_g) == 0,
        })
    else:
        checks.update({
            "impulse_mean": math.isfinite(r.impulse_mean),
            "impulse_pos": math.isfinite(r.impulse_pos),
            "window_peaks_g": np.all(np.isfinite(r.window_peaks_g)),
            "impulse_pos >= max(mean, 0)": r.impulse_pos >= max(r.impulse_mean, 0.0) - 1e-9 * (
                1 + abs(r.impulse_mean)),
        })
    bad = [k for k, ok in checks.items() if not ok]
    if bad:
        return "ok", f"run succeeded with non-finite or inconsistent outputs: {bad}"
    return "ok", None


def worker(seed: int, n: int) -> None:
    """Subprocess entry: run n cases drawn from seed, then print a JSON summary.

    Each case is announced ("START i") before it runs, so that a crash or a hang points at
    it; :func:`nth_case` redraws it.
    """
    rng = np.random.default_rng(seed)
    counts: dict[str, int] = {}
    problems = []
    slowest = (0.0, None)
    for i in range(n):
        case = draw_case(rng)
        print("START", i, flush=True)
        t0 = time.perf_counter()
        outcome, problem = classify(case)
        dt = time.perf_counter() - t0
        if dt > slowest[0]:
            slowest = (dt, i)
        key = f"{case['category']}:{outcome}"
        counts[key] = counts.get(key, 0) + 1
        if problem:
            problems.append({"index": i, "problem": problem, "case": repr(case)})
    print("SUMMARY", json.dumps({"counts": counts, "problems": problems,
                                 "slowest_s": slowest[0], "slowest_index": slowest[1]}),
          flush=True)


def nth_case(seed: int, index: int) -> dict:
    """The case a worker with this seed ran as number ``index`` (the generator is seeded)."""
    rng = np.random.default_rng(seed)
    for _ in range(index):
        draw_case(rng)
    return draw_case(rng)


# --------------------------------------------------------------------------------------------
# Subprocess fuzz (the bulk): two workers in parallel, one per core
# --------------------------------------------------------------------------------------------

# The budget is a count: every worker runs N_PER_WORKER cases, however long the machine takes.
# Time only guards against hangs: a worker that starts no new case (nor finishes) within
# CASE_HANG_GUARD_S is killed. A case takes milliseconds (the slowest about a second), so the
# guard is far from any real case even on a busy machine.
N_PER_WORKER = 1250
CASE_HANG_GUARD_S = 120.0
SEEDS = (20240601, 777)


def _last_started(out: str, seed: int) -> str:
    starts = [line for line in out.splitlines() if line.startswith("START")]
    if not starts:
        return "(no case started)"
    index = int(starts[-1].split()[1])
    return f"#{index}: {nth_case(seed, index)!r}"


def _wait_with_hang_guard(procs: list) -> set[int]:
    """Wait for every worker; kill one whose output stops growing for CASE_HANG_GUARD_S.
    Returns the seeds of the killed workers."""
    progress = {seed: (-1, time.monotonic()) for seed, *_ in procs}
    hung: set[int] = set()
    while True:
        running = 0
        for seed, proc, out, _ in procs:
            if proc.poll() is not None:
                continue
            running += 1
            size = out.seek(0, 2)  # each START line is progress
            last_size, since = progress[seed]
            now = time.monotonic()
            if size != last_size:
                progress[seed] = (size, now)
            elif now - since > CASE_HANG_GUARD_S:
                proc.kill()
                proc.wait()
                hung.add(seed)
        if not running:
            return hung
        time.sleep(0.2)


@pytest.mark.slow
def test_fuzz_subprocess_never_crashes(tmp_path):
    procs = []
    for seed in SEEDS:
        out = open(tmp_path / f"worker_{seed}.out", "w+")  # files, not pipes: no blocking
        err = open(tmp_path / f"worker_{seed}.err", "w+")
        proc = subprocess.Popen([sys.executable, __file__, "--worker", str(seed),
                                 str(N_PER_WORKER)], stdout=out, stderr=err, text=True)
        procs.append((seed, proc, out, err))
    hung = _wait_with_hang_guard(procs)
    summaries, failures = [], []
    for seed, proc, out, err in procs:
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
        out.close()
        err.close()
        if seed in hung:
            failures.append(f"seed {seed}: no progress for {CASE_HANG_GUARD_S} s (hang) in case "
                            f"{_last_started(stdout, seed)}")
            continue
        if proc.returncode != 0:
            failures.append(
                f"seed {seed}: worker exited with {proc.returncode} (crash/abort) in case "
                f"{_last_started(stdout, seed)}\nstderr tail: {stderr[-2000:]}"
            )
            continue
        line = [ln for ln in stdout.splitlines() if ln.startswith("SUMMARY")]
        assert line, f"seed {seed}: no summary; stderr: {stderr[-2000:]}"
        summary = json.loads(line[-1][len("SUMMARY "):])
        summaries.append(summary)
        for p in summary["problems"]:
            failures.append(f"seed {seed} case {p['index']}: {p['problem']}\n  case: {p['case']}")
    assert not failures, "\n".join(failures[:20]) + f"\n({len(failures)} problems in all)"
    # The fuzz must exercise every outcome, else it tests nothing.
    totals: dict[str, int] = {}
    for s in summaries:
        for k, v in s["counts"].items():
            outcome = k.split(":")[1]
            totals[outcome] = totals.get(outcome, 0) + v
    assert sum(totals.values()) == N_PER_WORKER * len(SEEDS)
    assert totals.get("ok", 0) > 0.2 * sum(totals.values()), totals
    assert totals.get("value_error", 0) > 0, totals
    assert totals.get("solver_error", 0) > 0, totals


# --------------------------------------------------------------------------------------------
# In-process hypothesis fuzz (fewer examples)
# --------------------------------------------------------------------------------------------

_SCALED_PARAMS = [n for n, rule in PARAM_RULES.items() if n != "hc_n" and rule != "optional"]


@st.composite
def hyp_cases(draw):
    preset = draw(st.sampled_from(PRESET_NAMES))
    params = dict(vadsim.PRESETS[preset].params)
    exps = draw(st.lists(st.floats(-3, 3), min_size=len(_SCALED_PARAMS),
                         max_size=len(_SCALED_PARAMS)))
    for n, e in zip(_SCALED_PARAMS, exps, strict=True):
        params[n] *= 10 ** e
    params["hc_n"] = draw(st.floats(1.0, 3.0))
    special = draw(st.sampled_from(["none", "undamped", "unexcited", "stiff", "bad"]))
    if special == "undamped":
        for n in DAMPING:
            params[n] = 0.0
    elif special == "unexcited":
        params["Fo"] = 0.0
    elif special == "stiff":
        for n in STIFFNESS:
            params[n] *= 1e4
    elif special == "bad":
        name = draw(st.sampled_from(sorted(PARAM_RULES)))
        params[name] = draw(st.sampled_from([-1.0, 0.0, float("nan"), float("inf"),
                                             float("-inf")]))
    cycles = draw(st.integers(2, 10))
    return {
        "category": f"hypothesis:{special}",
        "preset": preset,
        "params": params,
        "flow": draw(st.floats(1.0, 5000.0)),
        "options": dict(SHORT, cycles=cycles, analyse_cycles=draw(st.integers(1, cycles)),
                        summary_rate_hz=500.0),
        "law": draw(st.sampled_from([None, *LAWS])),
        "extras": [],
        "initial_state": None,
    }


@settings(max_examples=150, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(case=hyp_cases())
def test_fuzz_in_process(case):
    # Keep very slow excitations cheap (as draw_case does).
    period = 2 * math.pi / (case["params"]["alpha"] * case["flow"]) if _finite_positive(
        case["params"]["alpha"]) else 1.0
    span = case["options"]["analyse_cycles"] * period
    if math.isfinite(span) and span * case["options"]["summary_rate_hz"] > MAX_SUMMARY_SAMPLES:
        case["options"]["summary_rate_hz"] = MAX_SUMMARY_SAMPLES / span
    outcome, problem = classify(case)
    assert problem is None, f"{outcome}: {problem}\ncase: {case}"


# --------------------------------------------------------------------------------------------
# Determinism
# --------------------------------------------------------------------------------------------

DET_CASES = [
    ("7in-cde", 200.0, {}),
    ("7in-cde", 350.0, {}),  # intermittent: sensitive to any rounding difference
    ("7in-cde", 500.0, {"law": "hunt_crossley"}),
    ("7in-rc", 275.0, {"law": "kelvin_voigt_no_tension"}),
    ("9.5in-pdc", 560.0, {"method": "bdf"}),
    ("7in-cde", 420.0, {"extras": "friction"}),
]


def _det_run(case):
    preset, flow, kw = case
    kw = dict(kw)
    if kw.pop("extras", None) == "friction":
        kw["extras"] = [vadsim.extra_force("friction", force=20.0, v_eps=1e-3),
                        vadsim.extra_force("hydraulic", acts_on="bit", c=1e-4)]
    return vadsim.simulate(preset, flow, cycles=30, analyse_cycles=15, record="window",
                           output_rate_hz=5000, summary_rate_hz=5000, **kw)


def _assert_identical(r1, r2, label):
    for name in ("t", "x", "v", "a", "contact_forces", "excitation_force", "poincare",
                 "poincare_t", "y_end", "window_peaks_g"):
        a1, a2 = np.asarray(getattr(r1, name)), np.asarray(getattr(r2, name))
        assert a1.shape == a2.shape and a1.dtype == a2.dtype, f"{label}: {name}"
        assert a1.tobytes() == a2.tobytes(), f"{label}: {name} differs"
    assert list(r1.events.columns) == list(r2.events.columns)
    for col in ("time_s", "rel_velocity_mps"):
        assert r1.events[col].to_numpy().tobytes() == r2.events[col].to_numpy().tobytes(), (
            f"{label}: events.{col} differs")
    assert r1.events.equals(r2.events), f"{label}: events differ"
    assert r1.impacts == r2.impacts, label
    # Bitwise: compare the floats' representations, not within a tolerance.
    assert r1.impulse_mean.hex() == r2.impulse_mean.hex(), label
    assert r1.impulse_pos.hex() == r2.impulse_pos.hex(), label
    assert r1.window == r2.window, label
    assert r1.stats == r2.stats, label


def test_same_inputs_give_bitwise_identical_results():
    for case in DET_CASES[:3]:
        a, b = _det_run(case), _det_run(case)
        assert len(a.events) > 0
        _assert_identical(a, b, f"repeat {case}")


def test_threads_give_bitwise_identical_results():
    serial = [_det_run(c) for c in DET_CASES]
    with ThreadPoolExecutor(max_workers=4) as ex:
        # Each case twice, interleaved, so that identical runs overlap in time too.
        threaded = list(ex.map(_det_run, DET_CASES + DET_CASES))
    for i, case in enumerate(DET_CASES):
        _assert_identical(serial[i], threaded[i], f"thread {case}")
        _assert_identical(serial[i], threaded[i + len(DET_CASES)], f"thread (2nd) {case}")


def test_threaded_errors_are_clean():
    """Errors raised in worker threads are the same clear errors as in serial runs."""
    def bad(i):
        if i % 2:
            return vadsim.simulate("7in-cde", 200, cycles=5, analyse_cycles=2, max_steps=50,
                                   **{k: v for k, v in SHORT.items() if k != "max_steps"})
        return vadsim.simulate("7in-cde", 200, overrides={"kI": -1.0}, **SHORT)

    with ThreadPoolExecutor(max_workers=4) as ex:
        futures = [ex.submit(bad, i) for i in range(8)]
    for i, f in enumerate(futures):
        exc = f.exception()
        if i % 2:
            assert isinstance(exc, vadsim.SolverError) and "t =" in str(exc)
        else:
            assert isinstance(exc, ValueError) and "kI" in str(exc)


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--worker":
        worker(int(sys.argv[2]), int(sys.argv[3]))
    else:
        print("usage: test_simulate_fuzz.py --worker SEED N", file=sys.stderr)
        sys.exit(2)
