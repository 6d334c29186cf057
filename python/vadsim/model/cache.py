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
miss, removed, never a wrong result.

Opt-in: pass a folder (``cache=`` in :func:`vadsim.diagnose`, ``--cache DIR`` on the CLI) or
set ``VADSIM_CACHE=DIR``. The folder may be deleted at any time.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import json
import math
import os
import tempfile
import threading
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["ENV_VAR", "ResultCache", "Uncacheable", "canonical", "code_fingerprint",
           "default_cache"]

ENV_VAR = "VADSIM_CACHE"
"""Environment variable naming the cache folder used when none is passed."""

_MAGIC = b"vadsim-cache-1\n"


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
    hits, misses, rejected
        Counts since this object was made (``rejected``: files that did not verify).
    """

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        if self.folder.exists() and not self.folder.is_dir():
            raise ValueError(f"cache folder {str(self.folder)!r} is a file, not a folder")
        self.folder.mkdir(parents=True, exist_ok=True)
        self.hits = self.misses = self.rejected = 0
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

    def get(self, key: str) -> Any | None:
        """The stored value, or None (missing, or a file that does not verify: removed)."""
        path = self._path(key)
        try:
            blob = path.read_bytes()
        except OSError:
            self._count("misses")
            return None
        try:
            if not blob.startswith(_MAGIC):
                raise ValueError("not a vadsim cache file")
            digest, body = blob[len(_MAGIC):len(_MAGIC) + 64], blob[len(_MAGIC) + 64:]
            if hashlib.sha256(body).hexdigest().encode() != digest:
                raise ValueError("checksum")
            stored = json.loads(zlib.decompress(body))
            if stored.get("key") != key:
                raise ValueError("key")
        except (ValueError, zlib.error, UnicodeDecodeError):
            self._count("rejected")
            path.unlink(missing_ok=True)
            return None
        self._count("hits")
        return stored["value"]

    def put(self, key: str, value: Any) -> None:
        """Store a JSON-ready value (written to a temporary file, then renamed: a reader sees
        the whole file or none)."""
        body = zlib.compress(json.dumps({"key": key, "value": value},
                                        separators=(",", ":")).encode(), 1)
        path = self._path(key)
        path.parent.mkdir(exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(_MAGIC + hashlib.sha256(body).hexdigest().encode() + body)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

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
