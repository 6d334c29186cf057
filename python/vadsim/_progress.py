"""Progress bars for long work (tqdm on stderr), one switch everywhere: ``progress=False`` in
Python, ``--quiet`` on the command line."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["ProgressArg", "bar", "reporter"]

ProgressArg = bool | Callable[[str], None] | None
"""``True``: a progress bar; ``False``/``None``: silent; a callable: one line per step."""


class _Silent:
    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, text: str) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> _Silent:
        return self

    def __exit__(self, *exc: object) -> None:
        pass


def bar(progress: ProgressArg, total: int | None, desc: str, unit: str = "run") -> Any:
    """A tqdm bar when ``progress is True``, else an object with the same methods that does
    nothing (callables get lines through :func:`reporter` instead)."""
    if progress is True:
        from tqdm.auto import tqdm

        return tqdm(total=total, desc=desc, unit=unit, smoothing=0.05, leave=False)
    return _Silent()


def reporter(progress: ProgressArg) -> Callable[[str], None]:
    """The line callback of ``progress`` (a no-op unless it is a callable)."""
    return progress if callable(progress) else (lambda _msg: None)
