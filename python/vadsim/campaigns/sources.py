"""Reading a vendor's files for an import: tables of named columns with their units.

Why this module exists: a downhole memory sub and a rig's surface log come as the vendor
wrote them -- CSV with its own column names and units, Parquet, HDF5, Excel, LAS 2.0 -- not
as the campaign format (RECORDINGS.md). :func:`open_table` opens any of them as a
:class:`Table` (the columns that exist, with the unit each file states for them) and reads
only the columns an import asks for. Units are converted here, once: accelerations to g,
flow to gal/min, WOB to klbf, time to seconds (:func:`unit_factor`).

Limits: every file is checked against :data:`MAX_FILE_BYTES` before it is parsed, a text
file's lines against :data:`MAX_LINE_CHARS` and its columns against :data:`MAX_COLUMNS`; each
error names the file and the limit. The optional readers (pyarrow for Parquet, h5py or
PyTables for HDF5, openpyxl for Excel, lasio for LAS) are imported when a file needs them;
a missing one gives an error naming the package (``pip install vadsim[io]`` brings them all).
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vadsim.campaigns.format import CampaignError, excerpt

__all__ = [
    "MAX_COLUMNS",
    "MAX_FILE_BYTES",
    "MAX_LINE_CHARS",
    "QUANTITIES",
    "Table",
    "canonical_unit",
    "open_table",
    "split_unit",
    "unit_factor",
]

#: Largest file an import reads (bytes): a 4 h record of two sensors at 1024 Hz is ~1 GB of CSV.
MAX_FILE_BYTES = 4 * 1024**3

#: Longest line of a text file (characters): a header of many long column names fits; a
#: binary file or a file without line breaks does not.
MAX_LINE_CHARS = 65_536

#: Most columns a file may have.
MAX_COLUMNS = 4096

G = 9.80665
"""Standard gravity, m/s^2 per g."""

#: For each quantity, each canonical unit and its factor to the campaign's unit.
QUANTITIES: dict[str, dict[str, float]] = {
    "acceleration": {"g": 1.0, "m/s^2": 1.0 / G},
    "flow": {"gal/min": 1.0, "L/min": 1.0 / 3.785411784, "m3/min": 1000.0 / 3.785411784},
    "wob": {"klbf": 1.0, "kN": 1.0 / 4.4482216152605, "lbf": 1e-3},
    "time": {"s": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0},
}

_ALIASES: dict[str, str] = {
    "g": "g", "gn": "g", "g0": "g", "gs": "g",
    "m/s^2": "m/s^2", "m/s2": "m/s^2", "m/s²": "m/s^2", "ms-2": "m/s^2", "m.s-2": "m/s^2",
    "m s-2": "m/s^2", "m/s/s": "m/s^2", "mps2": "m/s^2", "ms2": "m/s^2", "m/sec2": "m/s^2",
    "gpm": "gal/min", "gal/min": "gal/min", "usgpm": "gal/min", "galus/min": "gal/min",
    "l/min": "L/min", "lpm": "L/min", "lit/min": "L/min", "l/m": "L/min",
    "m3/min": "m3/min", "m³/min": "m3/min",
    "klbf": "klbf", "klb": "klbf", "kips": "klbf", "kip": "klbf", "klbs": "klbf",
    "1000lbf": "klbf", "1000 lbf": "klbf", "kn": "kN", "lbf": "lbf", "lbs": "lbf",
    "s": "s", "sec": "s", "secs": "s", "second": "s", "seconds": "s",
    "ms": "ms", "msec": "ms", "millisecond": "ms", "milliseconds": "ms",
    "min": "min", "minute": "min", "minutes": "min", "h": "h", "hr": "h", "hour": "h",
}

_BRACKET_RE = re.compile(r"^(.*?)\s*[\[(]\s*([^\[\]()]{1,20})\s*[\])]\s*$")


def canonical_unit(text: str | None, quantity: str) -> str | None:
    """The canonical spelling of a unit of ``quantity`` (``"m/s2"`` -> ``"m/s^2"``), or None
    when ``text`` is not one of that quantity's units."""
    if text is None:
        return None
    unit = _ALIASES.get(str(text).strip().lower())
    return unit if unit in QUANTITIES[quantity] else None


def unit_factor(unit: str, quantity: str) -> float:
    """Factor from ``unit`` (canonical) to the campaign's unit of ``quantity``."""
    return QUANTITIES[quantity][unit]


def split_unit(name: str, quantity: str) -> tuple[str, str | None]:
    """A column name without the unit it carries, and that unit (canonical) or None.

    ``"AccZ [m/s^2]"`` and ``"AccZ (m/s2)"`` -> ``("AccZ", "m/s^2")``; ``"flow_gpm"`` ->
    ``("flow", "gal/min")``; a suffix after the last ``_`` counts only when it is a unit of
    ``quantity``.
    """
    match = _BRACKET_RE.match(name)
    if match:
        unit = canonical_unit(match.group(2), quantity)
        if unit is not None:
            return match.group(1), unit
    stem, sep, suffix = name.rpartition("_")
    if sep and stem:
        unit = canonical_unit(suffix, quantity)
        if unit is not None:
            return stem, unit
    return name, None


@dataclass
class Table:
    """A file opened for an import: its column names and the unit the file states for each.

    ``read(names)`` returns those columns as arrays (numbers, or ``datetime64`` for a time
    column of dates); ``where`` names the file in errors; ``index_column`` is the column
    the format makes the index (a LAS file's first curve), the default time column.
    """

    path: Path
    format: str
    columns: list[str]
    units: dict[str, str] = field(default_factory=dict)
    reader: Callable[[list[str]], dict[str, np.ndarray]] | None = field(default=None,
                                                                         repr=False)
    index_column: str | None = None

    @property
    def where(self) -> str:
        """The file as errors name it."""
        return str(self.path)

    def listing(self) -> str:
        """The columns that exist, for an error message."""
        shown = ", ".join(repr(c) for c in self.columns[:40])
        more = f" and {len(self.columns) - 40} more" if len(self.columns) > 40 else ""
        return shown + more

    def read(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        """The named columns, each a one-dimensional array of the file's rows."""
        assert self.reader is not None
        return self.reader(list(names))


def _optional(module: str, package: str, what: str, path: Path) -> Any:
    """Import an optional reader, or a CampaignError naming the package to install."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise CampaignError(f"{path}: reading {what} needs the Python package {package!r}, "
                            f"which is not installed: pip install {package} (or pip install "
                            f"'vadsim[io]' for every format)") from None


def _check_size(path: Path) -> int:
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise CampaignError(f"{path}: no such file") from None
    except OSError as exc:
        raise CampaignError(f"{path}: cannot read: {exc.strerror or exc}") from None
    if not path.is_file():
        raise CampaignError(f"{path}: not a regular file")
    if size > MAX_FILE_BYTES:
        raise CampaignError(f"{path}: {size / 1024**3:.2f} GiB is larger than the import's "
                            f"limit of {MAX_FILE_BYTES / 1024**3:.0f} GiB per file "
                            f"(vadsim.campaigns.sources.MAX_FILE_BYTES); split the record "
                            f"into several files and give them all")
    if size == 0:
        raise CampaignError(f"{path}: empty file")
    return size


def _check_lines(path: Path) -> None:
    """Every line of a text file within MAX_LINE_CHARS, checked in chunks before parsing."""
    longest = run = 0
    with path.open("rb") as fh:
        while chunk := fh.read(1 << 24):
            ends = np.flatnonzero(np.frombuffer(chunk, dtype=np.uint8) == 10)
            if ends.size == 0:
                run += len(chunk)
            else:
                longest = max(longest, run + int(ends[0]) + 1,
                              int(np.max(np.diff(ends), initial=0)))
                run = len(chunk) - int(ends[-1]) - 1
            longest = max(longest, run)
            if longest > MAX_LINE_CHARS:
                raise CampaignError(f"{path}: a line is longer than the import's limit of "
                                    f"{MAX_LINE_CHARS} characters "
                                    f"(vadsim.campaigns.sources.MAX_LINE_CHARS): not a "
                                    f"table of one row per line")


def open_table(path: str | Path, *, sheet: str | int | None = None,
               key: str | None = None) -> Table:
    """Open a file by its suffix: ``.csv``/``.txt``/``.tsv``, ``.parquet``/``.pq``,
    ``.h5``/``.hdf5``/``.hdf``, ``.xlsx``/``.xlsm``, ``.las``.

    Parameters
    ----------
    path
        The file.
    sheet
        Excel: the sheet (name or index; default the first).
    key
        HDF5: the group or dataset holding the columns (default the file's root).

    Raises
    ------
    CampaignError
        Naming the file: too large, lines too long, an unknown suffix, a missing reader
        package, or a file the reader cannot parse.
    """
    path = Path(path)
    _check_size(path)
    suffix = path.suffix.lower()
    openers: dict[str, Callable[[Path], Table]] = {
        ".csv": _csv_table, ".txt": _csv_table, ".tsv": _csv_table, ".dat": _csv_table,
        ".parquet": _parquet_table, ".pq": _parquet_table,
        ".h5": lambda p: _hdf5_table(p, key), ".hdf5": lambda p: _hdf5_table(p, key),
        ".hdf": lambda p: _hdf5_table(p, key),
        ".xlsx": lambda p: _excel_table(p, sheet), ".xlsm": lambda p: _excel_table(p, sheet),
        ".las": _las_table,
    }
    if suffix not in openers:
        raise CampaignError(f"{path}: unknown file type {excerpt(suffix or 'without suffix')};"
                            f" an import reads {', '.join(sorted(openers))}")
    table = openers[suffix](path)
    if len(table.columns) > MAX_COLUMNS:
        raise CampaignError(f"{path}: {len(table.columns)} columns, more than the import's "
                            f"limit of {MAX_COLUMNS} (vadsim.campaigns.sources.MAX_COLUMNS)")
    return table


# --------------------------------------------------------------------------------------------
# CSV


def _csv_header(path: Path) -> tuple[int, str, list[str]]:
    """Lines to skip (leading ``#`` comments, blank lines), the separator and the names."""
    skip = 0
    with path.open("rb") as fh:
        for raw in fh:
            try:
                line = raw.decode("utf-8-sig").strip()
            except UnicodeDecodeError:
                raise CampaignError(f"{path}, line {skip + 1}: not UTF-8 text (is it a "
                                    f"binary file with a .csv name?)") from None
            if line and not line.startswith("#"):
                break
            skip += 1
        else:
            raise CampaignError(f"{path}: no header line (only comments or blank lines)")
    seps = {s: line.count(s) for s in (",", ";", "\t")}
    sep = max(seps, key=lambda s: seps[s])
    names = [n.strip().strip('"') for n in line.split(sep)] if seps[sep] else [line]
    for j, n in enumerate(names):
        if not n:
            raise CampaignError(f"{path}, line {skip + 1}: column {j + 1} has no name")
        if n in names[:j]:
            raise CampaignError(f"{path}, line {skip + 1}: column {excerpt(n)} appears twice")
    return skip, sep, names


def _csv_table(path: Path) -> Table:
    _check_lines(path)
    skip, sep, names = _csv_header(path)

    def read(wanted: list[str]) -> dict[str, np.ndarray]:
        try:
            frame = pd.read_csv(path, sep=sep, skiprows=skip, usecols=wanted, engine="c",
                                encoding="utf-8-sig", skipinitialspace=True)
        except (ValueError, pd.errors.ParserError, UnicodeDecodeError) as exc:
            raise CampaignError(f"{path}: cannot read as a table: {excerpt(str(exc))}") from None
        frame.columns = [str(c).strip().strip('"') for c in frame.columns]
        return {c: _column_values(frame[c], path, c, first_line=skip + 2) for c in wanted}

    return Table(path, "CSV", names, {}, read)


def _column_values(series: pd.Series, path: Path, column: str, first_line: int) -> np.ndarray:
    """A column as floats (or datetime64 for dates), refusing text and gaps with the line."""
    if pd.api.types.is_datetime64_any_dtype(series):
        return series.to_numpy()
    if series.dtype == object:
        numbers = pd.to_numeric(series, errors="coerce")
        if numbers.isna().all() and series.notna().any():
            dates = pd.to_datetime(series, errors="coerce", format="mixed")
            if dates.notna().all():
                return dates.to_numpy()
        series = numbers
    values = series.to_numpy(dtype=np.float64, na_value=np.nan)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        row = int(bad[0])
        at = f"line {first_line + row}" if first_line else f"row {row}"
        raise CampaignError(f"{path}, {at}: column {excerpt(column)}: missing or non-numeric "
                            f"value")
    return values


# --------------------------------------------------------------------------------------------
# Parquet, HDF5, Excel, LAS


def _frame_reader(frame_of: Callable[[list[str]], pd.DataFrame], path: Path,
                  first_line: int = 1) -> Callable[[list[str]], dict[str, np.ndarray]]:
    def read(wanted: list[str]) -> dict[str, np.ndarray]:
        frame = frame_of(wanted)
        return {c: _column_values(frame[c], path, c, first_line) for c in wanted}
    return read


def _parquet_table(path: Path) -> Table:
    pq = _optional("pyarrow.parquet", "pyarrow", "Parquet files", path)
    try:
        schema = pq.read_schema(path)
    except Exception as exc:  # pyarrow raises its own error types for a damaged file
        raise CampaignError(f"{path}: cannot read as Parquet: {excerpt(str(exc))}") from None
    units = {}
    for f in schema:
        meta = {k.decode(errors="replace"): v.decode(errors="replace")
                for k, v in (f.metadata or {}).items()}
        unit = meta.get("units") or meta.get("unit")
        if unit:
            units[f.name] = unit
    return Table(path, "Parquet", list(schema.names), units,
                 _frame_reader(lambda cols: pq.read_table(path, columns=cols).to_pandas(),
                               path, first_line=0))


def _hdf5_table(path: Path, key: str | None) -> Table:
    h5py = _optional("h5py", "h5py", "HDF5 files", path)
    try:
        with h5py.File(path, "r") as fh:
            node = fh[key] if key else fh
            if isinstance(node, h5py.Group) and ("pandas_type" in node.attrs
                                                 or any("pandas_type" in fh[k].attrs
                                                        for k in node if
                                                        isinstance(fh[k], h5py.Group))):
                return _pandas_hdf_table(path, key, fh)
            columns, units = _h5_columns(h5py, node)
    except (OSError, KeyError) as exc:
        raise CampaignError(f"{path}: cannot read as HDF5{f' (key {key!r})' if key else ''}: "
                            f"{excerpt(str(exc))}") from None

    def frame(cols: list[str]) -> pd.DataFrame:
        with h5py.File(path, "r") as fh:
            node = fh[key] if key else fh
            return pd.DataFrame({c: _h5_read(h5py, node, c) for c in cols})

    return Table(path, "HDF5", columns, units, _frame_reader(frame, path, first_line=0))


def _h5_columns(h5py: Any, node: Any) -> tuple[list[str], dict[str, str]]:
    """1-D datasets (by their path under ``node``) and the fields of table datasets."""
    columns: list[str] = []
    units: dict[str, str] = {}

    def visit(name: str, obj: Any) -> None:
        if not isinstance(obj, h5py.Dataset):
            return
        unit = obj.attrs.get("units", obj.attrs.get("unit"))
        if obj.dtype.names:
            columns.extend(obj.dtype.names)
        elif obj.ndim == 1:
            columns.append(name)
            if unit is not None:
                units[name] = unit.decode() if isinstance(unit, bytes) else str(unit)

    if isinstance(node, h5py.Dataset):
        visit(node.name.rsplit("/", 1)[-1], node)
    else:
        node.visititems(visit)
    return columns, units


def _h5_read(h5py: Any, node: Any, column: str) -> np.ndarray:
    if isinstance(node, h5py.Dataset):
        return np.asarray(node[column] if node.dtype.names else node[()])
    if column in node:
        return np.asarray(node[column][()])
    for item in node.values():
        if isinstance(item, h5py.Dataset) and item.dtype.names and column in item.dtype.names:
            return np.asarray(item[column])
    raise KeyError(column)


def _pandas_hdf_table(path: Path, key: str | None, fh: Any) -> Table:
    """An HDF5 file written by pandas (``DataFrame.to_hdf``): read with pandas (PyTables)."""
    _optional("tables", "tables", "HDF5 files written by pandas", path)
    keys = [key] if key else [k for k in fh if "pandas_type" in fh[k].attrs]
    if not keys:
        raise CampaignError(f"{path}: no pandas table found")
    if len(keys) > 1:
        raise CampaignError(f"{path}: holds several tables ({', '.join(keys)}); name one "
                            f"with key= (--key on the command line)")
    frame = pd.read_hdf(path, keys[0])
    if not isinstance(frame, pd.DataFrame):
        raise CampaignError(f"{path}: key {keys[0]!r} is not a table")
    frame = frame.reset_index() if frame.index.name else frame
    return Table(path, "HDF5 (pandas)", [str(c) for c in frame.columns], {},
                 _frame_reader(lambda cols: frame, path, first_line=0))


def _excel_table(path: Path, sheet: str | int | None) -> Table:
    _optional("openpyxl", "openpyxl", "Excel files", path)
    try:
        frame = pd.read_excel(path, sheet_name=0 if sheet is None else sheet,
                              engine="openpyxl")
    except Exception as exc:  # openpyxl and zipfile raise many types for a bad file
        raise CampaignError(f"{path}: cannot read as Excel: {excerpt(str(exc))}") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    return Table(path, "Excel", list(frame.columns), {},
                 _frame_reader(lambda cols: frame, path, first_line=2))


def _las_table(path: Path) -> Table:
    lasio = _optional("lasio", "lasio", "LAS files", path)
    _check_lines(path)
    try:
        las = lasio.read(str(path), ignore_header_errors=False)
    except Exception as exc:  # lasio raises many types on a malformed file
        raise CampaignError(f"{path}: cannot read as LAS 2.0: {excerpt(str(exc))}") from None
    names = [c.mnemonic for c in las.curves]
    units = {c.mnemonic: c.unit for c in las.curves if c.unit}
    data = {c.mnemonic: np.asarray(c.data, dtype=np.float64) for c in las.curves}

    def frame(cols: list[str]) -> pd.DataFrame:  # lasio has turned NULL values into NaN
        return pd.DataFrame({c: data[c] for c in cols})

    return Table(path, "LAS", names, units, _frame_reader(frame, path, first_line=0),
                 index_column=names[0] if names else None)
