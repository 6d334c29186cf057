"""Figures of the dissertation, one call per figure, from sweeps, runs and validation tables.

Why this package exists: the dissertation states its results as figures -- vibration peaks and
impacts per cycle against flow rate (Figs 3.42, 4.27), impulse per second J* coloured by impact
regime (Fig 4.28), regime and J* maps over excitation frequency and a design parameter (Figs
5.1-5.6), the original against the recommended design (Fig 5.7) and time traces of contact
forces, indentations and acceleration (Figs 4.2-4.6). This package draws each of them from the
objects the rest of vadsim returns (an :class:`xarray.Dataset` of
:func:`vadsim.studies.sweep.sweep`, a :class:`vadsim.SimulationResult`, a pandas table of
residuals), with one regime colour table (:data:`REGIME_COLORS`) so that a regime has the same
colour in every figure.

One module per subject, every public name re-exported here (``from vadsim import plots;
plots.regime_map(...)``):

* :mod:`~vadsim.plots.flow`: along flow -- :func:`peaks_vs_flow`, :func:`z_vs_flow`,
  :func:`j_vs_flow`;
* :mod:`~vadsim.plots.maps`: over frequency and a design parameter -- :func:`regime_map`,
  :func:`j_map`;
* :mod:`~vadsim.plots.design`: :func:`design_comparison`;
* :mod:`~vadsim.plots.traces`: :func:`time_traces`;
* :mod:`~vadsim.plots.campaigns`: recordings against the model -- :func:`mismatch_heatmap`,
  :func:`validation_peaks`, :func:`validation_mismatch`, :func:`heldout_features`,
  :func:`mismatch_base` (and their ``*_figure`` builders);
* :mod:`~vadsim.plots.imports`: :func:`import_figure` (a record and surface log imported as a
  campaign, the chosen stretches shaded);
* :mod:`~vadsim.plots.style`: what they share (colours, style, saving, units, feature names).

Conventions
-----------
* Every function returns a :class:`matplotlib.figure.Figure` built without pyplot (no global
  state, safe with any backend and in threads; never shown). Pass ``path`` (``.png``, ``.pdf``
  or ``.svg``) to save it; in Jupyter the returned figure displays itself. The exceptions are
  :func:`heldout_features` and :func:`mismatch_base`, which save into a report folder and
  return the file names.
* Features are named in words with their units (``x1_peak_mean_g`` is "x1 mean of 200 ms peaks
  (g)", :func:`vadsim.plots.style.feature_label`); titles give the weight on bit and the length
  of the runs when the data records them.
* Functions that need one axes take ``ax=``: the figure is then drawn into it and the returned
  figure is the one that holds ``ax``.
* Flow rates are in gal/min, excitation frequencies in Hz, accelerations in g, J* and contact
  forces in kN when the dataset (or result) knows the reference mass m*, otherwise in N/kg.
* The operating range of a design is where J* >= :data:`OPERATING_FRACTION` times its maximum
  (dissertation chapter 5: "J* within 10 % of its max").
"""

from vadsim.plots.campaigns import (
    heldout_features,
    heldout_features_figure,
    mismatch_base,
    mismatch_base_figure,
    mismatch_heatmap,
    validation_mismatch,
    validation_peaks,
)
from vadsim.plots.design import design_comparison
from vadsim.plots.flow import THESIS_REFERENCES, j_vs_flow, peaks_vs_flow, z_vs_flow
from vadsim.plots.imports import import_figure
from vadsim.plots.maps import j_map, regime_map
from vadsim.plots.style import (
    OPERATING_FRACTION,
    REGIME_COLORS,
    SURFACE_COLORS,
    SURFACE_LABELS,
    regime_label,
)
from vadsim.plots.traces import time_traces

__all__ = [
    "OPERATING_FRACTION",
    "REGIME_COLORS",
    "SURFACE_COLORS",
    "SURFACE_LABELS",
    "THESIS_REFERENCES",
    "design_comparison",
    "heldout_features",
    "heldout_features_figure",
    "import_figure",
    "j_map",
    "j_vs_flow",
    "mismatch_base",
    "mismatch_base_figure",
    "mismatch_heatmap",
    "peaks_vs_flow",
    "regime_label",
    "regime_map",
    "time_traces",
    "validation_mismatch",
    "validation_peaks",
    "z_vs_flow",
]
