"""A folder of results keyed by everything that decided them, the code included.

Why this module exists: a diagnosis, a calibration and a validation of one campaign run the
same model at the same operating points again and again -- a second diagnosis with one more
candidate repeats every run of the first, and the README, the gallery and the tests diagnose
one campaign three times. A :class:`ResultCache` keeps each result under a key made of its
inputs and a fingerprint of the code that computed it (every source file of the installed
package and the compiled core), so a hit is the value a fresh computation would give, bit for
bit, and any change to the code or the inputs is a miss.

Values are JSON (numbers written exactly, ``repr`` round-trips a float), compressed, with a
checksum: a folder is never a way to run code (no pickle), and a damaged or foreign file is a
miss, removed, never a wrong result. The folder itself is not trusted either: an entry is read
only as a regular file inside it (a link, a folder, a device or a pipe in its place is a miss),
with a size cap on disk and inflated (:data:`MAX_ENTRY_BYTES`), and checked against the
reader's schema after its checksum (``get(key, parse=...)``); whatever fails is removed.

Opt-in: pass a folder (``cache=`` in :func:`vadsim.fit.diagnosis.diagnose`, ``--cache DIR`` on
the CLI) or set ``VADSIM_CACHE=DIR``. The folder may be deleted at any time.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import json
import math
import os
import shutil
import stat
import tempfile
import threading
import warnings
import zlib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["ENV_VAR", "MAX_ENTRY_BYTES", "CacheWarning", "ResultCache", "Uncacheable",
           "canonical", "code_fingerprint", "default_cache"]

ENV_VAR = "VADSIM_CACHE"
"""Environment variable naming the cache folder used when none is passed."""

_MAGIC = b"vadsim-cache-1\n"

MAX_ENTRY_BYTES = 64 << 20
"""Largest cache entry read, on disk and inflated (bytes); an event's measured run is a few kB."""


class CacheWarning(UserWarning):
    """A result could not be stored in the cache (it is computed again next time)."""


def _read_entry(path: Path) -> bytes:
    """An entry's bytes: a regular file (links are not followed, a FIFO is not waited on) in a
    shard folder that is no link, of at most :data:`MAX_ENTRY_BYTES`; else OSError or
    ValueError. FileNotFoundError only when there is no entry at all."""
    if path.parent.is_symlink():
        raise ValueError("the shard folder is a link")
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0)
    fd = os.open(path, flags | getattr(os, "O_CLOEXEC", 0))
    with os.fdopen(fd, "rb", buffering=0) as f:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError("not a regular file")
        if st.st_size > MAX_ENTRY_BYTES:
            raise ValueError("over the size cap")
        blob = f.read(MAX_ENTRY_BYTES + 1)
    if len(blob) > MAX_ENTRY_BYTES:
        raise ValueError("over the size cap")
    return blob


def _is_regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(path.lstat().st_mode)
    except FileNotFoundError:
        return True  # nothing in the way
    except OSError:
        return False


def _remove_entry(path: Path) -> None:
    """Remove whatever is at ``path`` without following a link; errors are ignored (the
    next reader rejects the entry again)."""
    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
    except OSError:
        pass


def _own_folder(folder: Path) -> None:
    """``folder`` made a real folder of the cache: a link or a file in its place removed."""
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        folder.unlink()
    folder.mkdir(exist_ok=True)


class Uncacheable(TypeError):
    """An input has no exact, stable description (e.g. a core object or a function)."""


def canonical(value: Any) -> Any:
    """A JSON-ready, exact and order-independent description of ``value``.

    Floats are kept by ``repr`` (exact), mappings sorted by key, dataclasses by their fields,
    numpy scalars and arrays as Python numbers. Anything else (a core object, a callable)
    raises :class:`Uncacheable`: it would need an identity, and identities do not repeat
    across processes.
    """
    if value is None or isinstance(value, (bool, str, int)):
        return value
    if isinstance(value, float):
        return repr(float(value)) if not math.isnan(value) else "nan"
    if isinstance(value, enum.Enum):
        return canonical(value.value)
    if isinstance(value, np.generic):
        return canonical(value.item())
    if isinstance(value, np.ndarray):
        return [canonical(v) for v in value.tolist()]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__type__": type(value).__name__,
                **{f.name: canonical(getattr(value, f.name))
                   for f in dataclasses.fields(value)}}
    if isinstance(value, Mapping):
        return {str(k): canonical(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, (list, tuple)):
        return [canonical(v) for v in value]
    raise Uncacheable(f"{type(value).__name__} has no stable description for a cache key")


@functools.cache
def code_fingerprint() -> str:
    """sha256 of every source file of the installed package and of the compiled core: a
    result computed by other code never matches."""
    package = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for path in sorted(p for p in package.rglob("*")
                       if p.is_file() and p.suffix in (".py", ".so", ".pyd", ".toml", ".csv")):
        h.update(str(path.relative_to(package)).encode())
        h.update(hashlib.sha256(path.read_bytes()).digest())
    return h.hexdigest()


class ResultCache:
    """Results in a folder, one file per key (``<aa>/<sha256>.json.z``).

    Parameters
    ----------
    folder
        Where the results live; created if missing.

    Attributes
    ----------
    hits, misses, rejected, write_failures
        Counts since this object was made (``rejected``: entries that did not verify, removed;
        ``write_failures``: results that could not be stored).
    """

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        if self.folder.exists() and not self.folder.is_dir():
            raise ValueError(f"cache folder {str(self.folder)!r} is a file, not a folder")
        self.folder.mkdir(parents=True, exist_ok=True)
        self.hits = self.misses = self.rejected = self.write_failures = 0
        self._lock = threading.Lock()

    def __repr__(self) -> str:
        return (f"ResultCache({str(self.folder)!r}, hits={self.hits}, misses={self.misses}, "
                f"rejected={self.rejected})")

    def key(self, *parts: Any) -> str:
        """The key of a result computed from ``parts`` by this code (:class:`Uncacheable`
        if a part has no stable description)."""
        text = json.dumps([code_fingerprint(), canonical(list(parts))], separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def _path(self, key: str) -> Path:
        return self.folder / key[:2] / f"{key}.json.z"

    def get(self, key: str, parse: Callable[[Any], Any] | None = None) -> Any | None:
        """The stored value, or None: missing, or an entry that does not verify (removed).

        An entry verifies if it is a regular file inside the cache (no link, folder or device;
        its shard folder no link either), of at most :data:`MAX_ENTRY_BYTES` on disk and
        inflated, with the right magic, checksum and key, and, given ``parse``, if
        ``parse(value)`` accepts it: its result is returned then. ``parse`` is the reader's
        schema; any ``ValueError``, ``TypeError``, ``KeyError``, ``AttributeError`` or
        ``IndexError`` it raises makes the entry a miss, removed, never a traceback.
        """
        path = self._path(key)
        try:
            blob = _read_entry(path)
        except FileNotFoundError:
            self._count("misses")
            return None
        except (OSError, ValueError):
            self._reject(path)
            return None
        try:
            value = self._verify(key, blob)
            if parse is not None:
                value = parse(value)
        except (ValueError, TypeError, KeyError, AttributeError, IndexError, zlib.error,
                RecursionError):
            self._reject(path)
            return None
        self._count("hits")
        return value

    @staticmethod
    def _verify(key: str, blob: bytes) -> Any:
        """The value of an entry's bytes, or ValueError (magic, checksum, size or key)."""
        if not blob.startswith(_MAGIC):
            raise ValueError("not a vadsim cache file")
        digest, body = blob[len(_MAGIC):len(_MAGIC) + 64], blob[len(_MAGIC) + 64:]
        if hashlib.sha256(body).hexdigest().encode() != digest:
            raise ValueError("checksum")
        inflate = zlib.decompressobj()
        text = inflate.decompress(body, MAX_ENTRY_BYTES)
        if inflate.unconsumed_tail or not inflate.eof:
            raise ValueError("inflates past the size cap, or is cut short")
        stored = json.loads(text)
        if not isinstance(stored, dict) or stored.get("key") != key or "value" not in stored:
            raise ValueError("key")
        return stored["value"]

    def _reject(self, path: Path) -> None:
        """Count a bad entry and remove it: a link or a file is unlinked (never its target),
        a folder removed with what it holds."""
        self._count("rejected")
        if path.parent.is_symlink():  # the link goes, not what it leads to
            _remove_entry(path.parent)
        else:
            _remove_entry(path)

    def put(self, key: str, value: Any) -> None:
        """Store a JSON-ready value (written to a temporary file, then renamed: a reader sees
        the whole file or none). Whatever sits in the entry's place (a folder, a link) is
        removed first; a write that still fails (a full disk, a read-only folder) is given up
        with a :class:`CacheWarning`: the cache is an optimisation, never a failure."""
        body = zlib.compress(json.dumps({"key": key, "value": value},
                                        separators=(",", ":")).encode(), 1)
        path = self._path(key)
        try:
            _own_folder(path.parent)
            if not _is_regular(path):
                _remove_entry(path)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        except OSError as exc:
            self._write_failed(path, exc)
            return
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(_MAGIC + hashlib.sha256(body).hexdigest().encode() + body)
            os.replace(tmp, path)
        except OSError as exc:
            Path(tmp).unlink(missing_ok=True)
            self._write_failed(path, exc)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    def _write_failed(self, path: Path, exc: OSError) -> None:
        self._count("write_failures")
        warnings.warn(f"result cache: cannot write {path}: {exc.strerror or exc}; "
                      "the result is not kept", CacheWarning, stacklevel=3)

    def _count(self, name: str) -> None:
        with self._lock:
            setattr(self, name, getattr(self, name) + 1)


def default_cache(cache: ResultCache | str | os.PathLike[str] | bool | None = None
                  ) -> ResultCache | None:
    """The cache to use: ``cache`` itself, a folder's cache, or (None) ``$VADSIM_CACHE``'s;
    ``False`` turns caching off whatever the environment says."""
    if cache is False:
        return None
    if isinstance(cache, ResultCache):
        return cache
    if cache is None or cache is True:
        folder = os.environ.get(ENV_VAR, "")
        if not folder:
            if cache is True:
                raise ValueError(f"cache=True needs a folder: pass one or set ${ENV_VAR}")
            return None
        return _shared_cache(folder)
    return _shared_cache(os.fspath(cache))


@functools.lru_cache(maxsize=8)
def _shared_cache(folder: str) -> ResultCache:
    """One object per folder in a process, so its counts add up over a session."""
    return ResultCache(folder)
