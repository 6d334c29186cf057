"""Impact regimes: a run's impacts per cycle at the recoil spring and the impact face, named as
the dissertation's scenarios (Table 4.2).

Why this module is in the model layer: the scenario is part of what a run *is* (its
:attr:`~vadsim.model.result.SimulationResult.scenario`), decided from two numbers the core
counts; the signal-level labels (:mod:`vadsim.signals.labels`) re-export it.
"""

from __future__ import annotations

import math

__all__ = ["SCENARIO_NONE", "SCENARIO_SPRING_ONLY", "Z_EQ_TOL", "check_tol", "check_z",
           "regime_name", "scenario", "surface_state"]


Z_EQ_TOL: float = 0.02
"""Absolute tolerance on Z for "Z = 1" (more generally "Z = k", k a positive integer) and "Z = 0".

Z is counted over the 200 analysed cycles, so one missed impact gives 199/200 = 0.995 and a
stray one 1/200 = 0.005. A tolerance of 0.02 accepts up to four missed (or stray) impacts in 200
cycles -- residue of a slowly decaying transient or a rare grazing contact -- as "regular" (or
"none"). It rejects every genuinely intermittent rational Z = p/q with q < 50: the largest such
value below 1 is 48/49 = 0.9796 (Z = 1/2, 2/3, 4/5, 7/8 of the 7in model are all far from it),
and the smallest above 0 is 1/49 = 0.0204. Orbits whose period is 50 cycles or more repeat at most
four times in 200 cycles, so they cannot be told from regular-with-misses anyway. The bound is
inclusive (a tiny slack absorbs rounding of the division). When Z is counted over a different
number of cycles n, pass ``tol`` of about ``4 / n`` (but keep it below ``1 / (2 * q_max)``).
"""


SCENARIO_NONE: int = 0
"""Scenario code for no impact at either the recoil spring or the impact face."""


SCENARIO_SPRING_ONLY: int = 7
"""Scenario code for impacts at the recoil spring but none at the impact face.

Not in the dissertation's Table 4.2 (the anvil bounces on the spring without reaching the bit);
a code of its own keeps it apart from the idle tool (:data:`SCENARIO_NONE`).
"""


_Z_SLACK: float = 1e-9
# Absorbs the rounding of onsets / cycles so that e.g. 196/200 sits inside a 0.02 tolerance.


_SCENARIOS: dict[tuple[str, str], int] = {
    ("regular", "regular"): 1,
    ("intermittent", "regular"): 2,
    ("intermittent", "intermittent"): 3,
    ("none", "intermittent"): 4,
    ("none", "regular"): 5,
    ("regular", "intermittent"): 6,
    ("none", "none"): SCENARIO_NONE,
    ("regular", "none"): SCENARIO_SPRING_ONLY,
    ("intermittent", "none"): SCENARIO_SPRING_ONLY,
}


_REGIME_NAMES: dict[int, str] = {
    SCENARIO_NONE: "no impacts",
    1: "regular spring, regular impact face",
    2: "intermittent spring, regular impact face",
    3: "intermittent spring, intermittent impact face",
    4: "no spring impact, intermittent impact face",
    5: "no spring impact, regular impact face",
    6: "regular spring, intermittent impact face",
    SCENARIO_SPRING_ONLY: "spring impacts only, none at the impact face",
}


def check_z(name: str, z: float) -> float:
    z = float(z)
    if not math.isfinite(z) or z < 0.0:
        raise ValueError(f"{name} must be a finite number >= 0, got {z!r}")
    return z


def check_tol(tol: float) -> float:
    tol = float(tol)
    # Above 0.5 the "near an integer" bands would overlap and every Z would be regular or none.
    if not math.isfinite(tol) or not 0.0 <= tol < 0.5:
        raise ValueError(f"tol must be in [0, 0.5), got {tol!r}")
    return tol


def surface_state(z: float, tol: float = Z_EQ_TOL) -> str:
    """Impact state of one surface from its Z: ``"regular"``, ``"intermittent"`` or ``"none"``.

    * ``"none"``: ``Z <= tol``.
    * ``"regular"``: Z within ``tol`` of a positive integer k. MODEL.md's "=1" is k = 1; k >= 2
      (two impacts every cycle, or a chattering contact that re-opens the same number of times
      each cycle) is regular too, because Z near an integer over 200 cycles means the surface is
      hit the same number of times every cycle up to a few exceptions. Only the mean is known,
      so a mixture like "0 impacts one cycle, 2 the next" (Z = 1) cannot be told apart; a
      Poincare section (:func:`periodicity`) resolves it if needed.
    * ``"intermittent"``: anything else, including a non-integer Z > 1 (e.g. 1.5: one impact in
      some cycles, two in others) -- the surface is not hit the same way every cycle.

    Parameters
    ----------
    z : float
        Impacts per cycle, >= 0.
    tol : float, optional
        Absolute tolerance, default :data:`Z_EQ_TOL` (see there for why 0.02).

    Returns
    -------
    str
        The state, as in the columns of ``data/thesis/regimes_7in.csv``.
    """
    z = check_z("z", z)
    tol = check_tol(tol)
    if z <= tol + _Z_SLACK:
        return "none"
    if abs(z - round(z)) <= tol + _Z_SLACK:
        return "regular"
    return "intermittent"


def scenario(z_spring: float, z_impact: float, tol: float = Z_EQ_TOL) -> int:
    """Impact scenario (dissertation Table 4.2) from Z1 (recoil spring) and Z2 (impact face).

    ======== ============ ============ ===================================================
    code     Z1 (spring)  Z2 (face)    note
    ======== ============ ============ ===================================================
    1        regular      regular
    2        intermittent regular
    3        intermittent intermittent
    4        none         intermittent
    5        none         regular
    6        regular      intermittent
    0        none         none         not in Table 4.2: idle tool (:data:`SCENARIO_NONE`)
    7        > 0          none         not in Table 4.2 (:data:`SCENARIO_SPRING_ONLY`)
    ======== ============ ============ ===================================================

    "regular" is MODEL.md's "=1", "intermittent" its "0<Z<1", "none" its "=0", judged by
    :func:`surface_state` with the same ``tol`` (so Z = 2 counts as regular, Z = 1.5 as
    intermittent).

    Parameters
    ----------
    z_spring, z_impact : float
        Z1 and Z2, >= 0.
    tol : float, optional
        Absolute tolerance on Z, default :data:`Z_EQ_TOL`.

    Returns
    -------
    int
        Scenario code, 0..7.
    """
    s1 = surface_state(check_z("z_spring", z_spring), tol)
    s2 = surface_state(check_z("z_impact", z_impact), tol)
    return _SCENARIOS[(s1, s2)]


def regime_name(scenario: int) -> str:
    """Short description of a scenario code returned by :func:`scenario`.

    Raises
    ------
    ValueError
        If the code is not one of 0..7.
    """
    try:
        return _REGIME_NAMES[int(scenario)]
    except (KeyError, TypeError, ValueError):
        raise ValueError(
            f"scenario must be one of {sorted(_REGIME_NAMES)}, got {scenario!r}"
        ) from None
