"""
Design studies and the recommended design
=========================================

The dissertation's one-at-a-time studies change the excitation force ``Fo``, the recoil
spring's stiffness ``kS`` and the gap, each over its published range, and read off the
largest impulse per second J* and the operating range. Its recommended design combines them
(kS = 4.724e5 N/m/kg, gap ratio 1.5, Fo = 534.17 N/kg); here it is compared with the original
tool over the field's flows.
"""

import os

import pandas as pd
from vadsim import plots
from vadsim.studies import design

FULL = os.environ.get("VADSIM_GALLERY_FULL") == "1"
flows = design.thesis_flows("7in-cde", hz_step=0.5 if FULL else 3.0)
short = {} if FULL else {"cycles": 200, "analyse_cycles": 100}

force = design.one_at_a_time("force", steps=21 if FULL else 4, flows=flows, progress=False,
                             **short)
design.study_table(force)

# %%
# The same for the spring's stiffness:
spring = design.one_at_a_time("spring", steps=21 if FULL else 4, flows=flows, progress=False,
                              **short)
design.study_table(spring)

# %%
# The recommended design against the original: J* over flow, and the metrics of each.
rec = design.compare_designs(design.RECOMMENDED, flows=flows, progress=False, **short)
fig = plots.design_comparison(rec.original, rec.changed)

# %%
pd.DataFrame({"original": rec.metrics_original, "recommended": rec.metrics_changed})
