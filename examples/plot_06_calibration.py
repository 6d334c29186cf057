"""
Calibrating the 9.5in tool
==========================

The dissertation withholds the standard length ``l0`` and the weight on bit per unit
reference mass ``wob``. For the 9.5in tool they are fitted to its own simulation of the 12
field events (one impact per cycle everywhere, the x1 peaks), at full resolution as it
computed them. The fast mode fits every third event in a narrow box around the answer of the
full calibration (:doc:`../CALIBRATION`: 19 minutes on two cores); ``VADSIM_GALLERY_FULL=1``
runs that one.
"""

import dataclasses
import os

from vadsim import plots
from vadsim.campaigns import load_any_campaign
from vadsim.fit import calibrate, validate

FULL = os.environ.get("VADSIM_GALLERY_FULL") == "1"
campaign = load_any_campaign("thesis:9.5in-pdc")
if FULL:
    opts = dict(bounds={"l0": (0.6, 1.3), "wob": (300.0, 3000.0)}, n_global=384, n_starts=4)
else:
    campaign = dataclasses.replace(campaign, events=campaign.events[::3])
    opts = dict(bounds={"l0": (1.127, 1.135), "wob": (400.0, 520.0)}, n_global=12,
                n_starts=1, max_nfev=10, alias_stripes=0)
campaign

# %%
fit = calibrate.calibrate(campaign, ["l0", "wob"], targets="thesis-sim", resolution="full",
                          progress=False, **opts)
print(fit.summary())

# %%
# The calibrated tool against the field recordings of the same events (1024 Hz, 250 g),
# through the sensor chain:
res = validate.validate(campaign, overrides=fit.estimates, progress=False)
fig = plots.validation_peaks(res)
