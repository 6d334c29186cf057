"""The model layer: presets (Table 2.1 plus the withheld constants), one run of the C++ core,
and the settings bundle every analysis passes along."""

from vadsim.model.change import ModelChange
from vadsim.model.presets import PRESETS, Preset, get_preset, make_params, param_names
from vadsim.model.result import SimulationResult
from vadsim.model.settings import ExtraSpec, RunSettings, excitation_hz
from vadsim.model.simulation import SolverError, extra_force, simulate

__all__ = ["PRESETS", "ExtraSpec", "ModelChange", "Preset", "RunSettings", "SimulationResult",
           "SolverError", "excitation_hz", "extra_force", "get_preset", "make_params",
           "param_names", "simulate"]
