"""vadsim: simulator and diagnosis toolkit for vibration-assisted drilling (VAD) tools.

The model is the 7-DOF vibro-impact model of an M.Sc. dissertation (bit, anvil, housing, motor,
sub, LWD, MWD; four impact surfaces and the rock), integrated by SUNDIALS CVODE with every
contact switch located by root-finding. See MODEL.md in the docs for every equation.

The package is layered (docs/ARCHITECTURE.md): ``model`` (presets, one run, run settings) ->
``signals`` (labels, features, sensor chain) -> ``campaigns`` (the recordings format) ->
``compare`` (the one comparison engine) -> ``fit`` (validate, calibrate, diagnosis) and
``studies`` (sweeps, maps, design) -> ``report`` and ``plots`` -> ``cli``. Each module has one
import path (``vadsim.studies.sweep``, ``vadsim.fit.diagnosis``, ...); this facade holds what a
first script needs.

Quick start
-----------
>>> import vadsim
>>> r = vadsim.simulate("7in-cde", flow_gpm=200, cycles=40, analyse_cycles=20)
>>> r.scenario
1
"""

import importlib as _importlib

from vadsim import _aliases
from vadsim._interrupt import stop_on_interrupt
from vadsim._version import __version__
from vadsim.model.defaults import DEFAULTS
from vadsim.model.presets import (
    PRESETS,
    Preset,
    get_preset,
    make_params,
    param_names,
    preset_names,
)
from vadsim.model.result import SURFACES, G, SimulationResult
from vadsim.model.settings import RunSettings
from vadsim.model.simulation import SolverError, extra_force, simulate

_aliases.install()

# Packages of their own, loaded on first use: they pull in xarray, matplotlib and dask, and
# `import vadsim` stays quick for a single run.
_LAZY = ("blind", "campaigns", "compare", "fit", "model", "plots", "report", "signals",
         "studies")

# vadsim 0.1's short names of modules, deprecated (vadsim._aliases).
_OLD = {old.split(".", 1)[1]: old for old in _aliases.ALIASES if old.count(".") == 1}


def __getattr__(name: str):
    if name in _LAZY:
        return _importlib.import_module(f"vadsim.{name}")
    if name in _OLD and name != "simulate":
        _aliases.deprecated(_OLD[name])
        return _importlib.import_module(_aliases.ALIASES[_OLD[name]])
    raise AttributeError(f"module 'vadsim' has no attribute {name!r}")


__all__ = [
    "DEFAULTS",
    "G",
    "PRESETS",
    "SURFACES",
    "Preset",
    "RunSettings",
    "SimulationResult",
    "SolverError",
    "__version__",
    "blind",
    "campaigns",
    "compare",
    "extra_force",
    "fit",
    "get_preset",
    "make_params",
    "model",
    "param_names",
    "plots",
    "preset_names",
    "report",
    "signals",
    "simulate",
    "stop_on_interrupt",
    "studies",
]
