"""
Bringing your own recordings: a continuous record and a surface log
===================================================================

A downhole memory sub records acceleration for hours; the rig's surface log gives flow and
WOB once a second, on its own clock. Here vadsim writes such a pair itself -- a flow-step
test, the pumps off for a few seconds and then the flow stepped through 200-650 gal/min with
the model's state carried from each step into the next -- in a vendor's form: the record in
m/s^2 with its own column names, the log in L/min and kN at 1 Hz, 37.3 s ahead of the
record's clock, with noise. ``import_campaign`` (``vadsim campaign import`` on the command
line) reads both, converts the units, finds when the pumps came on in each to align the
clocks, keeps the stretches where flow and WOB held steady as events, and writes a campaign.
The campaign is then validated and diagnosed: the model wrote it, so nothing is missing.
"""

import os
import tempfile
from pathlib import Path

from vadsim import plots
from vadsim.campaigns import campaign_text, import_campaign, load_campaign
from vadsim.campaigns.flowstep import flow_step_test
from vadsim.fit import diagnosis, validate

FULL = os.environ.get("VADSIM_GALLERY_FULL") == "1"
folder = Path(tempfile.mkdtemp(prefix="vadsim-import-"))

test = flow_step_test("7in-cde", (200, 300, 400, 500, 600, 650), step_s=30 if FULL else 16,
                      clock_offset_s=37.3, flow_unit="L/min", wob_unit="kN", seed=7)
record = test.write_record(folder / "memory-sub.csv")    # Time [s], AccZ_bit [m/s^2], ...
surface = test.write_surface(folder / "rig-log.csv")     # Time [s], Flow [L/min], WOB [kN]
print(open(record).readline().strip(), "|", open(surface).readline().strip())

# %%
# The import: the same as ``vadsim campaign import memory-sub.csv --surface rig-log.csv
# --out campaign --tool 7in --bit CDE --column x1=AccZ_bit --column x5=AccZ_mwd``. The
# summary says what was read and converted, the clock offset it found (the truth is 37.3 s),
# the events and every refused stretch with its reason.
result = import_campaign(record, surface, folder / "campaign", tool="7in", bit="CDE",
                         columns={"x1": "AccZ_bit", "x5": "AccZ_mwd"})
print(result.summary())

# %%
# The record's vibration envelope and the log on the record's clock, the events shaded:
fig_import = plots.import_figure(result)

# %%
# The steady stretches against the flow steps that wrote them (record clock, s):
for st, (t0, t1, q) in zip([s for s in result.stretches if s.accepted], test.steps,
                           strict=True):
    print(f"{st.event_id}: kept {st.kept_s[0]:6.1f}-{st.kept_s[1]:6.1f} s at "
          f"{st.flow_gpm:5.1f} gal/min; step {t0:6.1f}-{t1:6.1f} s at {q:g} gal/min")

# %%
# What ``vadsim campaign show`` prints: check an import here before a long diagnosis.
camp = load_campaign(folder / "campaign")
print(campaign_text(camp))

# %%
# Validation: every event simulated at its imported flow and WOB, through the same sensor
# chain, feature by feature. The model wrote the record, so the residuals stay small.
run = {} if FULL else {"cycles": 240, "analyse_cycles": 160}
res = validate.validate(camp, progress=False, **run)
fig_peaks = plots.validation_peaks(res)

# %%
# The diagnosis: with the base model's uncertain constants calibrated, is anything missing?
offered = None if FULL else ["hydraulic_force", "anvil_friction"]
short = {} if FULL else {"cycles": 160, "analyse_cycles": 100}
d = diagnosis.diagnose(camp, candidates=offered, phases=4 if FULL else 2, progress=False,
                      **short)
print(d.verdict_text())
assert d.missing_physics == ["none"], d.summary()
