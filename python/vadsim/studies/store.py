"""The resumable store of a sweep: chunks of finished rows that verify themselves, and claims
that let several processes share one store.

A sweep interrupted at any moment (Ctrl-C, kill -9) and called again with the same arguments
and store resumes where it stopped; several processes given the same store share its chunks.
Every chunk is verified when read (its grid's hash, a checksum of its rows, every row's
features); a bad one is recomputed with a :class:`StoreWarning`. A chunk being computed is
claimed by a file naming its owner (host, process id and the process' start), refreshed
while it runs: a claim left by a dead process, or not refreshed for :data:`CLAIM_STALE_S`,
is taken over.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import socket
import tempfile
import time
import uuid
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vadsim.studies.rows import FEATURES, STORE_FORMAT, TEXT_FEATURES

if TYPE_CHECKING:
    from vadsim.studies.grid import Chunk, Grid

__all__ = ["CLAIM_STALE_S", "CLAIM_WRITE_GRACE_S", "DEBRIS_AGE_S", "BadChunk", "Store",
           "StoreWarning", "atomic_write_text", "process_start", "read_json", "verify_chunk"]



DEBRIS_AGE_S = 5.0
"""Age (s) after which a private claim file without an owner record is debris
(:meth:`Store.clear_debris`)."""

CLAIM_STALE_S = 600.0
"""A claim not refreshed for this long (s) is taken over, whoever holds it. A live process
refreshes its claims every few seconds, so only a dead or frozen one reaches this age."""


CLAIM_WRITE_GRACE_S = 30.0
"""No longer waited for: a claim is hard-linked into place only once its owner record is
written, so a claim without a valid record (empty, garbage) is taken over at once. Kept for
code that reads it."""


_HEARTBEAT_S = 5.0


class StoreWarning(UserWarning):
    """Something in a sweep's store did not verify and was recomputed (or was taken over)."""


class BadChunk(Exception):
    """A chunk file that does not verify (the message says why); it is recomputed."""


def _rows_text(rows: Any) -> str:
    return json.dumps(rows, sort_keys=True, default=float)


def _checksum(rows: Any) -> str:
    return "sha256:" + hashlib.sha256(_rows_text(rows).encode()).hexdigest()


def _row_problem(row: Any) -> str | None:
    """Why ``row`` is not a row of features (None: it is one)."""
    if not isinstance(row, dict):
        return f"is {type(row).__name__}, not a mapping"
    missing = [k for k in FEATURES if k not in row]
    if missing:
        return f"lacks {', '.join(missing)}"
    unknown = sorted(set(row) - set(FEATURES))
    if unknown:
        return f"has unknown keys {', '.join(unknown)}"
    for name, value in row.items():
        text = name in TEXT_FEATURES
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if (text and not isinstance(value, str)) or (not text and not number):
            return f"has {name} = {value!r}"
    return None


def verify_chunk(text: str, chunk: Chunk, grid_hash: str, where: str) -> list[dict[str, Any]]:
    """The rows of a chunk file, or :class:`BadChunk`; ValueError if it is another grid's."""
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise BadChunk(f"is not readable JSON ({exc})") from None
    if not isinstance(doc, dict) or "grid" not in doc or "checksum" not in doc:
        raise BadChunk("carries no grid hash or checksum (an older vadsim's chunk, or none)")
    if not (isinstance(doc["grid"], str) and len(doc["grid"]) == len(grid_hash)
            and all(c in "0123456789abcdef" for c in doc["grid"])):
        raise BadChunk(f"carries a damaged grid hash {str(doc['grid'])[:20]!r}")
    if doc["grid"] != grid_hash:
        raise ValueError(
            f"{where}: {chunk.key}.json belongs to grid {str(doc['grid'])[:16]}, but grid.json "
            f"describes grid {grid_hash[:16]}: grid.json was replaced after chunks were "
            "written, so the store cannot be trusted; use another folder or delete it")
    rows = doc.get("rows")
    if not isinstance(rows, list) or doc["checksum"] != _checksum(rows):
        raise BadChunk("does not match its checksum (changed or damaged after it was written)")
    for name, expected in chunk.header(grid_hash).items():
        if doc.get(name) != expected:
            raise BadChunk(f"holds {name} {doc.get(name)!r}, expected {expected!r}")
    if len(rows) != len(chunk.spec.flows):
        raise BadChunk(f"has {len(rows)} rows for {len(chunk.spec.flows)} flows")
    for j, row in enumerate(rows):
        problem = _row_problem(row)
        if problem:
            raise BadChunk(f"row {j} {problem}")
    return rows


def atomic_write_text(path: Path, text: str, *, replace: bool = True) -> None:
    """Write ``text`` to ``path`` all at once: to a temporary file, then renamed into place (or,
    with ``replace=False``, linked: FileExistsError if ``path`` exists)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        if replace:
            os.replace(tmp, path)
        else:
            os.link(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)


def read_json(path: Path) -> Any:
    """The JSON in ``path``; None if missing, unreadable or not JSON."""
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        return None


def _owner_record(holder: Mapping[str, Any]) -> bool:
    """Whether a claim's content is an owner record: a positive PID, a host and a token (the
    start is optional: claims of vadsim before 0.2 have none)."""
    pid = holder.get("pid")
    return (isinstance(pid, int) and not isinstance(pid, bool) and pid > 0
            and isinstance(holder.get("host"), str) and isinstance(holder.get("token"), str)
            and isinstance(holder.get("start", ""), (str, type(None))))


def process_start(pid: int) -> str | None:
    """When process ``pid`` started, as ``"<boot id>:<start tick>"`` (Linux's /proc), or None
    where that cannot be read. Two processes with one PID on one host differ in it: a claim
    records it so that a reused PID is not taken for the claimant."""
    try:
        stat_text = Path(f"/proc/{pid}/stat").read_text()
        boot = Path("/proc/sys/kernel/random/boot_id").read_text().strip()
    except (OSError, ValueError):
        return None
    fields = stat_text.rsplit(")", 1)[-1].split()
    return f"{boot}:{fields[19]}" if len(fields) > 19 else None


def _pid_alive(pid: Any) -> bool:
    if not isinstance(pid, int) or isinstance(pid, bool) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: alive, someone else's
        return True
    return True


def _differences(old: Mapping[str, Any], new: Mapping[str, Any], prefix: str = "") -> list[str]:
    """The fields where two grid documents differ, e.g. ``settings.cycles 20.0 -> 30.0``."""
    out = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k), new.get(k)
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            out += _differences(a, b, f"{prefix}{k}.")
        elif a != b:
            short = not isinstance(a, list) and not isinstance(b, list)
            out.append(f"{prefix}{k} {a!r} -> {b!r}" if short else f"{prefix}{k} differ")
    return out


class Store:
    """A folder of finished chunks of one grid (``grid.json``) that verifies what it reads and
    shares the work with other processes through claim files."""

    def __init__(self, path: Path, grid: Grid) -> None:
        self.path = path
        self.grid = grid
        self.where = f"store {path}"
        self.host = socket.gethostname()
        self._held: dict[str, str] = {}  # chunk key -> token of this process's claim
        self._bad: dict[str, tuple[int, int]] = {}  # chunk key -> (mtime, size) found bad
        self._beat = time.monotonic()

    @classmethod
    def open(cls, path: str | os.PathLike[str], grid: Grid) -> Store:
        """The store at ``path`` for ``grid``; ValueError if it holds another or an unknown
        grid."""
        store = cls(Path(path), grid)
        store.path.mkdir(parents=True, exist_ok=True)
        store._check_grid_file()
        return store

    def _chunk_files(self) -> list[Path]:
        return sorted(self.path.glob("chunk-*.json"))

    def _check_grid_file(self) -> None:
        spec = self.path / "grid.json"
        if not spec.exists():
            if self._chunk_files() and not spec.exists():  # (re-checked: a racing creator)
                raise ValueError(
                    f"{self.where} has chunk files but no grid.json: nothing says which grid "
                    "they belong to, so they cannot be trusted; use another folder or delete it")
            with contextlib.suppress(FileExistsError):  # another process was first: compare
                atomic_write_text(spec, self.grid.text, replace=False)
        try:
            current = spec.read_text()
        except (OSError, UnicodeDecodeError):
            current = None
        if current != self.grid.text:
            raise ValueError(self._grid_mismatch(current))

    def _grid_mismatch(self, current: str | None) -> str:
        fix = "use another folder or delete it"
        try:
            old = json.loads(current or "")
        except ValueError:
            old = None
        if not isinstance(old, dict):
            return f"{self.where}: grid.json is unreadable, so its chunks cannot be verified; {fix}"
        if old.get("format") != STORE_FORMAT:
            fmt = old.get("format", old.get("version"))
            return (f"{self.where} holds a different grid, in store format {fmt} (an older "
                    f"vadsim's, whose chunks carry no checksums); {fix}")
        diff = _differences(old, self.grid.document)
        what = "; ".join(diff[:6]) + (" ..." if len(diff) > 6 else "") or "same fields"
        return f"{self.where} holds a different grid ({what}); {fix}"

    def load(self, chunks: Sequence[Chunk], *, strays_too: bool = True
             ) -> dict[str, list[dict[str, Any]]]:
        """The verified rows of every chunk the store holds (bad ones reported, left out);
        files of no chunk given are reported unless ``strays_too`` is False (an adaptive map
        loads one level at a time)."""
        known = {c.key for c in chunks}
        strays = ([f.name for f in self._chunk_files() if f.stem not in known]
                  if strays_too else [])
        if strays:
            warnings.warn(f"{self.where}: ignored {len(strays)} file(s) that are no chunk of "
                          f"this grid: {', '.join(strays[:3])}", StoreWarning, stacklevel=3)
        self.clear_debris()
        done = {}
        for chunk in chunks:
            rows = self.read(chunk)
            if rows is not None:
                done[chunk.key] = rows
                self.drop_stale_claim(chunk)
        return done

    def read(self, chunk: Chunk) -> list[dict[str, Any]] | None:
        """The chunk's rows if its file exists and verifies, else None (a bad file is reported
        once, with a :class:`StoreWarning`)."""
        path = self.path / f"{chunk.key}.json"
        try:
            st = path.stat()
        except FileNotFoundError:
            return None
        stamp = (st.st_mtime_ns, st.st_size)
        if self._bad.get(chunk.key) == stamp:
            return None
        try:
            text = path.read_text()
        except FileNotFoundError:
            return None
        except (OSError, UnicodeDecodeError):
            text = ""
        try:
            return verify_chunk(text, chunk, self.grid.hash, self.where)
        except BadChunk as exc:
            self._bad[chunk.key] = stamp
            warnings.warn(f"{self.where}: {chunk.key}.json {exc}; recomputing it", StoreWarning,
                          stacklevel=4)
            return None

    def write(self, chunk: Chunk, rows: list[dict[str, Any]]) -> None:
        doc = {**chunk.header(self.grid.hash), "rows": rows, "checksum": _checksum(rows)}
        atomic_write_text(self.path / f"{chunk.key}.json", json.dumps(doc, default=float))
        self._bad.pop(chunk.key, None)

    # claims

    def _claim_path(self, key: str) -> Path:
        return self.path / f"{key}.claim"

    def claim(self, chunk: Chunk) -> bool:
        """Claim ``chunk`` for this process (True), or find it held by a live one (False).

        The owner record is written to a private file first and hard-linked into place, so a
        claim never exists without its owner; and the claim is registered as held before it
        exists, so a Ctrl-C at any moment leaves none that :meth:`release_all` does not
        remove (under load, one landed between creating an empty claim and writing it)."""
        path = self._claim_path(chunk.key)
        for _ in range(2):
            token = uuid.uuid4().hex
            record = path.with_name(f"{path.name}.new-{token}")
            try:
                record.write_text(json.dumps({"pid": os.getpid(), "host": self.host,
                                              "start": process_start(os.getpid()),
                                              "time": time.time(), "token": token}))
                self._held[chunk.key] = token
                try:
                    os.link(record, path)
                except FileExistsError:
                    self._held.pop(chunk.key, None)
                    if not self._take_over_if_stale(path, chunk):
                        return False
                    continue
            finally:
                record.unlink(missing_ok=True)
            return True
        return False

    def _stale(self, path: Path) -> tuple[dict[str, Any], str] | None:
        """The holder of the claim at ``path`` and why it is stale; None if live or gone."""
        holder = read_json(path)
        try:
            age = time.time() - path.stat().st_mtime
        except FileNotFoundError:
            return None
        holder = holder if isinstance(holder, dict) else {}
        if age > CLAIM_STALE_S:
            return holder, f"no sign of life for {age:.0f} s"
        if not _owner_record(holder):
            # a claim is linked into place only once its record is written: one without a
            # valid record was never a live claimant's (an older vadsim's claim left empty by
            # a kill, or garbage), whatever its age
            return holder, "holds no owner record (its process ended while writing it)"
        if holder.get("host") == self.host:
            pid = holder["pid"]
            if not _pid_alive(pid):
                return holder, f"process {pid} on this host has ended"
            start = holder.get("start")
            if start is not None and start != process_start(pid):
                return holder, (f"process {pid} on this host is another process than the "
                                f"claimant (its PID was reused: started {process_start(pid)}, "
                                f"the claimant {start})")
        return None

    @staticmethod
    def _remove(path: Path, holder: dict[str, Any]) -> bool:
        """Remove the claim at ``path`` if it still is ``holder``'s (a fresh claim that replaced
        it meanwhile is put back); True if removed."""
        aside = path.with_name(f"{path.name}.stale-{uuid.uuid4().hex}")
        try:
            os.rename(path, aside)
        except FileNotFoundError:
            return False
        moved = read_json(aside)
        if (moved if isinstance(moved, dict) else {}) != holder:
            with contextlib.suppress(OSError):
                os.link(aside, path)
            aside.unlink(missing_ok=True)
            return False
        aside.unlink(missing_ok=True)
        return True

    def _take_over_if_stale(self, path: Path, chunk: Chunk) -> bool:
        """Remove the claim at ``path`` if its holder is gone; True if it is gone now."""
        stale = self._stale(path)
        if stale is None or not self._remove(path, stale[0]):
            return not path.exists()
        warnings.warn(f"{self.where}: took over the claim of {chunk.key} ({stale[1]})",
                      StoreWarning, stacklevel=5)
        return True

    def clear_debris(self) -> None:
        """Remove the private files of claiming that a process killed between two file
        operations leaves: an owner record not yet linked into place (``*.claim.new-*``) or
        a claim set aside for removal (``*.claim.stale-*``), where its owner is gone
        (:meth:`_stale`). One without an owner record is removed once it is
        :data:`DEBRIS_AGE_S` old: a live process keeps such a file for microseconds, between
        writing it and linking or removing it. Measured: a kill -9 in a resume test left
        ``chunk-1-8.claim.new-...`` behind."""
        for pattern in ("*.claim.new-*", "*.claim.stale-*"):
            for path in self.path.glob(pattern):
                stale = self._stale(path)
                if stale is None:
                    continue
                if not _owner_record(stale[0]):
                    try:
                        if time.time() - path.stat().st_mtime < DEBRIS_AGE_S:
                            continue
                    except FileNotFoundError:
                        continue
                path.unlink(missing_ok=True)

    def drop_stale_claim(self, chunk: Chunk) -> None:
        """Remove a dead holder's claim of a chunk that is finished (it was killed between
        writing the chunk and releasing the claim): nothing to take over, nothing to report."""
        path = self._claim_path(chunk.key)
        stale = self._stale(path) if path.exists() else None
        if stale is not None:
            self._remove(path, stale[0])

    def release(self, key: str) -> None:
        """Remove this process's claim of chunk ``key`` (if it still is this process's)."""
        token = self._held.pop(key, None)
        path = self._claim_path(key)
        holder = read_json(path)
        if token is not None and isinstance(holder, dict) and holder.get("token") == token:
            path.unlink(missing_ok=True)

    def release_all(self) -> None:
        for key in list(self._held):
            self.release(key)

    def heartbeat(self) -> None:
        """Refresh this process's claims (so that they never look stale while it lives)."""
        now = time.monotonic()
        if now - self._beat < _HEARTBEAT_S:
            return
        self._beat = now
        for key in self._held:
            with contextlib.suppress(OSError):
                os.utime(self._claim_path(key))
