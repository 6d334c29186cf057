"""vadsim: simulator and diagnosis toolkit for vibration-assisted drilling (VAD) tools.

The model is the 7-DOF vibro-impact model of an M.Sc. dissertation (bit, anvil, housing, motor,
sub, LWD, MWD; four impact surfaces and the rock), integrated by SUNDIALS CVODE with every
contact switch located by root-finding. See MODEL.md in the docs for every equation.

Quick start
-----------
>>> import vadsim
>>> r = vadsim.simulate("7in-cde", flow_gpm=200, cycles=40, analyse_cycles=20)
>>> r.scenario
1
"""

from vadsim import labels, presets, recordings, sensor
from vadsim.presets import PRESETS, Preset, get_preset, make_params, param_names, preset_names
from vadsim.simulate import (
    SURFACES,
    G,
    SimulationResult,
    SolverError,
    extra_force,
    simulate,
)

__version__ = "0.1.0"

# The analysis modules pull in xarray, matplotlib and dask: loaded on first use, so that
# `import vadsim` stays quick for a single run.
_LAZY = (
    "blind", "calibrate", "candidates", "design", "diagnose", "features", "locate", "plots",
    "sweep", "synthetic", "thesis", "validate",
)


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return importlib.import_module(f"vadsim.{name}")
    raise AttributeError(f"module 'vadsim' has no attribute {name!r}")


__all__ = [
    "G",
    "PRESETS",
    "SURFACES",
    "Preset",
    "SimulationResult",
    "SolverError",
    "blind",
    "calibrate",
    "candidates",
    "design",
    "diagnose",
    "extra_force",
    "features",
    "get_preset",
    "labels",
    "locate",
    "make_params",
    "param_names",
    "plots",
    "preset_names",
    "presets",
    "recordings",
    "sensor",
    "simulate",
    "sweep",
    "synthetic",
    "thesis",
    "validate",
]
