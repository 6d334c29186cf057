"""MODEL.md's 7-DOF vibro-impact model, written again with NumPy and SciPy only.

Why this module exists: a benchmark whose campaigns are all written by the simulator the
diagnosis fits cannot see a diagnosis that only works on its own generator. This is a second
simulator of the same equations, written from MODEL.md and Table 2.1 alone: its own state
(displacements from the static on-bottom state, so tolerances mean metres), its own contact
bookkeeping (every Kelvin-Voigt contact switched from the current state, no modes) and its
own integrator (ODEPACK's LSODA through :func:`scipy.integrate.odeint`, which steps in
Fortran and calls back only for the right-hand side). Only the numbers come from the package:
Table 2.1 as data (:func:`vadsim.data.table_2_1`).

The right-hand side takes effects: functions of (time, positions, velocities, flow) that
return a force per body (N/kg, positive downward) added to the equations of motion
(:mod:`vadsim.blind.independent.effects`). The forces are written so that the same code
evaluates one state (floats, inside the integrator) or a whole output grid (arrays, for the
accelerations the sensors record).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.integrate import odeint

from vadsim.data import table_2_1

__all__ = ["G", "PRESETS", "SETTLE_BLOCK", "Effect", "IndependentModel", "ToolPreset",
           "preset_params", "rest_phase", "run_summary", "settle"]

G = 9.80665
"""Standard gravity (m/s^2): accelerations are recorded in g."""

Effect = Callable[[Any, Sequence[Any], Sequence[Any], float], Sequence[Any]]
"""An effect: ``f(t, x, v, flow_gpm) -> forces`` with ``x`` the absolute positions (m) and
``v`` the velocities (m/s) of the seven bodies (floats or arrays of equal shape), returning
seven forces per unit reference mass (N/kg, positive downward; 0.0 where none)."""


@dataclass(frozen=True)
class ToolPreset:
    """The constants MODEL.md says a preset must add to Table 2.1.

    Attributes
    ----------
    tool, bit
        The campaign's ``tool`` and ``bit`` (RECORDINGS.md).
    l0, wob, wob_klbf
        Standard length (m), weight on bit per unit reference mass (N/kg) and the WOB it
        stands for (klbf): MODEL.md's 7in values.
    """

    tool: str
    bit: str
    l0: float = 0.7
    wob: float = 1000.0
    wob_klbf: float = 4.0


PRESETS: dict[str, ToolPreset] = {
    "7in-cde": ToolPreset("7in", "CDE"),
    "7in-rc": ToolPreset("7in", "RC"),
}
"""The tools this generator writes: the 7in tool with its two bits (MODEL.md)."""


def preset_params(name: str) -> dict[str, float]:
    """Table 2.1 of the preset's tool with ``l0`` and ``wob`` (the RC bit's ``m1``)."""
    if name not in PRESETS:
        raise ValueError(f"independent generator: unknown preset {name!r}; it knows "
                         f"{', '.join(PRESETS)}")
    pr = PRESETS[name]
    table = dict(table_2_1()[pr.tool])
    if pr.bit == "RC":
        table["m1"] = table["m1_RC"]
    table.pop("m1_RC", None)
    return {**table, "l0": pr.l0, "wob": pr.wob}


def rest_phase(name: str, wob_scale: float = 1.0) -> float:
    """The excitation phase at rest ``beta (x2 - x3) + psi`` (rad) this generator runs the
    preset with at ``wob_scale`` times its WOB (MODEL.md's rest state).

    Why: the phase follows the static state, which the WOB compresses; vadsim's presets hold
    their phase at rest whatever the WOB. A concealed WOB off by 10 % moves it by 0.007 rad,
    and the true model in vadsim's terms carries that phase (the regret's truth point)."""
    m = IndependentModel(preset_params(name), 300.0, wob_scale=wob_scale)
    return float(m.p["beta"] * (m.x_static[1] - m.x_static[2]) + m.p["psi"])


def _kv(d: Any, rate: Any, k: float, c: float) -> Any:
    """Kelvin-Voigt contact ``H(d) (k d + c d')``, tension kept (MODEL.md's law)."""
    if isinstance(d, np.ndarray):
        return np.where(d > 0.0, k * d + c * rate, 0.0)
    return k * d + c * rate if d > 0.0 else 0.0


class IndependentModel:
    """The model at one flow: static state, right-hand side, accelerations.

    Parameters
    ----------
    params
        Table 2.1 with ``l0`` and ``wob`` (:func:`preset_params`).
    flow_gpm
        Flow rate (gal/min): the excitation frequency ``alpha Q``.
    effects
        Forces added to the right-hand side (:data:`Effect`).
    wob_scale
        The true WOB over the stated one (a campaign whose WOB reading is off).

    Attributes
    ----------
    x_static
        Absolute static positions (m) under the true WOB (MODEL.md, "The run", step 1).
    f_exc_hz
        Excitation frequency (Hz).
    """

    def __init__(self, params: Mapping[str, float], flow_gpm: float,
                 effects: Sequence[Effect] = (), wob_scale: float = 1.0) -> None:
        p = {k: float(v) for k, v in params.items()}
        self.p = p
        self.flow_gpm = float(flow_gpm)
        self.effects = tuple(effects)
        l0, wob = p["l0"], p["wob"] * float(wob_scale)
        self.len = {k: p[k] * l0 for k in ("L1", "L2", "L3", "LS", "LI", "LOn", "LR")}
        L = self.len
        x1 = L["LR"] - L["L1"] + wob / p["kR"]
        x3 = x1 + L["LI"] + L["LOn"] - L["L3"] + wob / p["kOn"]
        xs = [x1, x1, x3]
        for k in ("k3", "k4", "k5", "k6"):
            xs.append(xs[-1] + wob / p[k])
        self.x_static = np.array(xs)
        self.x_top = xs[-1] + wob / p["k7"]
        self.omega = p["alpha"] * self.flow_gpm
        self.f_exc_hz = self.omega / (2.0 * math.pi)
        self.mass = np.array([p[f"m{i}"] for i in range(1, 8)])
        self._lengths = tuple(self.len[k] for k in ("LS", "L2", "LI", "L3", "LOn", "L1", "LR"))
        self._contact = tuple(p[k] for k in ("kS", "cS", "kI", "cI", "kOff", "cOff", "kOn",
                                             "cOn", "kR", "cR"))
        self._string = tuple(p[f"{kc}{i}"] for i in range(3, 8) for kc in ("k", "c"))
        self._excitation = (p["Fo"], p["phi"], p["beta"], p["psi"], p["cD"])
        self._inv_mass = (1.0 / self.mass).tolist()
        self._x_static = self.x_static.tolist()

    # ------------------------------------------------------------------------- the physics

    def indentations(self, x: Sequence[Any]) -> tuple[Any, Any, Any, Any, Any]:
        """MODEL.md's five indentations (m) at absolute positions ``x``: spring, impact face,
        off-bottom, on-bottom, rock."""
        LS, L2, LI, L3, LOn, L1, LR = self._lengths
        x1, x2, x3 = x[0], x[1], x[2]
        return ((x3 + LS) - (x2 - L2), x2 - x1, (x1 + LI) - (x3 + L3), (x3 + L3) - (x1 + LI + LOn),
                (x1 + L1) - LR)

    def impact_force(self, x: Sequence[Any], v: Sequence[Any]) -> Any:
        """F_I (N/kg), the Kelvin-Voigt impact-face force of the nominal model."""
        return _kv(x[1] - x[0], v[1] - v[0], self.p["kI"], self.p["cI"])

    def forces(self, t: Any, x: Sequence[Any], v: Sequence[Any]) -> list[Any]:
        """The net force on each body (N/kg), effects included: MODEL.md's equations of
        motion times the masses. Floats (inside the integrator: math's trigonometry, the
        fast path) or arrays (an output grid: numpy's)."""
        kS, cS, kI, cI, kOff, cOff, kOn, cOn, kR, cR = self._contact
        k3, c3, k4, c4, k5, c5, k6, c6, k7, c7 = self._string
        Fo, phi, beta, psi, cD = self._excitation
        x1, x2, x3, x4, x5, x6, x7 = x
        v1, v2, v3, v4, v5, v6, v7 = v
        dS, dI, dOff, dOn, dR = self.indentations(x)
        FS = _kv(dS, v3 - v2, kS, cS)
        FI = _kv(dI, v2 - v1, kI, cI)
        FOff = _kv(dOff, v1 - v3, kOff, cOff)
        FOn = _kv(dOn, v3 - v1, kOn, cOn)
        FR = _kv(dR, v1, kR, cR)
        # tension of the string's spring-dashpot pairs, each body above the next one
        f3 = k3 * (x3 - x4) + c3 * (v3 - v4)
        f4 = k4 * (x4 - x5) + c4 * (v4 - v5)
        f5 = k5 * (x5 - x6) + c5 * (v5 - v6)
        f6 = k6 * (x6 - x7) + c6 * (v6 - v7)
        f7 = k7 * (x7 - self.x_top) + c7 * v7
        cos, sin = (np.cos, np.sin) if isinstance(x1, np.ndarray) else (math.cos, math.sin)
        FH = Fo * cos(self.omega * t + phi) * sin(beta * (x2 - x3) + psi)
        FD = cD * v2 * abs(v2)
        f = [-FR + FOn - FOff + FI, -FI + FS + FH - FD, -f3 - FS - FOn + FOff, f3 - f4,
             f4 - f5, f5 - f6, f6 - f7]
        for effect in self.effects:
            f = [a + b for a, b in zip(f, effect(t, x, v, self.flow_gpm), strict=True)]
        return f

    def rhs(self, t: float, y: np.ndarray) -> list[float]:
        """``dy/dt`` for ``y = [u, v]``, ``u = x - x_static`` (m): what the integrator calls."""
        u = y.tolist()
        x = [a + b for a, b in zip(self._x_static, u[:7], strict=True)]
        v = u[7:]
        f = self.forces(t, x, v)
        return v + [fi * im for fi, im in zip(f, self._inv_mass, strict=True)]

    def accelerations(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Accelerations (m/s^2) of every body on an output grid: ``y`` is (n, 14)."""
        x = [self.x_static[i] + y[:, i] for i in range(7)]
        v = [y[:, 7 + i] for i in range(7)]
        f = self.forces(t, x, v)
        return np.column_stack([np.broadcast_to(fi, t.shape) / m
                                for fi, m in zip(f, self.mass, strict=True)])

    # ------------------------------------------------------------------------ integration

    def integrate(self, t: np.ndarray, y0: np.ndarray | None = None, *, rtol: float = 1e-6,
                  atol_x: float = 1e-8, atol_v: float = 1e-5) -> np.ndarray:
        """States ``[u, v]`` at the times ``t`` (from rest at the static state at ``t[0]``
        unless ``y0``): LSODA with vadsim's tolerances (1e-6 relative, 1e-8 m, 1e-5 m/s)."""
        y0 = np.zeros(14) if y0 is None else np.asarray(y0, dtype=float)
        atol = np.r_[np.full(7, atol_x), np.full(7, atol_v)]
        y, info = odeint(self.rhs, y0, t, tfirst=True, rtol=rtol, atol=atol,
                         mxstep=10_000_000, full_output=True)
        if info["message"] != "Integration successful.":
            raise RuntimeError(f"independent generator: LSODA failed at {self.flow_gpm:g} "
                               f"gal/min: {info['message']}")
        return np.asarray(y)


SETTLE_BLOCK = 50
"""Cycles per block of the settle's drift check."""

SETTLE_POINTS = 8
"""States per cycle the drift check samples (the first of each is the stroboscopic one)."""


def settle(model: IndependentModel, cycles: float, *, max_extra_blocks: int = 4,
           tol: float = 2e-3) -> tuple[float, np.ndarray, int]:
    """Run from the static state for ``cycles`` cycles, then on in blocks of
    :data:`SETTLE_BLOCK` cycles while the motion still drifts.

    Why: a driller records once the tool runs steadily, and some operating points approach
    their steady motion slowly (near a period doubling a period-2 component decays over
    hundreds of cycles); a record of the transient is another campaign than the one stated.
    The check is stroboscopic: the state once per excitation cycle over the last block
    against the block before, per component the change of its mean and of its spread,
    relative to the size of the orbit (the component's range over both blocks, sampled
    :data:`SETTLE_POINTS` times a cycle). Settled below ``tol``; an aperiodic motion that
    never settles is recorded after ``max_extra_blocks`` more blocks. Below two blocks of
    ``cycles`` (short test runs) there is no check.

    Returns
    -------
    tuple
        ``(t, y, extra_blocks)``: the time and state ``[u, v]`` the record may start from,
        and how many blocks were added.
    """
    period = 1.0 / model.f_exc_hz
    n0 = int(math.ceil(cycles))
    grid = np.arange(n0 * SETTLE_POINTS + 1) * (period / SETTLE_POINTS)
    y = model.integrate(grid)
    if n0 < 2 * SETTLE_BLOCK:
        return float(grid[-1]), y[-1], 0
    tail = y[-2 * SETTLE_BLOCK * SETTLE_POINTS - 1:]
    extra = 0
    while True:
        sec = tail[::SETTLE_POINTS]  # 2 * SETTLE_BLOCK + 1 stroboscopic states
        prev, last = sec[:SETTLE_BLOCK], sec[SETTLE_BLOCK + 1:]
        scale = np.ptp(tail, axis=0) + np.r_[np.full(7, 1e-9), np.full(7, 1e-6)]
        drift = (np.abs(last.mean(0) - prev.mean(0)) + np.abs(last.std(0) - prev.std(0)))
        if float(np.max(drift / scale)) < tol or extra >= max_extra_blocks:
            return float(grid[-1]), y[-1], extra
        extra += 1
        start = grid[-1]
        grid = start + np.arange(SETTLE_BLOCK * SETTLE_POINTS + 1) * (period / SETTLE_POINTS)
        y = model.integrate(grid, y[-1])
        tail = np.concatenate([tail[SETTLE_BLOCK * SETTLE_POINTS:], y[1:]])


def run_summary(params: Mapping[str, float], flow_gpm: float, cycles: float,
                analyse_cycles: float, *, effects: Sequence[Effect] = (),
                rate_hz: float = 50_000.0) -> dict[str, Any]:
    """Impacts per cycle and J* of one run, as MODEL.md defines them.

    The run starts from the static state; the last ``analyse_cycles`` are analysed on a grid
    of ``rate_hz``: an impact is the indentation turning positive between two grid points
    (contacts last milliseconds, the grid 20 us), J* the mean of F_I and of max(F_I, 0).

    Returns
    -------
    dict
        ``z`` (per surface: spring, impact, off_bottom, on_bottom, rock), ``jstar_pos``,
        ``jstar_mean`` (N/kg), ``peak_x1_g`` (max |a1| in the window).
    """
    m = IndependentModel(params, flow_gpm, effects)
    period = 1.0 / m.f_exc_hz
    t_w0 = (cycles - analyse_cycles) * period
    n = int(round(analyse_cycles * period * rate_hz))
    t = np.r_[0.0, t_w0 + np.arange(n + 1) / rate_hz]
    y = m.integrate(t)[1:]
    t = t[1:]
    x = [m.x_static[i] + y[:, i] for i in range(7)]
    v = [y[:, 7 + i] for i in range(7)]
    d = m.indentations(x)
    names = ("spring", "impact", "off_bottom", "on_bottom", "rock")
    z = {nm: float(np.count_nonzero((di[1:] > 0.0) & (di[:-1] <= 0.0))) / analyse_cycles
         for nm, di in zip(names, d, strict=True)}
    fi = m.impact_force(x, v)
    a = m.accelerations(t, y)
    return {"z": z, "jstar_pos": float(np.maximum(fi, 0.0).mean()),
            "jstar_mean": float(np.mean(fi)), "peak_x1_g": float(np.abs(a[:, 0]).max() / G)}
