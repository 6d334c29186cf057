"""What one row of a sweep holds: the features of a run, their meaning and units, and the
version of the format they are stored in.

Shared by the grid (:mod:`vadsim.studies.grid`), which computes the rows, and the store
(:mod:`vadsim.studies.store`), which checks them when it reads a chunk back.
"""

from __future__ import annotations

__all__ = ["FEATURES", "FEATURE_ATTRS", "INT_FEATURES", "STORE_FORMAT", "TEXT_FEATURES"]

STORE_FORMAT = 3
"""Version of the store's files (1: vadsim 0.1, chunks without grid hash or checksum; 2:
rows without ``steady_period``, runs integrated to their end)."""

FEATURES: dict[str, str] = {
    "z_spring": "impacts per cycle at the recoil spring (#1)",
    "z_impact": "impacts per cycle at the impact face (#2)",
    "z_off_bottom": "impacts per cycle at the off-bottom shoulder (#3)",
    "z_on_bottom": "impacts per cycle at the on-bottom shoulder (#4)",
    "z_rock": "bit-rock contact onsets per cycle",
    "scenario": "impact scenario, dissertation Table 4.2 (0: no impact, 7: spring only)",
    "j_mean": "J*: mean impact-face force over the window (N/kg)",
    "j_pos": "J*: mean of max(F_I, 0) over the window (N/kg)",
    "j_pos_kN": "J* (mean of max(F_I, 0)) in kN, times the preset's reference mass",
    "x1_peak_mean_g": "mean of 200 ms peaks of |a| at the bit sub, full resolution (g)",
    "x1_peak_std_g": "dispersion of those peaks (g)",
    "x5_peak_mean_g": "mean of 200 ms peaks of |a| above the motor, full resolution (g)",
    "x5_peak_std_g": "dispersion of those peaks (g)",
    "x1_impact_hz": "major x1 acceleration peaks per second",
    "period": "period of the steady response in cycles (0: not periodic)",
    "periodicity": "period-n, quasi-periodic or aperiodic (Poincare section)",
    "steps": "CVODE steps",
    "steady_period": "cycles of the periodic orbit the run stopped at and was built from "
                     "(0: every cycle integrated)",
    "error": "empty, or why the run failed",
}

TEXT_FEATURES = ("periodicity", "error")
"""Features that are text, not numbers."""

INT_FEATURES = ("scenario", "period", "steps", "steady_period")
"""Features that are integers."""

# CF-style (units, long_name) of every variable, so that xarray's plots label themselves.
# "1" is a dimensionless number; labels (text) have no unit, hence "".
FEATURE_ATTRS: dict[str, tuple[str, str]] = {
    "z_spring": ("1", "impacts per cycle, recoil spring (#1)"),
    "z_impact": ("1", "impacts per cycle, impact face (#2)"),
    "z_off_bottom": ("1", "impacts per cycle, off-bottom shoulder (#3)"),
    "z_on_bottom": ("1", "impacts per cycle, on-bottom shoulder (#4)"),
    "z_rock": ("1", "bit-rock contact onsets per cycle"),
    "scenario": ("1", "impact scenario (Table 4.2)"),
    "j_mean": ("N/kg", "mean impact-face force J*"),
    "j_pos": ("N/kg", "impulse per second J*"),
    "j_pos_kN": ("kN", "impulse per second J*"),
    "x1_peak_mean_g": ("g", "bit-sub acceleration peaks, mean"),
    "x1_peak_std_g": ("g", "bit-sub acceleration peaks, dispersion"),
    "x5_peak_mean_g": ("g", "acceleration peaks above the motor, mean"),
    "x5_peak_std_g": ("g", "acceleration peaks above the motor, dispersion"),
    "x1_impact_hz": ("Hz", "bit-sub impact frequency"),
    "period": ("1", "period of the steady response (excitation cycles)"),
    "periodicity": ("", "periodicity of the steady response"),
    "steps": ("1", "CVODE steps"),
    "steady_period": ("1", "period of the orbit the run was built from (cycles)"),
    "error": ("", "why the run failed"),
}
