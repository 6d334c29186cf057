"""vadsim: simulator and diagnosis toolkit for vibration-assisted drilling (VAD) tools.

The model is the 7-DOF vibro-impact model of an M.Sc. dissertation (bit, anvil, housing, motor,
sub, LWD, MWD; four impact surfaces and the rock), integrated by SUNDIALS CVODE with every
contact switch located by root-finding. See MODEL.md in the docs for every equation.

The package is layered (docs/ARCHITECTURE.md): ``model`` (presets, one run, run settings) ->
``signals`` (labels, features, sensor chain) -> ``campaigns`` (the recordings format) ->
``compare`` (the one comparison engine) -> ``fit`` (validate, calibrate, diagnose) and
``studies`` (sweeps, maps, design) -> ``report`` and ``plots`` -> ``cli``.

Quick start
-----------
>>> import vadsim
>>> r = vadsim.simulate("7in-cde", flow_gpm=200, cycles=40, analyse_cycles=20)
>>> r.scenario
1
"""

from vadsim import _aliases
from vadsim import campaigns as recordings
from vadsim._interrupt import stop_on_interrupt
from vadsim._version import __version__
from vadsim.model import presets
from vadsim.model.presets import (
    PRESETS,
    Preset,
    get_preset,
    make_params,
    param_names,
    preset_names,
)
from vadsim.model.settings import RunSettings
from vadsim.model.simulate import (
    SURFACES,
    G,
    SimulationResult,
    SolverError,
    extra_force,
    simulate,
)
from vadsim.signals import labels, sensor

_aliases.install(eager=("vadsim.presets", "vadsim.simulate", "vadsim.labels", "vadsim.sensor",
                        "vadsim.recordings"))

# The analysis modules pull in xarray, matplotlib and dask: loaded on first use, so that
# `import vadsim` stays quick for a single run.
_LAZY = {
    "blind": "vadsim.blind",
    "calibrate": "vadsim.fit.calibrate",
    "candidates": "vadsim.fit.candidates",
    "compare": "vadsim.compare",
    "design": "vadsim.studies.design",
    "diagnose": "vadsim.fit.diagnose",
    "features": "vadsim.signals.features",
    "locate": "vadsim.fit.locate",
    "plots": "vadsim.plots",
    "report": "vadsim.report",
    "sweep": "vadsim.studies.sweep",
    "synthetic": "vadsim.campaigns.synthetic",
    "thesis": "vadsim.studies.thesis",
    "validate": "vadsim.fit.validate",
}


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        return importlib.import_module(_LAZY[name])
    raise AttributeError(f"module 'vadsim' has no attribute {name!r}")


__all__ = [
    "G",
    "PRESETS",
    "SURFACES",
    "Preset",
    "RunSettings",
    "SimulationResult",
    "SolverError",
    "__version__",
    "blind",
    "calibrate",
    "candidates",
    "compare",
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
    "report",
    "sensor",
    "simulate",
    "stop_on_interrupt",
    "sweep",
    "synthetic",
    "thesis",
    "validate",
]
