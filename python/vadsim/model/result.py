"""What one run returns: :class:`SimulationResult`, its steady-state account
(:class:`SteadyInfo`) and the periodic orbit (:class:`Orbit`).

Why this module exists: every layer above the model reads results (labels, features, the
comparison engine, plots), while only :func:`vadsim.model.simulation.simulate` makes them. The
result's arrays, event table and steady-window summary, and the constants that label them
(gravity ``G``, the contact ``SURFACES``, ``EVENT_KINDS``, ``DOF_NAMES``), live here, apart
from the checks and the call into the C++ core.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from vadsim._html import key_value_table
from vadsim.model.regimes import regime_name, scenario

__all__ = [
    "G",
    "SURFACES",
    "Orbit",
    "SimulationResult",
    "SteadyInfo",
]

G = 9.80665
"""Standard gravity (m/s^2): accelerations are reported in g."""

SURFACES = ("spring", "impact", "off_bottom", "on_bottom", "rock")
"""Contact surfaces in the core's order: #1 recoil spring, #2 impact face, #3 off-bottom
shoulder, #4 on-bottom shoulder, then the rock."""

EVENT_KINDS = ("onset", "release", "lift", "relatch")
DOF_NAMES = ("bit", "anvil", "housing", "motor", "sub", "lwd", "mwd")


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
    """One period of a periodic run's steady orbit: a uniform grid and the orbit's corners.

    ``a[j]`` is the acceleration (m/s^2, 7 bodies) at ``t[j] = start + j * period_s / len(t)``;
    the run repeats it: the acceleration at any later time ``t`` is the orbit's at
    ``start + (t - start) mod period_s`` (:meth:`at`). ``corner_t`` are the times inside the
    period where a contact closes or opens, ``corner_before`` and ``corner_after`` the
    accelerations just before and just after: a contact force jumps or kinks there, and a
    uniform grid alone would smear that corner over a spacing.
    """

    t: np.ndarray
    a: np.ndarray
    period_s: float
    cycles: int
    corner_t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    corner_before: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    corner_after: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))

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
        by linear interpolation between the grid's points and the corners (a time exactly at
        a corner takes the value just after it)."""
        return self.at_bodies(times, (dof,))[dof]

    def at_bodies(self, times: np.ndarray, dofs: Iterable[int]) -> dict[int, np.ndarray]:
        """:meth:`at` for each body of ``dofs`` (1..7), with the times' places in the orbit
        worked out once: a measurement reads two or three bodies at every fine-grid time of
        a 200-cycle window, and the places were half of that work."""
        dofs = list(dofs)
        for dof in dofs:
            if not 1 <= dof <= 7:
                raise ValueError(f"dof = {dof} must be in 1..7")
        m = self.t.size
        # The grid is uniform over one period: the interval of each time is arithmetic.
        pos = np.asarray(times, dtype=float) - self.start
        pos = np.mod(pos, self.period_s) * (m / self.period_s)
        i0 = np.minimum(np.floor(pos), m - 1)
        frac = pos - i0
        i = i0.astype(np.int64)
        sel = np.zeros(0, dtype=np.int64)
        if self.corner_t.size:
            # Only the few intervals that hold a corner interpolate on the merged table.
            has_corner, grid, order, table_t = self._corner_table
            sel = np.flatnonzero(has_corner[i])
            if sel.size:
                tau = pos[sel] * (self.period_s / m)
                k = np.minimum(np.searchsorted(table_t, tau, side="right") - 1,
                               table_t.size - 2)
                w = (tau - table_t[k]) / (table_t[k + 1] - table_t[k])
        out: dict[int, np.ndarray] = {}
        for dof in dofs:
            col = self.a[:, dof - 1] / G
            nxt = np.append(col[1:], col[0])
            left = col[i]
            values_at = left + frac * (nxt[i] - left)
            if sel.size:
                values = np.concatenate([col[grid % m], self.corner_before[:, dof - 1] / G,
                                         self.corner_after[:, dof - 1] / G])[order]
                values_at[sel] = values[k] + w * (values[k + 1] - values[k])
            out[dof] = values_at
        return out

    @functools.cached_property
    def _corner_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What :meth:`at` needs near the corners: which grid intervals hold one (a mask); the
        grid indices of those intervals' ends (m: the next period's first point); the time
        order of the merged table (those ends, each corner before, each corner after; ties in
        that order) and its times (s after the start)."""
        m = self.t.size
        offset = self.corner_t - self.start
        cells = np.clip(np.floor(offset * (m / self.period_s)), 0, m - 1).astype(np.int64)
        has_corner = np.zeros(m, dtype=bool)
        has_corner[cells] = True
        grid = np.unique(np.concatenate([cells, cells + 1]))
        times = np.concatenate([grid * (self.period_s / m), offset, offset])
        rank = np.concatenate([np.zeros(grid.size), np.ones(offset.size),
                               np.full(offset.size, 2.0)])
        order = np.lexsort((rank, times))
        return has_corner, grid, order, times[order]


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
