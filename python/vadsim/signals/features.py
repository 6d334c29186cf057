"""The :class:`Feature` record -- a value with a spread from the recording itself -- the floors of
those spreads, features of a published summary, and tables of features.

Why this module exists: a model run and a field recording are compared feature by feature
(:mod:`vadsim.signals.window_features`: peaks, impact rate, band RMS and peak ratio over
200 ms windows; :mod:`vadsim.signals.fold_features`: the folded waveform, or quantiles where
a record does not repeat). A difference between a simulated and a recorded feature means
nothing without a yardstick, so every feature is a :class:`Feature` that carries a spread
estimated from the recording itself, and :func:`vadsim.compare.standardised_residual` divides
by the *recording's* spread.

What the spread is, and why it is not a standard error
------------------------------------------------------
Every window feature (:mod:`vadsim.signals.window_features`) is built from a per-window
quantity (window peak, window rate of impacts, window band RMS, ...) over the fixed 200 ms
windows of :func:`vadsim.signals.labels.window_peaks`. Its spread is the across-window standard
deviation of that quantity (``ddof=1``): how much the tool's response changes from one 200 ms
stretch of steady operation to the next. It is deliberately *not* the standard error of the
mean (that standard deviation divided by sqrt(n)):

* the model is deterministic: its feature has no sampling noise to speak of, and the question
  is whether it lies within the recording's natural variability, not whether it hits the
  recording's long-run mean to within the statistical precision of that mean;
* a standard error shrinks as 1/sqrt(record length). A long recording would make every model
  "wrong by tens of sigma" because of the slow variations no model holds (WOB and flow
  fluctuations, formation changes), and residuals would depend on how long someone happened to
  record. The across-window standard deviation does not depend on the record length.

For the dispersion ``peak_std_g``, which has no per-window value, the spread is the
one-window equivalent of its sampling standard deviation (``sqrt(n)`` times the standard
error, by the delta method; see :func:`vadsim.signals.window_features.sensor_features`) --
the same scaling that turns the standard error of ``peak_mean_g`` back into the standard
deviation of the window peaks.

Floors
------
A perfectly periodic signal (a simulation, a constructed test signal) has an across-window
standard deviation of 0, which would turn any residual into infinity. Every spread is floored::

    spread = max(raw spread, REL_SPREAD_FLOOR * |value|, SPREAD_FLOORS[kind])

with ``REL_SPREAD_FLOOR = 2 %`` (about the calibration accuracy of a field accelerometer, and
closer than a lumped model can be expected to match anyway) and an absolute floor per kind of
feature (:data:`SPREAD_FLOORS`): 0.5 g for accelerations, 0.5 Hz for frequencies, 0.02 for
dimensionless ratios and impacts per cycle. The kind is read off the key's suffix: ``_g``,
``_hz``, anything else (:func:`spread_kind`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import pandas as pd

from vadsim._checks import finite_positive, number

__all__ = [
    "REL_SPREAD_FLOOR",
    "SPREAD_FLOORS",
    "SUMMARY_REL_SPREAD",
    "Feature",
    "features_table",
    "spread_kind",
    "summary_features",
]

REL_SPREAD_FLOOR: float = 0.02
"""Smallest spread as a fraction of ``|value|`` (see the module docstring)."""

SPREAD_FLOORS: Mapping[str, float] = MappingProxyType({"g": 0.5, "hz": 0.5, "ratio": 0.02})
"""Absolute spread floor per kind of feature: ``"g"`` (key ends in ``_g``), ``"hz"`` (``_hz``),
``"ratio"`` (anything else: impacts per cycle, peak ratios, the clipped fraction).

* 0.5 g: a few LSB of a +-250 g, 12-bit field accelerometer (0.12 g per LSB) plus its noise;
  a simulated feature closer than that to the recording cannot be told apart from it.
* 0.5 Hz: the resolution of a count of impacts over a couple of seconds (1 / duration).
* 0.02: :data:`vadsim.signals.labels.Z_EQ_TOL`, the tolerance within which impacts per cycle
  count as equal.
"""

SUMMARY_REL_SPREAD: float = 0.1
"""Default spread of a summary-only feature, as a fraction of its value (see
:func:`summary_features`)."""


# --------------------------------------------------------------------------------------------
# The feature record
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Feature:
    """One feature: its value, the spread to standardise residuals with, and its support.

    Attributes
    ----------
    value : float
        The feature's value; NaN when it cannot be computed (e.g. every window clipped).
    spread : float
        Across-window standard deviation of the per-window quantity behind ``value``, floored
        as described in the module docstring (so > 0 whenever ``value`` is finite and the
        spread could be estimated); NaN when it could not be estimated (fewer than two usable
        windows). Not a standard error: see the module docstring.
    n : int
        Number of windows (observations) behind the value; 0 for a feature that could not be
        computed or that comes from a published summary (:func:`summary_features`).
    """

    value: float
    spread: float
    n: int

    def __post_init__(self) -> None:
        value = number("value", self.value)
        spread = number("spread", self.spread)
        if spread < 0.0 or math.isinf(spread):
            raise ValueError(f"spread must be a finite number >= 0 or NaN, got {spread!r}")
        if isinstance(self.n, bool) or not isinstance(self.n, int | np.integer) or self.n < 0:
            raise ValueError(f"n must be an integer >= 0, got {self.n!r}")
        object.__setattr__(self, "value", value)
        object.__setattr__(self, "spread", spread)
        object.__setattr__(self, "n", int(self.n))


def spread_kind(key: str) -> str:
    """The kind of feature ``key`` names, which decides its absolute spread floor.

    A feature's unit is written in its key's suffix, and the floor belongs to the unit
    (:data:`SPREAD_FLOORS`): a window feature and a summary feature of the same key get the
    same floor.

    Parameters
    ----------
    key : str
        Feature key, e.g. ``x1_peak_mean_g``.

    Returns
    -------
    str
        ``"g"`` for a key ending ``_g``, ``"hz"`` for ``_hz``, ``"ratio"`` for anything else.
    """
    if key.endswith("_g"):
        return "g"
    if key.endswith("_hz"):
        return "hz"
    return "ratio"


# --------------------------------------------------------------------------------------------
# Summary-only events
# --------------------------------------------------------------------------------------------


def summary_features(
    values: Mapping[str, float],
    rel_spread: float = SUMMARY_REL_SPREAD,
    floors: Mapping[str, float] = SPREAD_FLOORS,
) -> dict[str, Feature]:
    """Features of a summary-only event (RECORDINGS.md ``features = {...}``), with a default spread.

    A published summary (``x1_peak_mean_g = 68.0``, ``x1_impact_hz = 24.0``, ...) carries no
    spread, so one is assumed so that residuals can still be standardised:

        spread = max(rel_spread * |value|, floors[kind])

    **Default: 10 % of the value** (:data:`SUMMARY_REL_SPREAD`), floored at 0.5 g for keys
    ending ``_g``, 0.5 Hz for ``_hz`` and 0.02 otherwise (:data:`SPREAD_FLOORS`, the floors of
    the features computed from signals). 10 % is an assumption, not a measurement: the order
    of the window-to-window scatter of steady-state 200 ms peaks and of field-accelerometer
    calibration together; it makes a residual of a few units mean "clearly off" and no more.
    Pass ``rel_spread`` when the source states its scatter. ``n`` is 0 (no windows known).

    Parameters
    ----------
    values : mapping of str to float
        Feature key (``<sensor>_peak_mean_g``, ``<sensor>_peak_std_g``, ``<sensor>_impact_hz``,
        or any key of :func:`vadsim.signals.window_features.event_features`) to its finite value.
    rel_spread : float, optional
        Spread as a fraction of ``|value|``, > 0; default 0.1.
    floors : mapping of str to float, optional
        Absolute floors for the kinds ``"g"``, ``"hz"``, ``"ratio"``; missing kinds keep
        :data:`SPREAD_FLOORS`.

    Returns
    -------
    dict of str to Feature

    Raises
    ------
    ValueError
        Naming the argument: ``values`` not a mapping, a non-string key, a non-finite value, a
        ``rel_spread`` that is not a finite number > 0, an unknown kind or a floor that is not
        a finite number > 0.
    """
    if not isinstance(values, Mapping):
        raise ValueError(f"values must be a mapping of feature key to number, got {values!r}")
    rel_spread = finite_positive("rel_spread", rel_spread)
    if not isinstance(floors, Mapping):
        raise ValueError(f"floors must be a mapping of kind to floor, got {floors!r}")
    unknown = [k for k in floors if k not in SPREAD_FLOORS]
    if unknown:
        raise ValueError(f"floors: unknown kind {unknown[0]!r}; kinds are {list(SPREAD_FLOORS)}")
    fl = dict(SPREAD_FLOORS)
    fl.update({k: finite_positive(f"floors[{k!r}]", v) for k, v in floors.items()})
    out: dict[str, Feature] = {}
    for key, raw in values.items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"values: keys must be non-empty strings, got {key!r}")
        v = number(f"values[{key!r}]", raw)
        if not math.isfinite(v):
            raise ValueError(f"values[{key!r}] must be finite, got {v!r}")
        out[key] = Feature(v, max(rel_spread * abs(v), fl[spread_kind(key)]), 0)
    return out


# --------------------------------------------------------------------------------------------
# Tables and residuals
# --------------------------------------------------------------------------------------------


def _check_events(name: str, events: object) -> Mapping[str, Mapping[str, Feature]]:
    if not isinstance(events, Mapping):
        raise ValueError(f"{name} must be a mapping of event id to features, got {events!r}")
    for eid, feats in events.items():
        if not isinstance(feats, Mapping):
            raise ValueError(f"{name}[{eid!r}] must be a mapping of key to Feature")
        for key, f in feats.items():
            if not isinstance(f, Feature):
                raise ValueError(f"{name}[{eid!r}][{key!r}] must be a Feature, got {f!r}")
    return events


def _ordered_keys(*groups: Mapping[str, Mapping[str, Feature]]) -> list[str]:
    seen: dict[str, None] = {}
    for events in groups:
        for feats in events.values():
            seen.update(dict.fromkeys(feats))
    return list(seen)


def features_table(features: Mapping[str, Mapping[str, Feature]]) -> pd.DataFrame:
    """Features of several events as one table.

    Parameters
    ----------
    features : mapping of str to mapping of str to Feature
        Event id to its features (e.g.
        :func:`vadsim.signals.window_features.event_features` or :func:`summary_features`).

    Returns
    -------
    pandas.DataFrame
        One row per event (index ``"event"``, in the given order); columns a MultiIndex
        ``(feature, "value" | "spread")`` (levels ``"feature"``, ``"stat"``), features in the
        order first met; NaN where an event lacks a feature.

    Raises
    ------
    ValueError
        If ``features`` is not a mapping of mappings of :class:`Feature`.
    """
    events = _check_events("features", features)
    keys = _ordered_keys(events)
    columns = pd.MultiIndex.from_product([keys, ["value", "spread"]], names=["feature", "stat"])
    data = np.full((len(events), len(columns)), np.nan)
    for i, feats in enumerate(events.values()):
        for j, key in enumerate(keys):
            if key in feats:
                data[i, 2 * j : 2 * j + 2] = feats[key].value, feats[key].spread
    index = pd.Index(list(events), name="event")
    return pd.DataFrame(data, index=index, columns=columns)
