"""Argument checks shared by the analysis modules: errors that name the bad argument."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt


def number(name: str, value: object) -> float:
    """``value`` as a float, or a ValueError naming ``name``. Booleans are not numbers here,
    though ``float(True)`` is 1.0: ``fs=True`` is a mistake, not a rate of 1 Hz."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None


def finite_positive(name: str, value: object) -> float:
    """A finite number > 0, or a ValueError naming ``name``."""
    out = number(name, value)
    if not math.isfinite(out) or out <= 0.0:
        raise ValueError(f"{name} must be a finite number > 0, got {out!r}")
    return out


def finite_1d(name: str, values: npt.ArrayLike) -> np.ndarray:
    """A one-dimensional float array without NaN or inf, or a ValueError naming ``name``."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ValueError(f"{name} has a non-finite value at index {bad[0]}: {arr[bad[0]]!r}")
    return arr
