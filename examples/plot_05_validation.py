"""
Validation against the field tables
===================================

The dissertation's field test of the 7in tool with the CDE bit: the mean 200 ms peaks at the
bit sub (x1) and above the motor (x5) at ten flows, recorded at 1024 Hz with a 250 g range.
Every event is simulated, passed through the same sensor chain and compared feature by
feature; a residual is (model - recorded) / the recording's own spread.
"""

import os

from vadsim import plots
from vadsim.fit import validate

FULL = os.environ.get("VADSIM_GALLERY_FULL") == "1"
cycles = {} if FULL else {"cycles": 240, "analyse_cycles": 160}

res = validate.validate("thesis:7in-cde", progress=False, **cycles)
fig = plots.validation_peaks(res)

# %%
# The standardised residuals, event by feature:
fig_mismatch = plots.validation_mismatch(res)

# %%
res.residuals.round(2)
