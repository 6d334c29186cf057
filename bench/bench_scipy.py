"""Time vadsim against SciPy's LSODA on the same model, in the same process.

The model of MODEL.md is written here again in plain Python/NumPy, independently of the C++
core, the way a SciPy user would write it: the right-hand side switches every Kelvin-Voigt
contact on and off from the current state (F = H(d) (k d + c d')), with no mode bookkeeping,
and ``solve_ivp(method=LSODA, events=...)`` records the contact crossings (the five
indentations, both directions). Both integrators get the same problem:

- state ``[u, v]`` with ``u = x - x_static`` (displacements from the static on-bottom state,
  as vadsim integrates them, so ``rtol`` means the same thing on both sides);
- ``rtol = 1e-6``, ``atol = 1e-8`` m on displacements and ``1e-5`` m/s on velocities
  (vadsim's defaults);
- ``cycles`` excitation cycles from the static state at ``t = 0``, the last ``analyse_cycles``
  analysed: impacts per cycle Z from the contact onsets (d crossing 0 upwards) and
  J* = mean of max(F_I, 0) on a 20 kHz grid (for SciPy: the solver's dense output, through
  ``t_eval``).

Usage::

    python bench/bench_scipy.py                 # 400 cycles at 200 gal/min
    python bench/bench_scipy.py --cycles 20     # smoke test

vadsim runs twice: the literal run (``steady="full"``, every cycle integrated: the
integrator's speed, compared with LSODA's) and the time to the same answer with
``steady="auto"`` (the run stops at its periodic orbit and builds the window from it). The
lines ``ratio scipy/vadsim (literal): NNNx`` and ``ratio scipy/vadsim (steady=auto): NNNx``
give both. The exit status is 1 if an integration disagrees with SciPy's on the physics (Z of
the spring or the impact face, or J* beyond ``--jstar-tol``).
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp
from scipy.integrate._ivp.lsoda import LSODA

SURFACES = ("spring", "impact", "off_bottom", "on_bottom", "rock")

# Bodies joined by each contact: d = d_static + u[A] - u[B] (B = -1: the rock, fixed).
_SURFACE_A = (2, 1, 0, 2, 0)
_SURFACE_B = (1, 0, 2, 0, -1)


class ReferenceModel:
    """MODEL.md's 7-DOF model in plain Python, on the state ``y = [u1..u7, v1..v7]``.

    ``u = x - x_static`` (m), ``v`` (m/s). Attributes: ``x_static`` (absolute static positions,
    m), ``x_top``, ``d_static`` (the five indentations at the static state, m), ``omega``
    (rad/s), ``rhs(t, y)`` (for ``solve_ivp``) and ``events`` (the five indentations).
    """

    def __init__(self, params: Mapping[str, float], flow_gpm: float) -> None:
        p = {k: float(v) for k, v in params.items()}
        self.params = p
        self.flow_gpm = float(flow_gpm)
        l0, wob = p["l0"], p["wob"]
        LS, L1, L2, L3, LI, LOn, LR = (p[k] * l0 for k in ("LS", "L1", "L2", "L3", "LI", "LOn",
                                                           "LR"))

        # MODEL.md "The run", step 1: static on-bottom equilibrium, absolute metres.
        x1 = LR - L1 + wob / p["kR"]
        x2 = x1
        x3 = x1 + LI + LOn - L3 + wob / p["kOn"]
        x4 = x3 + wob / p["k3"]
        x5 = x4 + wob / p["k4"]
        x6 = x5 + wob / p["k5"]
        x7 = x6 + wob / p["k6"]
        x_top = x7 + wob / p["k7"]
        self.x_static = np.array([x1, x2, x3, x4, x5, x6, x7])
        self.x_top = x_top

        # Indentations of MODEL.md's table at the static state. They are linear in x with unit
        # coefficients, so d = d_static + u_a - u_b exactly (and without the cancellation of
        # subtracting two ~3 m positions at every evaluation).
        self.d_static = np.array(self.indentations_abs(self.x_static))
        dS0, dI0, dOff0, dOn0, dR0 = self.d_static.tolist()
        # String springs' extensions at the static state.
        e3, e4, e5, e6, e7 = x3 - x4, x4 - x5, x5 - x6, x6 - x7, x7 - x_top
        rel0 = x2 - x3  # x2 - x3 in metres enters the excitation

        k3, k4, k5, k6, k7 = (p[k] for k in ("k3", "k4", "k5", "k6", "k7"))
        c3, c4, c5, c6, c7 = (p[k] for k in ("c3", "c4", "c5", "c6", "c7"))
        kS, kI, kOff, kOn, kR = (p[k] for k in ("kS", "kI", "kOff", "kOn", "kR"))
        cS, cI, cOff, cOn, cR = (p[k] for k in ("cS", "cI", "cOff", "cOn", "cR"))
        im1, im2, im3, im4, im5, im6, im7 = (1.0 / p[f"m{i}"] for i in range(1, 8))
        Fo, beta, phi, psi, cD = p["Fo"], p["beta"], p["phi"], p["psi"], p["cD"]
        omega = p["alpha"] * self.flow_gpm
        self.omega = omega
        self.f_exc_hz = omega / (2.0 * math.pi)
        cos, sin, array = math.cos, math.sin, np.array

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            u1, u2, u3, u4, u5, u6, u7, v1, v2, v3, v4, v5, v6, v7 = y.tolist()
            # Contacts: F = H(d) (k d + c d'), d from MODEL.md's table.
            d = dS0 + u3 - u2  # spring: (x3 + LS) - (x2 - L2)
            FS = kS * d + cS * (v3 - v2) if d > 0.0 else 0.0
            d = dI0 + u2 - u1  # impact face: x2 - x1
            FI = kI * d + cI * (v2 - v1) if d > 0.0 else 0.0
            d = dOff0 + u1 - u3  # off-bottom: (x1 + LI) - (x3 + L3)
            FOff = kOff * d + cOff * (v1 - v3) if d > 0.0 else 0.0
            d = dOn0 + u3 - u1  # on-bottom: (x3 + L3) - (x1 + LI + LOn)
            FOn = kOn * d + cOn * (v3 - v1) if d > 0.0 else 0.0
            d = dR0 + u1  # rock: (x1 + L1) - LR
            FR = kR * d + cR * v1 if d > 0.0 else 0.0
            # String: tension of each spring/dashpot pair, k (x_i - x_j) + c (v_i - v_j).
            f3 = k3 * (e3 + u3 - u4) + c3 * (v3 - v4)
            f4 = k4 * (e4 + u4 - u5) + c4 * (v4 - v5)
            f5 = k5 * (e5 + u5 - u6) + c5 * (v5 - v6)
            f6 = k6 * (e6 + u6 - u7) + c6 * (v6 - v7)
            f7 = k7 * (e7 + u7) + c7 * v7
            FH = Fo * cos(omega * t + phi) * sin(beta * (rel0 + u2 - u3) + psi)
            FD = cD * v2 * abs(v2)
            return array((
                v1, v2, v3, v4, v5, v6, v7,
                (-FR + FOn - FOff + FI) * im1,
                (-FI + FS + FH - FD) * im2,
                (-f3 - FS - FOn + FOff) * im3,
                (f3 - f4) * im4,
                (f4 - f5) * im5,
                (f5 - f6) * im6,
                (f6 - f7) * im7,
            ))

        def ev_spring(t, y):
            return dS0 + y[2] - y[1]

        def ev_impact(t, y):
            return dI0 + y[1] - y[0]

        def ev_off_bottom(t, y):
            return dOff0 + y[0] - y[2]

        def ev_on_bottom(t, y):
            return dOn0 + y[2] - y[0]

        def ev_rock(t, y):
            return dR0 + y[0]

        events = [ev_spring, ev_impact, ev_off_bottom, ev_on_bottom, ev_rock]
        for ev in events:
            ev.direction = 0  # both: onsets and releases
            ev.terminal = False
        self.rhs = rhs
        self.events = events

    def indentations_abs(self, x: Sequence[float]) -> list[float]:
        """The five indentations (m) of MODEL.md's table at absolute positions ``x``."""
        p, l0 = self.params, self.params["l0"]
        x1, x2, x3 = x[0], x[1], x[2]
        return [
            (x3 + p["LS"] * l0) - (x2 - p["L2"] * l0),
            x2 - x1,
            (x1 + p["LI"] * l0) - (x3 + p["L3"] * l0),
            (x3 + p["L3"] * l0) - (x1 + (p["LI"] + p["LOn"]) * l0),
            (x1 + p["L1"] * l0) - p["LR"] * l0,
        ]

    def indentation(self, s: int, y: np.ndarray) -> np.ndarray:
        """Indentation (m) of surface ``s`` for ``y`` of shape (14,) or (14, n)."""
        b = _SURFACE_B[s]
        return self.d_static[s] + y[_SURFACE_A[s]] - (y[b] if b >= 0 else 0.0)

    def indentation_rate(self, s: int, y: np.ndarray) -> np.ndarray:
        """d' (m/s) of surface ``s`` for ``y`` of shape (14,) or (14, n)."""
        b = _SURFACE_B[s]
        return y[7 + _SURFACE_A[s]] - (y[7 + b] if b >= 0 else 0.0)

    def impact_force(self, y: np.ndarray) -> np.ndarray:
        """F_I (N/kg) at states ``y`` of shape (14, n)."""
        d = self.indentation(1, y)
        f = self.params["kI"] * d + self.params["cI"] * self.indentation_rate(1, y)
        return np.where(d > 0.0, f, 0.0)


def make_model(params: Mapping[str, float], flow_gpm: float) -> ReferenceModel:
    """The reference model for ``params`` (a dict by name, e.g. a preset's) at ``flow_gpm``."""
    return ReferenceModel(params, flow_gpm)


class _CountingLSODA(LSODA):
    """SciPy's LSODA, unchanged, counting its steps (``solve_ivp`` does not report them)."""

    last: _CountingLSODA | None = None

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.n_steps = 0
        _CountingLSODA.last = self

    def _step_impl(self):
        out = super()._step_impl()
        self.n_steps += 1
        return out


def run_scipy(
    params: Mapping[str, float],
    flow_gpm: float,
    cycles: float = 400,
    analyse_cycles: float | None = None,
    *,
    rtol: float = 1e-6,
    atol_x: float = 1e-8,
    atol_v: float = 1e-5,
    summary_rate_hz: float = 20000.0,
) -> dict:
    """Integrate the reference model with ``solve_ivp(method="LSODA", events=...)``.

    Returns a dict: ``seconds`` (wall time of ``solve_ivp``), ``steps``, ``nfev``, ``njev``,
    ``onset_times`` (per surface, all onsets of the run), ``impacts`` (onsets in the window
    per surface), ``z``, ``impulse_pos``, ``impulse_mean`` (N/kg), ``window``, ``f_exc_hz``.
    """
    if analyse_cycles is None:
        analyse_cycles = cycles / 2
    model = make_model(params, flow_gpm)
    period = 1.0 / model.f_exc_hz
    t_end = cycles * period
    t_w0 = (cycles - analyse_cycles) * period
    # The summary grid of vadsim: t_w0 + k / rate, k = 0 .. floor(span * rate) - 1.
    n = max(1, math.floor((t_end - t_w0) * summary_rate_hz * (1 + 1e-12)))
    t_eval = t_w0 + np.arange(n) / summary_rate_hz
    atol = np.r_[np.full(7, atol_x), np.full(7, atol_v)]
    y0 = np.zeros(14)  # the static state, at rest

    t_start = time.perf_counter()
    sol = solve_ivp(model.rhs, (0.0, t_end), y0, method=_CountingLSODA, t_eval=t_eval,
                    events=model.events, rtol=rtol, atol=atol)
    seconds = time.perf_counter() - t_start
    if sol.status != 0:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    solver = _CountingLSODA.last

    onset_times: dict[str, np.ndarray] = {}
    impacts: dict[str, int] = {}
    for s, name in enumerate(SURFACES):
        te, ye = sol.t_events[s], sol.y_events[s]
        if te.size:
            # An onset is d crossing 0 upwards: d' > 0 at the crossing.
            onset = model.indentation_rate(s, ye.T) > 0.0
            onset_times[name] = te[onset]
        else:
            onset_times[name] = te
        impacts[name] = int(np.count_nonzero(onset_times[name] >= t_w0))
    fi = model.impact_force(sol.y)
    return {
        "seconds": seconds,
        "steps": solver.n_steps,
        "nfev": int(sol.nfev),
        "njev": int(sol.njev),
        "nlu": int(sol.nlu),
        "method_last": {1: "Adams", 2: "BDF"}.get(int(solver._lsoda_solver._integrator.iwork[18]),
                                                   "?"),
        "onset_times": onset_times,
        "crossings": {name: int(sol.t_events[s].size) for s, name in enumerate(SURFACES)},
        "impacts": impacts,
        "z": {k: v / analyse_cycles for k, v in impacts.items()},
        "impulse_pos": float(np.maximum(fi, 0.0).mean()),
        "impulse_mean": float(fi.mean()),
        "window": (t_w0, t_end),
        "f_exc_hz": model.f_exc_hz,
    }


def run_vadsim(preset: str, flow_gpm: float, cycles: float, analyse_cycles: float,
               steady: str = "full"):
    """One vadsim run with its defaults (Adams, rtol 1e-6, atol 1e-8 m / 1e-5 m/s)."""
    import vadsim

    return vadsim.simulate(preset, flow_gpm, cycles=cycles, analyse_cycles=analyse_cycles,
                           record="none", steady=steady)


def time_vadsim(args: argparse.Namespace, analyse: float, steady: str) -> tuple[Any, float]:
    """``--vadsim-runs`` runs in one steady mode: the last result and the median time."""
    vt = []
    for _ in range(args.vadsim_runs):
        t0 = time.perf_counter()
        r = run_vadsim(args.preset, args.flow, args.cycles, analyse, steady)
        vt.append(time.perf_counter() - t0)
    v_med = statistics.median(vt)
    print(f"\nvadsim steady={steady} ({args.vadsim_runs} runs): median {_fmt_s(v_med)}  "
          f"[min {_fmt_s(min(vt))}, max {_fmt_s(max(vt))}]")
    st = r.stats
    print(f"  CVODE Adams: steps {st['steps']}, rhs evals {st['rhs_evals']}, "
          f"jac evals {st['jac_evals']}, root evals {st['root_evals']}, "
          f"reinits {st['reinits']}")
    print(f"  {r.steady_info}")
    return r, v_med


def check_physics(r: Any, s: Mapping[str, Any], args: argparse.Namespace, analyse: float,
                  label: str) -> bool:
    """Z and J* of a vadsim run against SciPy's, printed; False where they disagree."""
    print(f"\nphysics over the last {analyse:g} cycles (vadsim {label} | scipy):")
    ok = True
    for name in ("spring", "impact"):
        zv, zs = r.z[name], s["z"][name]
        good = abs(zv - zs) <= args.z_tol
        ok &= good
        print(f"  Z {name:<7} {zv:8.4f} | {zs:8.4f}   ({r.impacts[name]} | {s['impacts'][name]} "
              f"impacts)  {'ok' if good else 'DISAGREE'}")
    jv, js = r.impulse_pos, s["impulse_pos"]
    rel = abs(js - jv) / abs(jv) if jv else math.inf
    good = rel <= args.jstar_tol
    ok &= good
    print(f"  J* mean max(F_I,0) N/kg {jv:8.3f} | {js:8.3f}   (diff {100 * rel:.2f} %)  "
          f"{'ok' if good else 'DISAGREE'}")
    print(f"  J* mean F_I       N/kg {r.impulse_mean:8.3f} | {s['impulse_mean']:8.3f}")
    return ok


def _fmt_s(x: float) -> str:
    return f"{x * 1e3:.1f} ms" if x < 1 else f"{x:.2f} s"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cycles", type=float, default=400, help="excitation cycles (default 400)")
    ap.add_argument("--analyse-cycles", type=float, default=None,
                    help="analysed (last) cycles (default: half of --cycles)")
    ap.add_argument("--flow", type=float, default=200, help="flow, gal/min (default 200)")
    ap.add_argument("--preset", default="7in-cde", help="vadsim preset (default 7in-cde)")
    ap.add_argument("--vadsim-runs", type=int, default=11, help="vadsim runs (median; 11)")
    ap.add_argument("--scipy-runs", type=int, default=1, help="SciPy runs (median; 1)")
    ap.add_argument("--jstar-tol", type=float, default=0.03,
                    help="relative J* agreement required (default 0.03)")
    ap.add_argument("--z-tol", type=float, default=0.02,
                    help="absolute Z agreement required (default 0.02)")
    args = ap.parse_args(argv)
    if args.vadsim_runs < 1 or args.scipy_runs < 1:
        ap.error("--vadsim-runs and --scipy-runs must be >= 1")
    analyse = args.analyse_cycles if args.analyse_cycles is not None else args.cycles / 2

    import scipy
    import vadsim

    params = dict(vadsim.get_preset(args.preset).params)
    print(f"model: {args.preset}, {args.flow:g} gal/min, {args.cycles:g} cycles "
          f"(last {analyse:g} analysed), rtol 1e-6, atol 1e-8 m / 1e-5 m/s")
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}")

    # vadsim: N runs of each kind, median (the first one also warms up the module).
    r, v_med = time_vadsim(args, analyse, "full")
    r_auto, a_med = time_vadsim(args, analyse, "auto")

    # SciPy: M runs, median.
    runs = []
    for i in range(args.scipy_runs):
        print(f"  scipy run {i + 1}/{args.scipy_runs} ...", file=sys.stderr, flush=True)
        runs.append(run_scipy(params, args.flow, args.cycles, analyse))
    s_times = [x["seconds"] for x in runs]
    s_med = statistics.median(s_times)
    s = runs[-1]
    print(f"scipy    ({args.scipy_runs} run{'s' if args.scipy_runs > 1 else ''}): "
          f"median {_fmt_s(s_med)}  [min {_fmt_s(min(s_times))}, max {_fmt_s(max(s_times))}]")
    print(f"  solve_ivp LSODA + 5 events: steps {s['steps']}, rhs evals {s['nfev']}, "
          f"jac evals {s['njev']} (finite differences), last method {s['method_last']}, "
          f"crossings {sum(s['crossings'].values())}")

    ok = check_physics(r, s, args, analyse, "literal")
    ok &= check_physics(r_auto, s, args, analyse, "steady=auto")

    print(f"\ntime per run: vadsim literal {_fmt_s(v_med)}, vadsim steady=auto "
          f"{_fmt_s(a_med)}, scipy {_fmt_s(s_med)}")
    print(f"ratio scipy/vadsim (literal): {s_med / v_med:.0f}x")
    print(f"ratio scipy/vadsim (steady=auto): {s_med / a_med:.0f}x")
    if not ok:
        print("physics check FAILED: the integrations disagree", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
