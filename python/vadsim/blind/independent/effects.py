"""Effects the independent generator writes in its own form.

Why this module exists: a field's missing physics is never exactly a member of the
diagnosis' candidate library. Each effect here is a small function of (time, positions,
velocities, flow) that returns a force per body, added to the independent simulator's
right-hand side (:data:`vadsim.blind.independent.model.Effect`); some are library members
written another way, some are outside every family on purpose:

``excitation_power``
    The flow-driven force's amplitude ``Fo factor (Q/400)^p``: adds
    ``(factor (Q/400)^p - 1) F_H`` to the anvil. Exactly the library's
    ``excitation_amplitude`` at ``factor, p``: a truth the regret can evaluate.
``hydraulic_quadratic``
    A pressure-drop force on the anvil, towards the rock, of a nozzle law with a smooth onset:
    ``f400 (Q/400)^2 / (1 + exp(-(Q - q_on) / width))``. The library's
    ``hydraulic_force[anvil]`` is a pure power ``f_ref (Q/400)^n``; the onset bends it.
``friction_stribeck``
    Friction between anvil and housing with a Stribeck peak and an algebraic
    regularisation: ``(force + (static - force) exp(-(v/v_s)^2)) v / sqrt(v^2 + v0^2)``
    against the relative velocity ``v``. The library's ``anvil_friction[stribeck]`` has the
    same peak with another regularisation, ``tanh(v / 1 mm/s)``, so the truth is its nearest
    member (force, peak = static / force, v_s), not an exact one; ``anvil_friction`` is a
    constant ``force tanh(v / v_eps)``.
``hertz_contact``
    A Hertzian impact face ``k_h d^1.5 (1 + 1.5 damping d')`` without tension (Hunt and
    Crossley's damping on a Hertz spring) in place of the Kelvin-Voigt one: adds
    ``F_hertz - F_kv`` between anvil and bit. ``k_h = stiffness kI / sqrt(d_c)`` matches the
    linear spring at the indentation ``d_c``. Exactly the library's ``contact_law[impact]``
    (Hertz's spring with Hunt-Crossley damping at the impact face) at ``stiffness`` and
    ``factor = 1.5 damping stiffness kI d_c / cI``, written here in the generator's own form.

Each effect is built by :func:`build_effect` from its name and parameters, so a scenario
stays data (names and numbers) and truth.json can record it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from vadsim.blind.independent.model import Effect, preset_params

__all__ = ["EFFECTS", "build_effect", "nearest_hydraulic", "nearest_library"]

FLOW_REF = 400.0
"""Reference flow (gal/min) of the flow laws: the middle of the 7in tool's range."""

D_C = 1e-3
"""Indentation (m) at which the Hertzian face equals the linear one (the 7in tool's typical
impact indentation)."""


def _zero(x: Any) -> Any:
    return np.zeros_like(x[0]) if isinstance(x[0], np.ndarray) else 0.0


def excitation_power(p: Mapping[str, float], factor: float, exponent: float) -> Effect:
    """``F_H (factor (Q/400)^p - 1)`` on the anvil (the amplitude ``Fo factor (Q/400)^p``)."""
    Fo, alpha, phi, beta, psi = p["Fo"], p["alpha"], p["phi"], p["beta"], p["psi"]

    def effect(t: Any, x: Sequence[Any], v: Sequence[Any], q: float) -> list[Any]:
        gain = factor * (q / FLOW_REF) ** exponent - 1.0
        fh = Fo * np.cos(alpha * q * t + phi) * np.sin(beta * (x[1] - x[2]) + psi)
        z = _zero(x)
        return [z, gain * fh, z, z, z, z, z]

    return effect


def hydraulic_quadratic(p: Mapping[str, float], f400: float, q_on: float,
                        width: float) -> Effect:
    """``f400 (Q/400)^2`` with a logistic onset at ``q_on`` (gal/min), on the anvil."""
    del p  # the law needs no model parameter

    def effect(t: Any, x: Sequence[Any], v: Sequence[Any], q: float) -> list[Any]:
        force = f400 * (q / FLOW_REF) ** 2 / (1.0 + math.exp(-(q - q_on) / width))
        z = _zero(x)
        return [z, force + z, z, z, z, z, z]

    return effect


def friction_stribeck(p: Mapping[str, float], force: float, static: float, v_s: float,
                      v0: float) -> Effect:
    """Stribeck friction between anvil (dof 2) and housing (dof 3), algebraic regularisation."""
    del p

    def effect(t: Any, x: Sequence[Any], v: Sequence[Any], q: float) -> list[Any]:
        w = v[1] - v[2]
        level = force + (static - force) * np.exp(-(w / v_s) ** 2)
        f = level * w / np.sqrt(w * w + v0 * v0)
        z = _zero(x)
        return [z, -f, f + z, z, z, z, z]

    return effect


def hertz_contact(p: Mapping[str, float], stiffness: float, damping: float) -> Effect:
    """The impact face as ``k_h d^1.5 (1 + 1.5 damping d')``, no tension, replacing the
    Kelvin-Voigt face (adds the difference between anvil and bit)."""
    kI, cI = p["kI"], p["cI"]
    k_h = stiffness * kI / math.sqrt(D_C)

    def effect(t: Any, x: Sequence[Any], v: Sequence[Any], q: float) -> list[Any]:
        d, rate = x[1] - x[0], v[1] - v[0]
        if isinstance(d, np.ndarray):
            dp = np.maximum(d, 0.0)
            hz = np.maximum(k_h * dp ** 1.5 * (1.0 + 1.5 * damping * rate), 0.0)
            kv = np.where(d > 0.0, kI * d + cI * rate, 0.0)
        elif d > 0.0:
            hz = max(k_h * d ** 1.5 * (1.0 + 1.5 * damping * rate), 0.0)
            kv = kI * d + cI * rate
        else:
            return [0.0] * 7
        diff = hz - kv  # F_I acts +F_I on the bit, -F_I on the anvil
        z = _zero(x)
        return [diff, -diff, z, z, z, z, z]

    return effect


EFFECTS: dict[str, Any] = {
    "excitation_power": (excitation_power, ("factor", "p"), "excitation_amplitude"),
    "hydraulic_quadratic": (hydraulic_quadratic, ("f400", "q_on", "width"),
                            "hydraulic_force[anvil]"),
    "friction_stribeck": (friction_stribeck, ("force", "static", "v_s", "v0"),
                          "anvil_friction[stribeck]"),
    "hertz_contact": (hertz_contact, ("stiffness", "damping"), "contact_law[impact]"),
}
"""Each effect's factory, its parameters in order, and the library key it is scored as."""


def build_effect(name: str, values: Mapping[str, float], params: Mapping[str, float]
                 ) -> Effect:
    """The effect ``name`` at ``values`` for a model with ``params`` (Table 2.1)."""
    if name not in EFFECTS:
        raise ValueError(f"unknown independent effect {name!r}: choose from "
                         f"{', '.join(EFFECTS)}")
    factory, names, _ = EFFECTS[name]
    missing = [n for n in names if n not in values]
    unknown = sorted(set(values) - set(names))
    if missing or unknown:
        raise ValueError(f"independent effect {name}: parameters are {', '.join(names)} "
                         f"(missing {missing}, unknown {unknown})")
    return factory(params, *(float(values[n]) for n in names))


def nearest_hydraulic(f400: float, q_on: float, width: float,
                      flows: Sequence[float]) -> dict[str, float]:
    """The library member ``f_ref (Q/400)^n`` nearest to :func:`hydraulic_quadratic` over
    ``flows``: least squares in the force, ``n`` kept in the library's [1, 3]."""
    q = np.asarray(flows, dtype=float)
    target = f400 * (q / FLOW_REF) ** 2 / (1.0 + np.exp(-(q - q_on) / width))
    best = (math.inf, 0.0, 0.0)
    for n in np.linspace(1.0, 3.0, 201):
        basis = (q / FLOW_REF) ** n
        f_ref = float(basis @ target / (basis @ basis))
        err = float(np.sum((f_ref * basis - target) ** 2))
        if err < best[0]:
            best = (err, f_ref, float(n))
    return {"f_ref": round(best[1], 2), "n": round(best[2], 2)}


def nearest_library(name: str, values: Mapping[str, float], flows: Sequence[float],
                    params: Mapping[str, float] | None = None
                    ) -> tuple[str, dict[str, float], bool]:
    """How an effect is scored: ``(library key, values, exact)``.

    ``exact`` says whether the effect *is* that library member at those values (then the
    regret can evaluate the truth); otherwise the values are the nearest member's where one
    is defined (parameter errors are scored against them), or empty (identification only).
    ``params`` (Table 2.1 of the recording model; default the 7in tool's) converts an effect
    whose library form is relative to a surface's own constants.
    """
    key = EFFECTS[name][2]
    if name == "excitation_power":
        return key, {"factor": float(values["factor"]), "p": float(values["p"])}, True
    if name == "hydraulic_quadratic":
        return key, nearest_hydraulic(values["f400"], values["q_on"], values["width"],
                                      flows), False
    if name == "friction_stribeck":
        force = float(values["force"])
        return key, {"force": force, "peak": float(values["static"]) / force,
                     "v_s": float(values["v_s"])}, False
    if name == "hertz_contact":
        p = preset_params("7in-cde") if params is None else params
        stiffness = float(values["stiffness"])
        factor = 1.5 * float(values["damping"]) * stiffness * p["kI"] * D_C / p["cI"]
        return key, {"stiffness": stiffness, "factor": factor}, True
    return key, {}, False
