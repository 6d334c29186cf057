"""
The gap map
===========

The dissertation's map over flow and the anvil-spring gap (as a ratio of the original gap):
the impact scenario at every point and the impulse per second J*, with the operating range
outlined. The full-resolution map (85 gaps x 97 flows, ``VADSIM_GALLERY_FULL=1``) is the one
the dissertation needed days for; vadsim runs it in a few minutes on two cores.
"""

import os

import numpy as np
from vadsim import plots
from vadsim.studies import design, sweep

FULL = os.environ.get("VADSIM_GALLERY_FULL") == "1"
gaps = np.linspace(0.85, 1.5, 85 if FULL else 8)
flows = sweep.flows_from_hz("7in-cde", np.arange(21.3, 69.4, 0.5 if FULL else 3.0))

ds = sweep.sweep("7in-cde", flows, {"gap_ratio": gaps}, gap_via="spring", detail="map",
                 progress=False)
fig_regimes = plots.regime_map(ds)

# %%
fig_j = plots.j_map(ds)

# %%
# Per gap: the largest J*, the operating range and the edge of regime 1.
design.study_table(ds)
