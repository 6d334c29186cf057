"""Where a result's text and HTML come from: the report layer, found by type.

Why this module exists: a :class:`~vadsim.fit.diagnosis.Diagnosis` is data made in ``fit/``;
its words (a terminal summary, a notebook table, the verdict sentence) are written in
``report/``, which reads ``fit/`` and may not be read by it. The data classes ask this
registry for their renderer (``summary()``, ``_repr_html_()``), and the report layer
registers them when it is imported -- the way pandas finds its plotting backend by name. The
first request imports :data:`PROVIDERS` if nothing is registered yet.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

__all__ = ["PROVIDERS", "register", "render"]

PROVIDERS = ("vadsim.report.text",)
"""Modules that register renderers when imported."""

_RENDERERS: dict[tuple[type, str], Callable[[Any], str]] = {}


def register(cls: type, kind: str, fn: Callable[[Any], str]) -> None:
    """``fn(obj)`` renders objects of class ``cls`` as ``kind`` (``"text"``, ``"html"``,
    ``"verdict"``...)."""
    _RENDERERS[(cls, kind)] = fn


def render(obj: Any, kind: str) -> str:
    """``obj`` rendered as ``kind`` by the renderer registered for its class.

    Raises
    ------
    TypeError
        If no provider registers one.
    """
    key = (type(obj), kind)
    if key not in _RENDERERS:
        for module in PROVIDERS:
            importlib.import_module(module)
    try:
        fn = _RENDERERS[key]
    except KeyError:
        raise TypeError(f"no {kind} renderer for {type(obj).__name__}") from None
    return fn(obj)
