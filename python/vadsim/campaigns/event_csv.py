"""Reading one event CSV in bounded memory: limits checked before parsing, then chunks.

Why this module exists: an event CSV may come from anyone, and a parser handed a 50 MB line,
50 MB of newlines or a gigabyte of NUL bytes grows until the kernel kills it (pandas took 10 GB
and ended in a MemoryError traceback). So the file is opened as a regular file only, its size,
its header and its lines are checked against :func:`~vadsim.campaigns.format.csv_limits` in one
streaming pass of fixed-size blocks, and only then are its samples parsed, in chunks of rows
with a typed schema (every column float64). A parse that fails is diagnosed line by line, again
streaming, so that the error names the line.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
import re
import stat
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
import pandas as pd

from vadsim.campaigns.format import (
    CAMPAIGN_FILE,
    MAX_CSV_FIELD_BYTES,
    RATE_TOLERANCE,
    TIME_RESOLUTION_S,
    CampaignError,
    CsvLimits,
    Sensor,
    csv_limits,
    excerpt,
)

__all__ = ["open_regular", "read_event_csv", "time_problem"]

BLOCK_BYTES = 1 << 18
"""Bytes read at a time by the streaming checks (a few MB of working memory at most, when
every byte is a line end)."""

CHUNK_ROWS = 1 << 18
"""Rows parsed at a time (6 MB of float64 at three columns)."""

# A decimal number as the CSV cells hold it. ASCII only: in Python `\d` and `\s` also match
# other scripts' digits and spaces, and float() would read '١٢٣' as 123. Written without
# overlapping repeats so a long token fails in linear time.
_NUMBER_RE = re.compile(r"\s*[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\s*",
                        re.ASCII)
# Tokens pandas reads as missing values; named as such rather than as "non-numeric".
_NA_TOKENS = frozenset(
    {"", "nan", "+nan", "-nan", "na", "n/a", "null", "none", "#n/a", "#na", "<na>",
     "-1.#ind", "1.#ind", "-1.#qnan", "1.#qnan", "#n/a n/a"}
)
_INF_TOKENS = frozenset({"inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"})
_BLANK = b" \t\r\n"
_CR, _LF = 13, 10


@contextlib.contextmanager
def open_regular(path: Path, where: str, max_bytes: int, what: str) -> Iterator[IO[bytes]]:
    """``path`` opened for reading if it is a regular file of at most ``max_bytes``.

    A FIFO never ends and a device may be endless (``/dev/zero``): both are refused before a
    byte is read, as is a file over the limit. ``where`` starts each error message; ``what``
    says what the limit is for.

    Raises
    ------
    CampaignError
        Naming the file and the limit.
    """
    try:
        # O_NONBLOCK: opening a FIFO with no writer would otherwise block before the check
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise CampaignError(f"{where}: no such file") from None
    except (OSError, ValueError) as exc:
        raise CampaignError(f"{where}: cannot read: "
                            f"{excerpt(getattr(exc, 'strerror', None) or str(exc))}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise CampaignError(f"{where}: not a regular file (a folder, a pipe or a device); "
                                f"a campaign reads regular files only")
        if st.st_size > max_bytes:
            raise CampaignError(f"{where}: {st.st_size} bytes, larger than the limit of "
                                f"{max_bytes} bytes for {what}")
        os.set_blocking(fd, True)
        f = os.fdopen(fd, "rb", buffering=0)
    except BaseException:
        os.close(fd)
        raise
    with f:
        yield f


def time_problem(t: np.ndarray, rate_hz: float) -> tuple[int, str] | None:
    """First sample index whose time breaks monotonicity or the uniform grid, with the reason.

    The grid is anchored at the first sample: sample i must sit within
    ``RATE_TOLERANCE * i * dt + min(TIME_RESOLUTION_S, dt/100)`` of ``t0 + i * dt`` (a clock
    good to 1e-6 relative, printed with 7 decimals); dt/100 keeps a dropped sample visible at
    rates where 1e-7 s would be a sizeable part of the period.
    """
    steps = np.diff(t)
    bad = np.flatnonzero(~(steps > 0))
    if bad.size:
        k = int(bad[0]) + 1
        return k, (f"time_s = {float(t[k])!r} s does not increase strictly (previous sample "
                   f"{float(t[k - 1])!r} s)")
    dt = 1.0 / rate_hz
    idx = np.arange(t.size, dtype=np.float64)
    expected = t[0] + idx * dt
    with np.errstate(over="ignore", invalid="ignore"):
        dev = np.abs(t - expected)
        tol = (RATE_TOLERANCE * idx * dt + min(TIME_RESOLUTION_S, dt / 100)
               + 4 * np.finfo(np.float64).eps * np.abs(t))
        bad = np.flatnonzero(~(dev <= tol))
    if bad.size:
        k = int(bad[0])
        msg = (f"time_s = {float(t[k])!r} s is off the uniform {rate_hz:g} Hz grid started "
               f"at {float(t[0])!r} s: expected {float(expected[k]):.9g} s (deviation "
               f"{dev[k]:.3g} s, tolerance {tol[k]:.3g} s)")
        if k == 1:
            msg += f"; the first step {steps[0]:.9g} s means {1 / steps[0]:.9g} Hz"
        return k, msg
    return None


# ------------------------------------------------------------------- the streaming checks


@dataclass
class _Body:
    """Where the samples lie in the file and how many lines they take."""

    start: int  # offset of the first byte after the header line's end
    end: int  # offset after the last byte that is not blank (trailing blank lines dropped)
    rows: int  # lines between start and end


def _read_header(f: IO[bytes], limits: CsvLimits, where: str) -> tuple[bytes, int]:
    """The header line (its end excluded) and the offset after its end."""
    head = f.read(limits.max_line_bytes + 2)
    cut = min((i for i in (head.find(b"\n"), head.find(b"\r")) if i >= 0), default=-1)
    if cut < 0:
        if len(head) > limits.max_line_bytes:
            raise CampaignError(f"{where}, line 1: longer than {limits.max_line_bytes} bytes, "
                                f"the limit for a line of this file")
        return head, len(head)
    if cut > limits.max_line_bytes:
        raise CampaignError(f"{where}, line 1: longer than {limits.max_line_bytes} bytes, the "
                            f"limit for a line of this file")
    after = cut + (2 if head[cut:cut + 2] == b"\r\n" else 1)
    return head[:cut], after


def _columns(limits: CsvLimits) -> int:
    return limits.max_line_bytes // (MAX_CSV_FIELD_BYTES + 1)


def _scan_body(f: IO[bytes], start: int, limits: CsvLimits, where: str) -> _Body:
    """One pass over the samples in blocks: every line within the line limit, the lines
    within the row limit, and where the last non-blank byte is."""
    f.seek(start)
    offset = start
    line = 2  # the line the next byte belongs to
    run = 0  # bytes of that line seen so far
    last_cr = False  # the previous block ended in '\r' (a '\n' next ends the same line)
    end = start
    while block := f.read(BLOCK_BYTES):
        arr = np.frombuffer(block, dtype=np.uint8)
        breaks = np.flatnonzero((arr == _LF) | (arr == _CR))
        lengths = np.diff(np.concatenate(([-1], breaks))) - 1
        if lengths.size:
            lengths[0] += run
        tail = run + arr.size if not breaks.size else arr.size - 1 - int(breaks[-1])
        too_long = np.flatnonzero(lengths > limits.max_line_bytes)
        if too_long.size or tail > limits.max_line_bytes:
            k = int(too_long[0]) if too_long.size else breaks.size
            crlf = _crlf_count(arr, breaks[:k], last_cr)
            raise CampaignError(f"{where}, line {line + k - crlf}: longer than "
                                f"{limits.max_line_bytes} bytes, the limit for a line of this "
                                f"file ({_columns(limits)} columns of at most "
                                f"{limits.max_line_bytes // _columns(limits) - 1} bytes)")
        line += breaks.size - _crlf_count(arr, breaks, last_cr)
        if line - 2 > limits.max_rows + 1:
            raise CampaignError(f"{where}: more than {limits.max_rows} sample rows, the limit "
                                f"for this file (the sensors' rate times the longest recording)")
        run = tail
        last_cr = bool(arr[-1] == _CR)
        solid = np.flatnonzero(~np.isin(arr, np.frombuffer(_BLANK, dtype=np.uint8)))
        if solid.size:
            end = offset + int(solid[-1]) + 1
        offset += arr.size
    rows = _count_lines(f, start, end)
    if rows > limits.max_rows:
        raise CampaignError(f"{where}: more than {limits.max_rows} sample rows, the limit for "
                            f"this file (the sensors' rate times the longest recording)")
    return _Body(start, end, rows)


def _crlf_count(arr: np.ndarray, breaks: np.ndarray, last_cr: bool) -> int:
    """How many of ``breaks`` are the '\\n' of a '\\r\\n' pair (one line end, not two)."""
    lf = breaks[arr[breaks] == _LF]
    prev_cr = np.zeros(lf.size, dtype=bool)
    inside = lf > 0
    prev_cr[inside] = arr[lf[inside] - 1] == _CR
    prev_cr[~inside] = last_cr
    return int(np.count_nonzero(prev_cr))


def _count_lines(f: IO[bytes], start: int, end: int) -> int:
    """Lines in ``[start, end)``: line ends ('\\n', '\\r' or '\\r\\n') plus the last line."""
    if end <= start:
        return 0
    f.seek(start)
    left, count, last_cr = end - start, 1, False
    while left > 0 and (block := f.read(min(BLOCK_BYTES, left))):
        arr = np.frombuffer(block, dtype=np.uint8)
        breaks = np.flatnonzero((arr == _LF) | (arr == _CR))
        count += breaks.size - _crlf_count(arr, breaks, last_cr)
        last_cr = bool(arr[-1] == _CR)
        left -= arr.size
    return count


class _Window(io.RawIOBase):
    """A file seen from ``start`` to ``end`` only (what pandas reads), as a binary stream."""

    def __init__(self, f: IO[bytes], start: int, end: int) -> None:
        super().__init__()
        self.f, self.left = f, end - start
        f.seek(start)

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: Any) -> int:
        view = memoryview(buffer).cast("B")
        n = min(len(view), self.left)
        if n <= 0:
            return 0
        data = self.f.read(n)
        view[:len(data)] = data
        self.left -= len(data)
        return len(data)


def _window(f: IO[bytes], start: int, end: int) -> io.BufferedReader:
    return io.BufferedReader(_Window(f, start, end), buffer_size=BLOCK_BYTES)


# --------------------------------------------------------------------------- parsing


def _parse_chunks(f: IO[bytes], body: _Body, header: list[str]) -> np.ndarray | None:
    """Every sample as float64 (rows x header columns) by pandas in chunks; None where a
    chunk does not parse as finite numbers of the right count (then diagnosed by line)."""
    out = np.empty((body.rows, len(header)), dtype=np.float64)
    i = 0
    try:
        with warnings.catch_warnings():
            # A row longer than the header only warns in pandas; here it is an error.
            warnings.simplefilter("error", pd.errors.ParserWarning)
            reader = pd.read_csv(
                _window(f, body.start, body.end), header=None, names=header, index_col=False,
                skip_blank_lines=False, quoting=csv.QUOTE_NONE, engine="c",
                dtype=np.float64, chunksize=CHUNK_ROWS)
            with reader:
                for chunk in reader:
                    values = chunk.to_numpy(dtype=np.float64)
                    if i + len(values) > body.rows or not np.isfinite(values).all():
                        return None
                    out[i:i + len(values)] = values
                    i += len(values)
    except (ValueError, pd.errors.ParserError, pd.errors.ParserWarning, OverflowError,
            UnicodeDecodeError):
        return None
    return out if i == body.rows else None


def _line_problem(line: str, columns: list[str]) -> str | None:
    """What is wrong with one sample line, or None."""
    fields = line.split(",")
    if len(fields) != len(columns):
        return f"expected {len(columns)} comma-separated fields, found {len(fields)}"
    for col, token in zip(columns, fields, strict=True):
        low = token.strip().lower()
        if low in _NA_TOKENS:
            return f"column {excerpt(col)}: missing value or NaN ({excerpt(token)})"
        if low in _INF_TOKENS:
            return f"column {excerpt(col)}: infinite value ({excerpt(token)})"
        if not _NUMBER_RE.fullmatch(token):
            return f"column {excerpt(col)}: non-numeric value {excerpt(token)}"
        if not math.isfinite(float(token)):
            return f"column {excerpt(col)}: value out of float range ({excerpt(token)})"
    return None


def _parse_by_line(f: IO[bytes], body: _Body, header: list[str], where: str) -> np.ndarray:
    """Every sample parsed line by line in Python (slow, exact): the first bad line is named.
    Reached only when pandas balked; a file whose every token is a finite decimal is still
    read (e.g. integers beyond 64 bits)."""
    out = np.empty((body.rows, len(header)), dtype=np.float64)
    i = 0
    for lineno, raw in _split_lines(f, body):
        try:
            line = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise CampaignError(f"{where}, line {lineno}: not valid UTF-8 text") from None
        problem = _line_problem(line, header)
        if problem is not None:
            raise CampaignError(f"{where}, line {lineno}: {problem}")
        out[i] = [float(tok) for tok in line.split(",")]
        i += 1
    return out[:i]


def _split_lines(f: IO[bytes], body: _Body) -> Iterator[tuple[int, bytes]]:
    """(line number, bytes) of each sample line, streaming over the body in blocks."""
    window = _window(f, body.start, body.end)
    pending = b""
    lineno = 2
    while block := window.read(BLOCK_BYTES):
        data = pending + block
        # a '\r' at the end may be the first half of '\r\n': keep it for the next block
        keep = 1 if data.endswith(b"\r") else 0
        parts = re.split(rb"\r\n|\r|\n", data[:len(data) - keep] if keep else data)
        pending = parts.pop() + (b"\r" if keep else b"")
        for part in parts:
            yield lineno, part
            lineno += 1
    if pending.endswith(b"\r"):
        pending = pending[:-1]
    yield lineno, pending


def _check_header(header: list[str], expected: list[str], where: str) -> None:
    """The header names ``time_s`` first and each declared sensor's column exactly once."""
    wanted = excerpt(",".join(expected))
    if header[0] != "time_s":
        raise CampaignError(f"{where}, line 1: the first column must be 'time_s', found "
                            f"{excerpt(header[0])} (expected header {wanted})")
    for j, col in enumerate(header):
        if col in header[:j]:
            raise CampaignError(f"{where}, line 1: column {excerpt(col)} appears twice")
        if col not in expected:
            sensor = col[:-2] if col.endswith("_g") else None
            why = (f"no sensor {excerpt(sensor)} is declared" if sensor
                   else "sensor columns are named <sensor>_g")
            raise CampaignError(f"{where}, line 1: unexpected column {excerpt(col)} ({why}; "
                                f"expected columns {wanted})")
    for col in expected:
        if col not in header:
            raise CampaignError(f"{where}, line 1: missing column {excerpt(col)} for sensor "
                                f"{excerpt(col[:-2])} declared in {CAMPAIGN_FILE}")


def read_event_csv(path: Path, sensors: Mapping[str, Sensor],
                   where: str) -> tuple[pd.DataFrame, dict[str, np.ndarray]]:
    """Read and validate one event CSV in bounded memory; the samples and the clipping masks.

    ``where`` starts every error message (the file as the campaign names it, and the event).
    Limits (:func:`~vadsim.campaigns.format.csv_limits`) are checked before any parsing.

    Raises
    ------
    CampaignError
        Naming the file, the event, the line and the rule or limit broken.
    """
    expected = ["time_s"] + [s.column for s in sensors.values()]
    rate = next(iter(sensors.values())).rate_hz
    limits = csv_limits(rate, len(expected))
    with open_regular(path, where, limits.max_bytes,
                      f"{len(expected)} columns at {rate:g} Hz") as f:
        head, start = _read_header(f, limits, where)
        values = _read_body(f, head, start, expected, limits, where)
    if values.shape[0] < 2:
        raise CampaignError(f"{where}, line {values.shape[0] + 2}: at least 2 samples are "
                            f"needed to check the sampling rate, found {values.shape[0]}")
    problem = time_problem(values[:, 0], rate)
    if problem is not None:
        raise CampaignError(f"{where}, line {problem[0] + 2}: {problem[1]}")
    data = pd.DataFrame(values, columns=expected)
    clipped = {s.name: np.abs(values[:, j + 1]) >= s.range_g
               for j, s in enumerate(sensors.values())}
    return data, clipped


def _read_body(f: IO[bytes], head: bytes, start: int, expected: list[str], limits: CsvLimits,
               where: str) -> np.ndarray:
    """The samples (rows x ``expected`` columns) after the header line ``head``."""
    if not head.strip(_BLANK):
        f.seek(0)
        if not f.read(BLOCK_BYTES).strip(_BLANK):
            raise CampaignError(f"{where}, line 1: empty file; expected the header "
                                f"{excerpt(','.join(expected))}")
    try:
        header_text = head.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise CampaignError(f"{where}, line 1: not valid UTF-8 text") from None
    header = [h.strip() for h in header_text.split(",")]
    _check_header(header, expected, where)
    body = _scan_body(f, start, limits, where)
    if body.rows == 0:
        raise CampaignError(f"{where}, line 2: no samples after the header")
    table = _parse_chunks(f, body, header)
    if table is None:
        table = _parse_by_line(f, body, header, where)
    order: list[Any] = [header.index(c) for c in expected]
    return table[:, order]
