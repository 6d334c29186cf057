"""One run of the model: the Python entry point to the C++ core.

Why this module exists: the core returns raw arrays; users want a run by preset name and flow
rate, with parameters overridden by name, extra physics by keyword, errors that name the bad
input, and a result whose arrays, event table and steady-window summary are ready to use
(:class:`~vadsim.model.result.SimulationResult`, in :mod:`vadsim.model.result`).
The GIL is released while CVODE integrates, so runs in Python threads execute in parallel.
Ctrl-C stops a run within a few thousand steps, on the main thread or in a pool guarded by
:func:`vadsim.stop_on_interrupt` (see :func:`simulate`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from vadsim import _core
from vadsim._checks import shown
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import OPTIONAL_PARAMS, Preset, get_preset, make_params
from vadsim.model.result import EVENT_KINDS, SURFACES, G, Orbit, SimulationResult, SteadyInfo

__all__ = [
    "STEADY_MODES",
    "SolverError",
    "extra_force",
    "simulate",
]

_METHODS = {"adams": _core.Method.Adams, "bdf": _core.Method.BDF}
_RECORDS = {"none": _core.Record.None_, "window": _core.Record.Window, "all": _core.Record.All}
_STEADY = {"auto": _core.Steady.Auto, "full": _core.Steady.Full}
STEADY_MODES = tuple(_STEADY)
"""The values of ``simulate(steady=...)``: ``"auto"`` stops at a confirmed periodic orbit and
builds the rest of the run from it; ``"full"`` integrates every cycle (the dissertation's
literal run)."""
_BODY = {"bit": 0, "anvil": 1, "housing": 2, "motor": 3, "sub": 4, "lwd": 5, "mwd": 6}

SolverError = _core.SolverError
"""Raised when CVODE fails or a run exhausts its step or event budget; the message names the
SUNDIALS call, the simulated time and the reason."""


def _number(name: str, value: Any, *, integer: bool = False) -> float:
    """``value`` as a float (or int), or a ValueError that names the argument. Booleans are
    not numbers here (``float(True)`` is 1.0, but ``simulate(p, True)`` is a mistake)."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        raise ValueError(f"{name} = {shown(value)} must be a number")
    try:
        out = float(value)
    except OverflowError:
        raise ValueError(f"{name} = {shown(value)} is too large for a double") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {shown(value)} must be a number") from None
    if math.isnan(out):
        raise ValueError(f"{name} = nan must be a number")
    if integer:
        if out != int(out) or abs(out) > 2**62:
            raise ValueError(f"{name} = {value!r} must be an integer below 2**62")
        return int(out)
    return out


def extra_force(kind: str, **kw: Any) -> _core.ExtraForce:
    """Build a core extra force (physics beyond the dissertation's model).

    Parameters
    ----------
    kind
        ``"hydraulic"``: ``c * Q^n`` (N/kg per (gal/min)^n, ``n`` in [0, 4], default 2: a
        turbulent pressure drop) pushing ``acts_on`` ("anvil" or "bit") towards the rock.
        ``"friction"``: Coulomb friction of ``force`` N/kg between ``body`` (default "anvil")
        and ``other`` (default "housing"), regularised over ``v_eps`` m/s; with
        ``static_force`` (N/kg, at least ``force``) a Stribeck peak: the level is ``force +
        (static_force - force) exp(-(v / v_s)^2)`` (``v_s`` m/s, default 0.05). ``"dashpot"``:
        spring ``k`` and dashpot ``c`` from ``body`` to ``other`` (None: the ground), acting
        on displacements from the static state.
    """
    def dof(arg: str, name: Any) -> int:
        if name is None and arg == "other":
            return -1
        if name not in _BODY:
            raise ValueError(f"{kind} {arg} = {name!r}: choose one of {', '.join(_BODY)}")
        return _BODY[name]

    def need(arg: str) -> float:
        if arg not in kw:
            raise ValueError(f"extra force {kind!r} needs the argument {arg!r}")
        return _number(f"{kind} {arg}", kw.pop(arg))

    def opt(arg: str, default: float) -> float:
        return _number(f"{kind} {arg}", kw.pop(arg)) if arg in kw else default

    if kind == "hydraulic":
        acts_on = kw.pop("acts_on", "anvil")
        if acts_on not in ("anvil", "bit"):
            raise ValueError(f"hydraulic acts_on = {acts_on!r} must be 'anvil' or 'bit'")
        out: _core.ExtraForce = _core.HydraulicForce(dof("acts_on", acts_on), need("c"),
                                                     opt("n", 2.0))
    elif kind == "friction":
        body = dof("body", kw.pop("body", "anvil"))
        other = dof("other", kw.pop("other", "housing"))
        out = _core.CoulombFriction(body, other, need("force"), opt("v_eps", 1e-3),
                                    opt("static_force", math.nan), opt("v_s", 0.05))
    elif kind == "dashpot":
        if "body" not in kw:
            raise ValueError("extra force 'dashpot' needs the argument 'body'")
        body = dof("body", kw.pop("body"))
        other = dof("other", kw.pop("other", None))
        out = _core.SpringDashpot(body, other, opt("k", 0.0), opt("c", 0.0))
    else:
        raise ValueError(f"unknown extra force {kind!r}: choose hydraulic, friction or dashpot")
    if kw:
        raise ValueError(f"extra force {kind!r} got unknown arguments {sorted(kw)}")
    return out




def _initial_state(value: Sequence[float] | np.ndarray | SimulationResult | None,
                   name: str = "initial_state"):
    if value is None:
        return None
    if isinstance(value, SimulationResult):
        if name != "initial_state":
            raise ValueError(f"{name} must be 14 numbers (a result's end_displacement)")
        value = value.y_end
    bad = ValueError(f"{name} = {value!r} must be 14 numbers"
                     + (" or a result" if name == "initial_state" else ""))
    if isinstance(value, (str, bytes)):
        raise bad
    try:
        raw = np.asarray(value)
        # Numbers only: not booleans (float(True) is 1.0) nor strings that float() would take.
        if raw.dtype.kind not in "iuf" or any(
                isinstance(v, (bool, np.bool_)) for v in np.asarray(value, dtype=object).flat):
            raise bad
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise bad from None
    if arr.shape != (14,):
        raise ValueError(f"{name} must have 14 entries [x1..x7, v1..v7], got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return arr


def _scale_wob(params: _core.Params, preset: Preset | None, wob_klbf: float) -> None:
    """Set ``params.wob`` for a weight on bit in klbf, scaling the preset's."""
    if preset is None:
        raise ValueError("wob_klbf needs a preset (it scales the preset's wob)")
    wob = _number("wob_klbf", wob_klbf)
    if not (wob >= 0) or not math.isfinite(wob):
        raise ValueError(f"wob_klbf = {wob:g} must be finite and >= 0")
    params.wob = params.wob * wob / preset.wob_klbf
    try:
        params.validate()
    except ValueError as exc:
        raise ValueError(f"wob_klbf = {wob:g} klbf is beyond what the model takes (it sets "
                         f"the parameter wob to {params.wob:.4g} N/kg): {exc}") from None


def _check_choices(*, extras: Sequence[Any], method: Any, record: Any,
                   accelerations_only: Any, steady: Any, orbit_replaces_window: Any) -> None:
    """Refuse a bad choice among :func:`simulate`'s options, naming it."""
    if not isinstance(extras, Sequence) or isinstance(extras, (str, bytes)):
        raise ValueError(f"extras = {shown(extras)} must be a sequence of extra forces "
                         "(vadsim.extra_force(...)), e.g. []")
    for i, e in enumerate(extras):
        if not (isinstance(e, _core.ExtraForce) or callable(getattr(e, "build", None))):
            raise ValueError(f"extras[{i}] = {e!r} must come from vadsim.extra_force(...) "
                             "or be an ExtraSpec")
    if not isinstance(method, str) or method not in _METHODS:
        raise ValueError(f"method = {method!r} must be 'adams' or 'bdf'")
    if not isinstance(record, str) or record not in _RECORDS:
        raise ValueError(f"record = {record!r} must be 'window', 'all' or 'none'")
    if not isinstance(accelerations_only, (bool, np.bool_)):
        raise ValueError(f"accelerations_only = {accelerations_only!r} must be True or False")
    if not isinstance(steady, str) or steady not in _STEADY:
        raise ValueError(f"steady = {steady!r} must be 'auto' or 'full'")
    if not isinstance(orbit_replaces_window, (bool, np.bool_)):
        raise ValueError(f"orbit_replaces_window = {orbit_replaces_window!r} must be True or "
                         "False")


def simulate(
    model: str | Preset | Mapping[str, float] | _core.Params = "7in-cde",
    flow_gpm: float = 200.0,
    *,
    cycles: float = DEFAULTS.cycles,
    analyse_cycles: float = DEFAULTS.analyse_cycles,
    overrides: Mapping[str, float] | None = None,
    wob_klbf: float | None = None,
    law: str | None = None,
    extras: Sequence[_core.ExtraForce] = (),
    method: str = "adams",
    rtol: float = 1e-6,
    atol: float = 1e-8,
    max_step: float = 0.0,
    record: str = "window",
    output_rate_hz: float = 20000.0,
    summary_rate_hz: float = 20000.0,
    initial_state: Sequence[float] | np.ndarray | SimulationResult | None = None,
    initial_displacement: Sequence[float] | np.ndarray | None = None,
    max_steps: int | None = None,
    max_events: int | None = None,
    accelerations_only: bool = False,
    steady: str = "auto",
    orbit_rate_hz: float = 0.0,
    orbit_replaces_window: bool = False,
) -> SimulationResult:
    """Run the model at one flow rate: static on-bottom state, flow on at t = 0.

    Why so many parameters: each is one setting of a single run (the model, the operating point,
    the solver, what is stored, the steady-state engine), all keyword-only with the
    dissertation's defaults; grouping them would hide from the one-call user which one a result
    depends on.

    Parameters
    ----------
    model
        A preset name (``"7in-cde"``, ``"7in-rc"``, ``"9.5in-pdc"``), a :class:`Preset`, a
        mapping of parameters (missing ones from ``7in-cde``) or core ``Params``.
    flow_gpm
        Mud flow (gal/min); the excitation frequency is ``alpha * Q / (2 pi)`` and must lie
        in 0.1 to 2000 Hz (``_core.EXCITATION_HZ_RANGE``): 0.94 to 18756 gal/min for the 7in
        tool (``Params.flow_range_gpm()`` for others).
    cycles, analyse_cycles
        Run length and steady window, in excitation cycles (dissertation: 400 and 200).
    overrides
        Parameters to replace by name, e.g. ``{"kS": 4.7e5}``.
    wob_klbf
        Weight on bit (klbf); scales the preset's ``wob`` by ``wob_klbf / preset.wob_klbf``.
    law
        Contact law of the impact surfaces (see :func:`vadsim.model.presets.make_params`).
    extras
        Extra forces from :func:`extra_force`.
    method, rtol, atol, max_step
        CVODE settings: ``"adams"`` (default) or ``"bdf"``; ``atol`` on displacements (m),
        velocities get ``1000 * atol`` (m/s).
    record, output_rate_hz
        Which span to store as time series: ``"window"`` (default), ``"all"`` or ``"none"``,
        at ``output_rate_hz``.
    summary_rate_hz
        The grid of the steady-window summary (J*, 200 ms peaks); 20 kHz is MODEL.md's "full
        resolution". 0: no summary (J* is NaN, no peak windows), for a run measured from its
        stored series alone; the run itself is the same.
    initial_state
        Absolute ``[x1..x7, v1..v7]`` or a previous result (its final state), instead of the
        static equilibrium: continuation along a flow sweep.
    initial_displacement
        ``[u1..u7, v1..v7]``: displacements from this run's own static state and
        velocities (a result's ``end_displacement``), instead of ``initial_state``: another
        model's steady motion carried over to this one even where a WOB or a length moved
        the static state (an absolute state would then start centimetres off).
    accelerations_only
        Store only ``t`` and ``a`` (``x``, ``v`` and the forces are empty, 0 rows): what a
        sensor measures. A third of the memory at the same run; a fresh process storing a
        20 kHz window took 0.89x as long (fewer page faults), a long diagnosis about 1 % less.
    steady
        ``"auto"`` (default): once the state on the once-per-cycle Poincare section repeats
        after n = 1..8 cycles (within 1000 x ``rtol`` of each state component's amplitude, over
        at least max(2n, 6) consecutive cycles and again over one more recorded orbit whose
        contact events repeat those of the orbit before), stop integrating and build the rest
        of the run from that orbit: events shifted by whole orbits, Z*, J*, the 200 ms peaks,
        the stored series and the Poincare section, with the same shapes as a full run.
        Where no orbit is confirmed, every cycle is integrated, exactly as ``"full"``.
        ``"full"``: the dissertation's literal run, every cycle integrated. ``steady_info``
        says which happened.
    orbit_rate_hz, orbit_replaces_window
        With ``steady="auto"`` and an orbit: return one period of it on a uniform grid of
        about ``orbit_rate_hz`` (``result.orbit``; 0: none); with ``orbit_replaces_window``
        and the whole analysed window on the orbit, leave the stored series empty (a
        measurement reads the orbit instead of its 200 copies).
    max_steps, max_events
        Budgets that turn a pathological input into a :class:`SolverError` instead of a hang.
        ``None`` (default): budgets that grow with the run, 20000 steps per cycle (at least
        20 million) and 200 contact events per cycle (plus 1000); a valid run takes 20 to
        4000 steps and at most ~15 events per cycle. An explicit positive integer is used
        as given.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ValueError
        Naming a bad parameter or option.
    SolverError
        When the integration fails (the message says the time and why).
    KeyboardInterrupt
        On Ctrl-C during a run on the main thread: every 2000 steps the run lets Python run
        its signal handlers, and stops if one raises (the exception gets a note saying at
        which time and step the run stopped). Python runs signal handlers on the main thread
        only; a run in a worker thread polls the core's process-wide stop request instead
        (``vadsim._core.request_interrupt()``), which :func:`vadsim.stop_on_interrupt` sets
        when Ctrl-C reaches the main thread: ``with ThreadPoolExecutor() as pool,
        vadsim.stop_on_interrupt(pool): ...`` stops every run of the pool within 2000 steps.
        vadsim's own pools (the CLI, validate, the comparison engine, maps, a diagnosis'
        processes) do so.

    Examples
    --------
    >>> import vadsim
    >>> r = vadsim.simulate("7in-cde", 200, cycles=40, analyse_cycles=20)
    >>> round(r.z["impact"], 2), r.scenario
    (1.0, 1)
    """
    if not isinstance(model, (str, Preset, Mapping, _core.Params)):
        raise ValueError(
            f"model = {model!r} must be a preset name, a Preset, a mapping of parameters "
            "or core Params"
        )
    preset = get_preset(model) if isinstance(model, (str, Preset)) else None
    params = make_params(model, overrides, law)
    if wob_klbf is not None:
        _scale_wob(params, preset, wob_klbf)
    flow = _flow(params, flow_gpm)
    _check_choices(extras=extras, method=method, record=record,
                   accelerations_only=accelerations_only, steady=steady,
                   orbit_replaces_window=orbit_replaces_window)
    budgets = {}
    for name, value in (("max_steps", max_steps), ("max_events", max_events)):
        budgets[name] = _budget(name, value)
    core_model = _core.Model(params, [_core_extra(e) for e in extras])
    opts = _run_options(flow, cycles=cycles, analyse_cycles=analyse_cycles, method=method,
                        rtol=rtol, atol=atol, max_step=max_step, record=record,
                        output_rate_hz=output_rate_hz, summary_rate_hz=summary_rate_hz,
                        max_steps=budgets["max_steps"], max_events=budgets["max_events"],
                        initial_state=initial_state)
    if initial_displacement is not None:
        if initial_state is not None:
            raise ValueError("initial_state and initial_displacement: give one, not both")
        start = _initial_state(initial_displacement, "initial_displacement")
        opts.initial_displacement = start
    opts.accelerations_only = bool(accelerations_only)
    opts.steady = _STEADY[steady]
    opts.orbit_rate_hz = _number("option orbit_rate_hz", orbit_rate_hz)
    opts.orbit_replaces_window = bool(orbit_replaces_window)
    opts.validate(params)  # what depends on the model (the flow range, checked above)
    r = _core.simulate(core_model, opts)
    return _result(r, params, preset, flow, cycles, analyse_cycles, steady)


def _flow(params: _core.Params, flow_gpm: Any) -> float:
    """The flow rate, within the range whose excitation a run can resolve (from alpha)."""
    flow = _number("flow_gpm", flow_gpm)
    lo, hi = params.flow_range_gpm()
    if not lo <= flow <= hi:
        f_lo, f_hi = _core.EXCITATION_HZ_RANGE
        got = f", not {params.excitation_hz(flow):.3g} Hz" if math.isfinite(flow) else ""
        raise ValueError(
            f"flow_gpm = {flow_gpm!r} must be in [{lo:.4g}, {hi:.4g}] gal/min: with alpha = "
            f"{params.alpha:.4g} (rad/s)/(gal/min) the excitation must be in [{f_lo:g}, "
            f"{f_hi:g}] Hz{got}")
    return flow


def _budget(name: str, value: Any) -> int:
    """A step or event budget for the core: None -> 0 (the core's default, growing with the
    run), else a positive integer (``max_events = 0`` still means the default)."""
    if value is None:
        return 0
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} = {value!r} must be an integer or None")
    out = int(_number(name, value, integer=True))
    low = 1 if name == "max_steps" else 0
    if out < low:
        raise ValueError(f"{name} = {value!r} must be >= {low} (or None: grows with the run)")
    return out


def _core_extra(e: Any) -> _core.ExtraForce:
    """A core extra force from a core object or anything with ``build()`` (an ExtraSpec)."""
    return e if isinstance(e, _core.ExtraForce) else e.build()


def _run_options(flow: float, *, cycles: float, analyse_cycles: float, method: str,
                 rtol: float, atol: float, max_step: float, record: str, output_rate_hz: float,
                 summary_rate_hz: float, max_steps: int, max_events: int,
                 initial_state: Any) -> _core.RunOptions:
    """The core's run options, every value checked and named."""
    opts = _core.RunOptions()
    opts.flow_gpm = flow
    opts.cycles = _number("option cycles", cycles)
    opts.analyse_cycles = _number("option analyse_cycles", analyse_cycles)
    opts.method = _METHODS[method]
    opts.rtol = _number("option rtol", rtol)
    opts.atol = _number("option atol", atol)
    opts.max_step = _number("option max_step", max_step)
    opts.record = _RECORDS[record]
    opts.output_rate_hz = _number("option output_rate_hz", output_rate_hz)
    opts.summary_rate_hz = _number("option summary_rate_hz", summary_rate_hz)
    opts.max_steps = int(max_steps)
    opts.max_events = int(max_events)
    opts.initial_state = _initial_state(initial_state)
    opts.validate()
    return opts


def _steady_parts(r: Any, mode: str) -> tuple[SteadyInfo, Orbit | None]:
    st = r.steady
    info = SteadyInfo(mode=mode, period=int(st.period), detected_cycle=float(st.detected_cycle),
                      stopped_cycle=float(st.stopped_cycle), residual=float(st.residual),
                      tolerance=float(st.tolerance), window_on_orbit=bool(st.window_on_orbit))
    t = np.asarray(r.orbit_t)
    orbit = (Orbit(t=t, a=np.asarray(r.orbit_a), period_s=float(r.orbit_period_s),
                   cycles=info.period, corner_t=np.asarray(r.orbit_corner_t),
                   corner_before=np.asarray(r.orbit_corner_before),
                   corner_after=np.asarray(r.orbit_corner_after)) if t.size else None)
    return info, orbit


# Built once: a categorical built from its categories each run was most of the event
# table's cost (0.56 -> 0.21 ms a run for 800 events; a map makes one a run).
_SURFACE_DTYPE = pd.CategoricalDtype(SURFACES)
_KIND_DTYPE = pd.CategoricalDtype(EVENT_KINDS)


def _result(r: Any, params: _core.Params, preset: Preset | None, flow: float, cycles: float,
            analyse_cycles: float, steady: str = "auto") -> SimulationResult:
    """The core's raw result as a :class:`SimulationResult`."""
    kinds = np.asarray(r.event_kind)
    surf = np.asarray(r.event_surface)
    events = pd.DataFrame(
        {
            "time_s": np.asarray(r.event_t),
            "surface": pd.Categorical.from_codes(surf, dtype=_SURFACE_DTYPE),
            "kind": pd.Categorical.from_codes(kinds, dtype=_KIND_DTYPE),
            "rel_velocity_mps": np.asarray(r.event_rel_velocity),
        }
    )
    s = r.summary
    stats = {k: getattr(r.stats, k) for k in (
        "steps", "rhs_evals", "jac_evals", "lin_setups", "err_test_fails", "nonlin_iters",
        "nonlin_conv_fails", "root_evals", "reinits")}
    values = params.__getstate__()
    info, orbit = _steady_parts(r, steady)
    return SimulationResult(
        preset=preset.name if preset else None,
        # an unset optional parameter (nan) is left out: it has no value, and nan != nan
        params={k: v for k, v in values.items() if k != "law" and not (
            k in OPTIONAL_PARAMS and math.isnan(v))},
        flow_gpm=flow,
        f_exc_hz=r.f_exc_hz,
        cycles=float(cycles),
        analyse_cycles=float(analyse_cycles),
        window=(s.t0, s.t1),
        t=r.t,
        x=r.x,
        v=r.v,
        a=r.a,
        contact_forces=r.fc,
        excitation_force=r.fh,
        poincare_t=r.poincare_t,
        poincare=r.poincare,
        events=events,
        impacts=dict(zip(SURFACES, (int(n) for n in s.onsets), strict=True)),
        impulse_mean=s.impulse_mean,
        impulse_pos=s.impulse_pos,
        window_peaks_g=np.asarray(s.window_peaks) / G,
        stats=stats,
        y_end=np.asarray(r.y_end),
        m_ref_kg=preset.m_ref_kg if preset else None,
        x_static=np.asarray(r.x_static),
        steady_info=info,
        orbit=orbit,
        _core_result=r,
    )
