"""Sphinx-gallery helpers for the vadsim site.

vadsim's figure functions build :class:`matplotlib.figure.Figure` objects without pyplot (so
that they are safe in worker threads and never pop up a window), which sphinx-gallery's
matplotlib scraper cannot see. :func:`figure_scraper` saves every figure an example block
left in its namespace that has not been shown yet.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matplotlib.figure import Figure
from sphinx_gallery.scrapers import figure_rst

_SEEN: dict[str, set[int]] = {}


def _figures(value: Any) -> list[Figure]:
    if isinstance(value, Figure):
        return [value]
    if isinstance(value, (list, tuple)):
        return [v for v in value if isinstance(v, Figure)]
    if isinstance(value, dict):
        return [v for v in value.values() if isinstance(v, Figure)]
    return []


def figure_scraper(block: Any, block_vars: dict[str, Any], gallery_conf: dict[str, Any],
                   **kwargs: Any) -> str:
    """Save the figures a block created (found in the example's globals), in creation order."""
    seen = _SEEN.setdefault(str(block_vars["src_file"]), set())
    found = [f for v in list(block_vars["example_globals"].values()) for f in _figures(v)]
    new = [f for f in dict.fromkeys(found) if id(f) not in seen]
    paths = []
    for fig, path in zip(new, block_vars["image_path_iterator"], strict=False):
        fig.savefig(path, dpi=110)
        seen.add(id(fig))
        paths.append(Path(path))
    return figure_rst(paths, gallery_conf["src_dir"]) if paths else ""
