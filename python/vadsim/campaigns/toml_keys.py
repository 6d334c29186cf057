"""Where a key of a campaign.toml sits, and the error that names it: :class:`TomlContext`.

Why this module exists: :mod:`tomllib` returns plain dicts without positions, yet a line
number is what a person editing the file needs. A :class:`TomlContext` scans the table
headers once and turns a failed check on a key path (``("events", 3, "flow_gpm")``) into a
:class:`~vadsim.campaigns.format.CampaignError` naming the file, the line and the key. The
campaign's rules themselves are checked in :mod:`vadsim.campaigns.reading`.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import NoReturn

from vadsim.campaigns.format import EXCERPT_CHARS, CampaignError, excerpt

__all__ = ["BARE_KEY_RE", "TomlContext"]

BARE_KEY_RE = re.compile(r"[A-Za-z0-9_-]+")
"""TOML's bare-key alphabet. Sensor names become CSV column prefixes and TOML keys; restricting
them to it keeps both unambiguous without quoting rules (an error message shows such a key
unquoted)."""

# --------------------------------------------------------------------------------------------
# TOML key -> line lookup. tomllib returns plain dicts without positions, yet a line number is
# what a person editing the file needs; a light scan of table headers recovers it for the
# usual layout ([sensors.x], [[events]]) and gives up (key only) on anything fancier.


def _table_header(line: str) -> tuple[str, str] | None:
    """``("array", name)`` for a ``[[name]]`` line, ``("table", name)`` for ``[name]``, else
    None; the name with blanks around dots and quotes removed (``sensors.x1``).

    Plain string scanning, linear in the line: the regular expressions this replaces took
    quadratic time on a long run of blanks inside a header.
    """
    text = line.strip()
    kind, opening, closing = (("array", "[[", "]]") if text.startswith("[[")
                              else ("table", "[", "]"))
    if not text.startswith(opening):
        return None
    end = text.find("]", len(opening))
    if end < 0 or not text.startswith(closing, end):
        return None
    name = text[len(opening):end]
    rest = text[end + len(closing):].lstrip()
    if "[" in name or not name.strip() or (rest and not rest.startswith("#")):
        return None
    parts = (part.strip() for part in name.strip().split("."))
    return kind, ".".join(parts).replace('"', "").replace("'", "")


class _TomlLines:
    def __init__(self, text: str) -> None:
        self.lines = text.split("\n")
        # (first line number, kind, normalised name); line numbers are 1-based.
        self.headers: list[tuple[int, str, str]] = []
        for i, line in enumerate(self.lines, start=1):
            header = _table_header(line)
            if header is not None:
                self.headers.append((i, *header))

    def _segment(self, kind: str, name: str, nth: int = 0) -> tuple[int, int] | None:
        seen = 0
        for j, (line, k, n) in enumerate(self.headers):
            if k == kind and n == name:
                if seen == nth:
                    end = self.headers[j + 1][0] if j + 1 < len(self.headers) else len(
                        self.lines) + 1
                    return line, end
                seen += 1
        return None

    def _key_line(self, start: int, end: int, key: str) -> int | None:
        k = re.escape(key)
        pat = re.compile(rf"\s*(?:{k}|\"{k}\"|'{k}')\s*=")
        for i in range(start, min(end, len(self.lines) + 1)):
            if pat.match(self.lines[i - 1]):
                return i
        return None

    def line_of(self, path: tuple[str | int, ...]) -> int | None:
        """Best-effort 1-based line of a key path, or None."""
        if not path:
            return None
        head = path[0]
        if head == "events" and len(path) >= 2 and isinstance(path[1], int):
            seg = self._segment("array", "events", path[1])
            rest = path[2:]
        elif head == "sensors" and len(path) >= 2 and isinstance(path[1], str):
            seg = self._segment("table", f"sensors.{path[1]}")
            rest = path[2:]
        else:
            first = self.headers[0][0] if self.headers else len(self.lines) + 1
            seg = (0, first)
            rest = path
            if head == "sensors":
                table = self._segment("table", "sensors")
                if table is not None:
                    return table[0]
                sub = [line for line, _, n in self.headers if n.startswith("sensors.")]
                if sub:
                    return sub[0]
        if seg is None:
            return None
        start, end = seg
        if rest and isinstance(rest[0], str):
            line = self._key_line(start + 1 if start else 1, end, rest[0])
            if line is not None:
                return line
        return start or None


def _format_key(path: tuple[str | int, ...]) -> str:
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            bare = len(part) <= EXCERPT_CHARS and BARE_KEY_RE.fullmatch(part)
            text = part if bare else excerpt(part)
            out += f".{text}" if out else text
    return out


class TomlContext:
    """Formats key errors for one campaign.toml (file + best-effort line + key path).

    Parameters
    ----------
    file
        What each error names first: the file, or a description of a campaign being written.
    text
        The file's text, scanned for the lines of its keys; None: errors name the key only.
    """

    def __init__(self, file: Path | str, text: str | None) -> None:
        self.file = str(file)
        self.lines = _TomlLines(text) if text is not None else None

    def fail(self, path: tuple[str | int, ...], problem: str, label: str = "") -> NoReturn:
        """Raise a :class:`~vadsim.campaigns.format.CampaignError` saying ``problem`` at the
        key ``path``, with the key's line where the scan finds it; ``label`` (such as
        ``" (event e03)"``) follows the key."""
        line = self.lines.line_of(path) if self.lines is not None else None
        where = f"{self.file}, line {line}" if line else self.file
        raise CampaignError(f"{where}: key {_format_key(path)}{label}: {problem}")
