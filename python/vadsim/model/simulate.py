"""One run of the model: the Python entry point to the C++ core.

Why this module exists: the core returns raw arrays; users want a run by preset name and flow
rate, with parameters overridden by name, extra physics by keyword, errors that name the bad
input, and a result whose arrays, event table and steady-window summary are ready to use.
The GIL is released while CVODE integrates, so runs in Python threads execute in parallel.
Ctrl-C stops a run within a few thousand steps, on the main thread or in a pool guarded by
:func:`vadsim.stop_on_interrupt` (see :func:`simulate`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vadsim import _core
from vadsim._checks import shown
from vadsim._html import key_value_table
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import OPTIONAL_PARAMS, Preset, get_preset, make_params
from vadsim.model.regimes import regime_name, scenario

__all__ = [
    "G",
    "STEADY_MODES",
    "SURFACES",
    "Orbit",
    "SimulationResult",
    "SolverError",
    "SteadyInfo",
    "extra_force",
    "simulate",
]

G = 9.80665
"""Standard gravity (m/s^2): accelerations are reported in g."""

SURFACES = ("spring", "impact", "off_bottom", "on_bottom", "rock")
"""Contact surfaces in the core's order: #1 recoil spring, #2 impact face, #3 off-bottom
shoulder, #4 on-bottom shoulder, then the rock."""

EVENT_KINDS = ("onset", "release", "lift", "relatch")
DOF_NAMES = ("bit", "anvil", "housing", "motor", "sub", "lwd", "mwd")
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
        and ``other`` (default "housing"), regularised over ``v_eps`` m/s. ``"dashpot"``:
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
        out = _core.CoulombFriction(body, other, need("force"), opt("v_eps", 1e-3))
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


@dataclass(frozen=True)
class SteadyInfo:
    """What the steady-state engine did in one run (``simulate(steady=...)``).

    Attributes
    ----------
    mode
        ``"auto"`` or ``"full"``.
    period
        Excitation cycles of the detected periodic orbit; 0 when none was confirmed (the run
        then integrated every cycle, exactly as ``"full"``).
    detected_cycle
        The cycle at which the recorded orbit starts (its state there repeated, within the
        tolerance, over the confirming cycles before it).
    stopped_cycle
        The cycle at which integration stopped (``cycles`` when it did not).
    residual
        The largest difference between a section and the one ``period`` cycles before, over
        the confirming cycles and the recorded orbit, relative to each state component's
        amplitude (NaN without an orbit).
    tolerance
        The relative tolerance ``residual`` was held to (1000 x rtol by default).
    window_on_orbit
        The whole analysed window was built from the orbit.
    """

    mode: str
    period: int
    detected_cycle: float
    stopped_cycle: float
    residual: float
    tolerance: float
    window_on_orbit: bool

    @property
    def periodic(self) -> bool:
        """A periodic orbit was confirmed and the run built from it."""
        return self.period > 0

    def __str__(self) -> str:
        if not self.periodic:
            return f"steady={self.mode}: no periodic orbit confirmed, every cycle integrated"
        return (f"steady={self.mode}: period-{self.period} orbit from cycle "
                f"{self.detected_cycle:g}, integration stopped at cycle "
                f"{self.stopped_cycle:.4g} (residual {self.residual:.2g} <= "
                f"{self.tolerance:.2g})")


@dataclass(frozen=True)
class Orbit:
    """One period of a periodic run's steady orbit on a uniform grid.

    ``a[j]`` is the acceleration (m/s^2, 7 bodies) at ``t[j] = start + j * period_s / len(t)``;
    the run repeats it: the acceleration at any later time ``t`` is the orbit's at
    ``start + (t - start) mod period_s`` (:meth:`at`).
    """

    t: np.ndarray
    a: np.ndarray
    period_s: float
    cycles: int

    @property
    def start(self) -> float:
        """Time (s) at which the orbit starts."""
        return float(self.t[0])

    @property
    def accel_g(self) -> np.ndarray:
        """Accelerations in g, shape (M, 7)."""
        return self.a / G

    def at(self, times: np.ndarray, dof: int) -> np.ndarray:
        """Acceleration (g) of body ``dof`` (1..7) at ``times`` (s, at or after the start),
        by linear interpolation on the periodic grid."""
        if not 1 <= dof <= 7:
            raise ValueError(f"dof = {dof} must be in 1..7")
        m = self.t.size
        # The grid is uniform over one period: the interval of each time is arithmetic.
        pos = np.asarray(times, dtype=float) - self.start
        pos *= m / self.period_s
        i0 = np.floor(pos)
        frac = pos - i0
        i = np.mod(i0.astype(np.int64), m)
        col = self.a[:, dof - 1] / G
        nxt = np.append(col[1:], col[0])
        return col[i] + frac * (nxt[i] - col[i])


@dataclass
class SimulationResult:
    """One run: time series of the recorded span, events, steady-window summary, statistics.

    Positions are absolute in metres (MODEL.md frame), velocities in m/s, accelerations in
    m/s^2 (``accel_g`` in g), forces per unit reference mass in N/kg. The steady window is the
    last ``analyse_cycles`` cycles, ``window = (t0, t1)``.
    """

    preset: str | None
    params: dict[str, float]
    flow_gpm: float
    f_exc_hz: float
    cycles: float
    analyse_cycles: float
    window: tuple[float, float]
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    contact_forces: np.ndarray
    excitation_force: np.ndarray
    poincare_t: np.ndarray
    poincare: np.ndarray
    events: pd.DataFrame
    impacts: dict[str, int]
    impulse_mean: float
    impulse_pos: float
    window_peaks_g: np.ndarray
    stats: dict[str, int]
    y_end: np.ndarray
    m_ref_kg: float | None = None
    x_static: np.ndarray | None = None
    steady_info: SteadyInfo | None = None
    orbit: Orbit | None = None
    _core_result: Any = field(default=None, repr=False)

    @property
    def accelerations_only(self) -> bool:
        """Whether the run stored only ``t`` and ``a`` (``x``, ``v`` and the forces empty)."""
        return self.t.size > 0 and self.x.shape[0] == 0

    @property
    def period_s(self) -> float:
        """Excitation period (s)."""
        return 1.0 / self.f_exc_hz

    @property
    def end_displacement(self) -> np.ndarray:
        """The final state as displacements from the run's static state and velocities,
        ``[u1..u7, v1..v7]``: what ``simulate(initial_displacement=...)`` takes to start
        another model (whose static state may differ) in the same motion."""
        if self.x_static is None:
            raise ValueError("this result does not record its static state")
        out = np.array(self.y_end, dtype=float)
        out[:7] -= self.x_static
        return out

    @property
    def accel_g(self) -> np.ndarray:
        """Accelerations in g, shape (n, 7)."""
        return self.a / G

    @property
    def z(self) -> dict[str, float]:
        """Impacts per cycle Z over the steady window, per surface (dissertation Eq. 4.1)."""
        return {s: n / self.analyse_cycles for s, n in self.impacts.items()}

    @property
    def scenario(self) -> int:
        """Impact scenario of dissertation Table 4.2 (see
        :func:`vadsim.signals.labels.scenario`)."""
        z = self.z
        return scenario(z["spring"], z["impact"])

    def peak_stats(self, dof: int = 1) -> tuple[float, float]:
        """Mean and standard deviation (g) of the 200 ms window peaks of ``|a|`` at ``dof`` (1..7),
        at the summary grid's full resolution."""
        if not 1 <= dof <= 7:
            raise ValueError(f"dof = {dof} must be in 1..7")
        peaks = self.window_peaks_g[:, dof - 1]
        if peaks.size == 0:
            return math.nan, math.nan
        return float(peaks.mean()), float(peaks.std())

    def window_slice(self) -> slice:
        """Index range of the recorded samples that lie in the steady window."""
        i0 = int(np.searchsorted(self.t, self.window[0] - 1e-12))
        return slice(i0, len(self.t))

    @property
    def success(self) -> bool:
        """Always True: a run that fails raises :class:`SolverError` instead (the attribute is
        here where ``scipy.integrate.solve_ivp`` users look for it)."""
        return True

    @property
    def message(self) -> str:
        """What the solver did, in the words a ``solve_ivp`` user expects."""
        return (f"reached t = {self.window[1]:.6g} s ({self.cycles:g} cycles) in "
                f"{self.stats['steps']} steps and {self.stats['reinits']} contact events")

    @property
    def impulse_pos_kn(self) -> float:
        """J* (mean of max(F_I, 0)) in kN, with the preset's reference mass m*; NaN where the
        run has no m* (J* is per unit m*, N/kg)."""
        return self.impulse_pos * self.m_ref_kg / 1000.0 if self.m_ref_kg else math.nan

    def __repr__(self) -> str:
        # The dataclass repr printed every array (249 lines in a plain REPL); a notebook
        # shows _repr_html_'s table, a terminal the same rows as text.
        rows = self._summary_rows()
        width = max(len(k) for k, _ in rows)
        stored = "a only" if self.accelerations_only else "x, v, a and forces"
        series = (f"time series: {self.t.size} samples of {stored} (r.t, r.a, r.accel_g); "
                  f"{len(self.events)} contact events (r.events)")
        return "\n".join([f"<SimulationResult: {self.preset or 'custom parameters'}>",
                          *(f"  {k:<{width}}  {v}" for k, v in rows), f"  {series}"])

    def _summary_rows(self) -> list[tuple[str, str]]:
        mean, std = self.peak_stats(1)
        j = f"{self.impulse_pos:.4g} N/kg"
        if self.m_ref_kg:
            j += f" ({self.impulse_pos_kn:.3g} kN with m* = {self.m_ref_kg:.3g} kg)"
        rows = [
            ("operating point", f"{self.flow_gpm:g} gal/min, excitation {self.f_exc_hz:.3g} Hz"),
            ("run", f"{self.cycles:g} cycles, last {self.analyse_cycles:g} analysed"),
            ("impacts per cycle", ", ".join(f"{s} {v:.3g}" for s, v in self.z.items())),
            ("scenario", f"{self.scenario}: {regime_name(self.scenario)}"),
            ("200 ms peaks at x1", f"{mean:.3g} +- {std:.2g} g (full resolution)"),
            ("J* (mean of max(F_I, 0))", j),
            ("solver", f"{self.stats['steps']} steps, {self.stats['reinits']} contact events"),
        ]
        if self.steady_info is not None:
            rows.append(("steady state", str(self.steady_info)))
        return rows

    def _repr_html_(self) -> str:
        return key_value_table(f"SimulationResult: {self.preset or 'custom parameters'}",
                               self._summary_rows())

    def to_xarray(self) -> Any:
        """The recorded time series as an :class:`xarray.Dataset` with CF ``units`` and
        ``long_name`` attributes: dimensions ``time`` and ``dof`` (bit ... mwd) and
        ``surface`` for the contact forces; the labels of the run as attributes. A run
        that stored accelerations only (``accelerations_only``) gives ``a`` and ``accel_g``."""
        import xarray as xr

        dims = ("time", "dof")
        variables = {
            "x": (dims, self.x, {"units": "m", "long_name": "absolute position"}),
            "v": (dims, self.v, {"units": "m/s", "long_name": "velocity"}),
            "a": (dims, self.a, {"units": "m/s^2", "long_name": "acceleration"}),
            "accel_g": (dims, self.accel_g, {"units": "g", "long_name": "acceleration"}),
            "contact_force": (("time", "surface"), self.contact_forces,
                              {"units": "N/kg", "long_name": "contact force per unit "
                               "reference mass"}),
            "excitation_force": ("time", self.excitation_force,
                                 {"units": "N/kg", "long_name": "flow-driven excitation "
                                  "force per unit reference mass"}),
        }
        coords = {
            "time": ("time", self.t, {"units": "s", "long_name": "time"}),
            "dof": ("dof", list(DOF_NAMES), {"units": "", "long_name": "lumped mass"}),
            "surface": ("surface", list(SURFACES[:self.contact_forces.shape[1]]),
                        {"units": "", "long_name": "contact surface"}),
        }
        if self.accelerations_only:
            variables = {k: variables[k] for k in ("a", "accel_g")}
            del coords["surface"]
        ds = xr.Dataset(variables, coords=coords)
        ds.attrs.update(
            preset=self.preset or "", flow_gpm=self.flow_gpm, f_exc_hz=self.f_exc_hz,
            cycles=self.cycles, analyse_cycles=self.analyse_cycles, scenario=self.scenario,
            j_pos=self.impulse_pos, j_mean=self.impulse_mean,
            **{f"z_{s}": v for s, v in self.z.items()},
        )
        return ds


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
                   cycles=info.period) if t.size else None)
    return info, orbit


def _result(r: Any, params: _core.Params, preset: Preset | None, flow: float, cycles: float,
            analyse_cycles: float, steady: str = "auto") -> SimulationResult:
    """The core's raw result as a :class:`SimulationResult`."""
    kinds = np.asarray(r.event_kind)
    surf = np.asarray(r.event_surface)
    events = pd.DataFrame(
        {
            "time_s": np.asarray(r.event_t),
            "surface": pd.Categorical.from_codes(surf, SURFACES),
            "kind": pd.Categorical.from_codes(kinds, EVENT_KINDS),
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
