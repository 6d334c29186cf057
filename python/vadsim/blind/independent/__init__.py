"""An independent campaign generator for the blind benchmark.

Why this package exists: the blind benchmark's campaigns were all written by vadsim itself,
with effects drawn from the candidate library, so a diagnosis search that only works on its
own generator would pass it. This generator writes campaigns with none of vadsim's model,
core, sensor chain or campaign writer (it imports numpy, scipy and the package's data only):

- :mod:`~vadsim.blind.independent.model`: MODEL.md's 7-DOF model again, integrated by
  ODEPACK's LSODA (:func:`scipy.integrate.odeint`);
- :mod:`~vadsim.blind.independent.effects`: effects written in its own form (a library member
  written apart, a hydraulic force of another flow law, a friction of another regularisation,
  a Hertzian contact outside the families);
- :mod:`~vadsim.blind.independent.recording`: its own sensor chain (analog anti-alias filter
  discretised exactly, samples taken at solver points, noise, clipping) and its own writer
  of the RECORDINGS.md campaign folder.

The blind benchmark's classes ``indep_*`` (:data:`vadsim.blind.scenarios.INDEPENDENT_SCENARIOS`)
are written through :func:`write_campaign`.
"""

from vadsim.blind.independent.effects import EFFECTS, build_effect, nearest_library
from vadsim.blind.independent.model import (
    PRESETS,
    IndependentModel,
    preset_params,
    rest_phase,
    run_summary,
)
from vadsim.blind.independent.recording import (
    IndependentSpec,
    analog_lowpass,
    record_event,
    write_campaign,
)

__all__ = ["EFFECTS", "PRESETS", "IndependentModel", "IndependentSpec", "analog_lowpass",
           "build_effect", "nearest_library", "preset_params", "record_event", "rest_phase",
           "run_summary", "write_campaign"]
