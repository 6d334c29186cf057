"""Argument checks shared by the analysis modules: errors that name the bad argument."""

from __future__ import annotations

import math
import os
import stat

import numpy as np
import numpy.typing as npt


def number(name: str, value: object) -> float:
    """``value`` as a float, or a ValueError naming ``name``. Booleans are not numbers here,
    though ``float(True)`` is 1.0: ``fs=True`` is a mistake, not a rate of 1 Hz."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)  # type: ignore[arg-type]
    except OverflowError:
        raise ValueError(f"{name} = {shown(value)} is too large for a double") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {shown(value)}") from None


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


SHOWN_CHARS = 80
"""Most characters of a value an error message quotes."""


def shown(value: object, limit: int = SHOWN_CHARS) -> str:
    """``repr(value)`` for an error message, cut to ``limit`` characters; an integer too long
    to print (or to be a double) by its digit count."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 1100:
        return f"<an integer of {value.bit_length()} bits>"
    try:
        text = repr(value)
    except ValueError:
        return f"<{type(value).__name__} too large to print>"
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def real(name: str, value: object) -> float:
    """A real number (int or float, numpy's too; not a bool, a string or bytes) as a float, or
    a ValueError naming ``name``: an integer too large for a double is refused by name, not
    with an ``OverflowError``. NaN and infinity pass (callers decide)."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        raise ValueError(f"{name} = {shown(value)} is not a number")
    try:
        return float(value)  # type: ignore[arg-type]
    except OverflowError:
        raise ValueError(f"{name} = {shown(value)} is too large for a double") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {shown(value)} is not a number") from None


def read_regular_file(path: os.PathLike[str] | str, max_bytes: int, where: str) -> bytes:
    """The bytes of ``path`` if it is a regular file of at most ``max_bytes``; else a
    ValueError that starts with ``where``. A FIFO or a device (``/dev/zero``) is refused before
    a byte is read: reading one would hang or grow without end."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except (OSError, ValueError) as exc:
        raise ValueError(f"{where}: cannot read: "
                         f"{getattr(exc, 'strerror', None) or exc}") from None
    with os.fdopen(fd, "rb", buffering=0) as f:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError(f"{where}: not a regular file (a folder, a pipe or a device)")
        if st.st_size > max_bytes:
            raise ValueError(f"{where}: {st.st_size} bytes, larger than the limit of "
                             f"{max_bytes} bytes")
        os.set_blocking(fd, True)
        data = f.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise ValueError(f"{where}: larger than the limit of {max_bytes} bytes")
    return data
