"""
One run and its time traces
===========================

The 7in tool with the CDE bit at 200 gal/min: 400 excitation cycles from rest, the last 200
analysed. The summary says how the anvil impacts (impacts per cycle at each surface, the
dissertation's scenario), how hard (the 200 ms acceleration peaks at the bit sub) and how much
impulse reaches the bit per second (J*).
"""

import vadsim

r = vadsim.simulate("7in-cde", flow_gpm=200)
r

# %%
# The last three excitation cycles: positions of the bit, anvil and housing, the contact
# forces at the four surfaces and the acceleration at the two sensor positions. The anvil
# strikes the bit once per cycle and recoils into the spring: scenario 1.
fig = vadsim.plots.time_traces(r, cycles=3)

# %%
# Every contact onset and release is located by CVODE's root finding, with its exact time
# and the closing speed:
r.events.head(8)
