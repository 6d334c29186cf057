"""Sphinx configuration of the vadsim site: ``python3 -m sphinx -W docs docs/_build/html``.

Warnings are errors (``-W``): a renamed function breaks the build, not the reader. The
gallery (``examples/``) runs in a fast mode unless ``VADSIM_GALLERY_FULL=1`` (the
dissertation's run lengths and grid sizes), so that the whole site builds in minutes on two
cores. Links to numpy, scipy, pandas, xarray and matplotlib resolve through intersphinx
inventories read from local files where Debian's documentation packages put them (no network
at build time); a missing inventory only drops those links.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import vadsim

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE / "_ext"))  # vadsim_gallery: the figure scraper

project = "vadsim"
author = "the vadsim developers"
copyright = "2026, the vadsim developers"
release = vadsim.__version__
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_ext", "sg_execution_times.rst"]

# MyST: the Markdown pages stay Markdown; $...$ maths as in MODEL.md; headings get anchors so
# that [text](PAGE.md#section) links work
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
suppress_warnings = ["myst.xref_missing"] if os.environ.get("VADSIM_DOCS_LAX") else []

# API reference: one page per public object, docstrings in numpydoc format
autosummary_generate = True
autodoc_default_options = {"members": True, "inherited-members": False}
autodoc_typehints = "none"  # the numpydoc sections say the types in words
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# intersphinx from local inventories (Debian's python-*-doc packages); no network
_INVENTORIES = {
    "python": ("https://docs.python.org/3/", "/usr/share/doc/python3-doc/html/objects.inv"),
    "scipy": ("https://docs.scipy.org/doc/scipy/",
              "/usr/share/doc/python-scipy-doc/html/objects.inv"),
    "pandas": ("https://pandas.pydata.org/docs/",
               "/usr/share/doc/python-pandas-doc/html/objects.inv"),
    "xarray": ("https://docs.xarray.dev/en/stable/",
               "/usr/share/doc/python-xarray-doc/html/objects.inv"),
    "numpy": ("https://numpy.org/doc/stable/", "/usr/share/doc/python-numpy-doc/html/objects.inv"),
    "matplotlib": ("https://matplotlib.org/stable/",
                   "/usr/share/doc/python-matplotlib-doc/html/objects.inv"),
}
intersphinx_mapping = {name: (url, inv) for name, (url, inv) in _INVENTORIES.items()
                       if Path(inv).is_file()}
intersphinx_timeout = 1

# the gallery: one short script per task, run at build time
_FULL = os.environ.get("VADSIM_GALLERY_FULL") == "1"
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib", "vadsim_gallery.figure_scraper"),
    "reset_modules": ("matplotlib",),
    "capture_repr": ("_repr_html_", "__repr__"),
    "min_reported_time": 1,
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
    "show_signature": False,
}

html_theme = "pydata_sphinx_theme"
html_title = f"vadsim {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_static_path: list[str] = []
html_show_sourcelink = False
