"""The import paths of vadsim 0.1 (``vadsim.sweep``, ``vadsim.presets``, ...), deprecated.

Why this module exists: users' scripts import ``from vadsim.sweep import sweep``; the package
keeps each layer in its own folder (``vadsim.studies.sweep``), one import path per module.
For one release (0.2) the old paths still work and say where the module went: a
meta-path finder maps each old name to a small module that forwards every attribute to the
new one with a :class:`DeprecationWarning` naming the new path. The modules behind stay lazy.
The old paths go in 0.3.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from types import ModuleType
from typing import Any

__all__ = ["ALIASES", "MOVED_OUT", "deprecated", "install"]

ALIASES: dict[str, str] = {
    "vadsim.presets": "vadsim.model.presets",
    "vadsim.simulate": "vadsim.model.simulation",
    "vadsim.labels": "vadsim.signals.labels",
    "vadsim.features": "vadsim.signals.features",
    "vadsim.sensor": "vadsim.signals.sensor",
    "vadsim.recordings": "vadsim.campaigns",
    "vadsim.synthetic": "vadsim.campaigns.synthetic",
    "vadsim.validate": "vadsim.fit.validate",
    "vadsim.calibrate": "vadsim.fit.calibrate",
    "vadsim.diagnose": "vadsim.fit.diagnosis",
    "vadsim.fit.diagnose": "vadsim.fit.diagnosis",
    "vadsim.candidates": "vadsim.fit.candidates",
    "vadsim.locate": "vadsim.fit.locate",
    "vadsim.sweep": "vadsim.studies.sweep",
    "vadsim.design": "vadsim.studies.design",
    "vadsim.thesis": "vadsim.studies.thesis",
    # renamed in 0.2 because each shared its name with the function its package exports
    # (``vadsim.model.simulate`` was the function, never the module)
    "vadsim.model.simulate": "vadsim.model.simulation",
    "vadsim.blind.regret": "vadsim.blind.truth_regret",
    "vadsim.report.render": "vadsim.report.rendering",
}
"""Old module path -> the module that now holds it."""

MOVED_OUT: dict[str, tuple[str, ...]] = {
    "vadsim.simulate": ("vadsim.model.result",),
    "vadsim.features": ("vadsim.signals.window_features", "vadsim.signals.bands"),
    "vadsim.calibrate": ("vadsim.fit.calibration_targets", "vadsim.fit.calibration_search"),
}
"""Old module path -> the modules that 0.2 split out of its new module: a name read from the
old path is looked up there too, so a 0.1 script keeps working (with the warning)."""


def deprecated(old: str, stacklevel: int = 3) -> None:
    """Warn that ``old`` is an old import path, naming the new one."""
    warnings.warn(f"{old} is deprecated since vadsim 0.2 and goes in 0.3: import "
                  f"{ALIASES[old]} instead", DeprecationWarning, stacklevel=stacklevel)


class _Forwarding(ModuleType):
    """An old path: every attribute read from the new module, with a warning."""

    def __init__(self, old: str) -> None:
        super().__init__(old)
        self.__dict__["_vadsim_target"] = ALIASES[old]

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") and name.endswith("__"):
            raise AttributeError(name)
        deprecated(self.__name__)
        for target in self._targets():
            module = importlib.import_module(target)
            if hasattr(module, name):
                return getattr(module, name)
        raise AttributeError(f"module {self.__name__!r} (now {self._targets()[0]}) has no "
                             f"attribute {name!r}")

    def _targets(self) -> tuple[str, ...]:
        return (self.__dict__["_vadsim_target"], *MOVED_OUT.get(self.__name__, ()))

    def __dir__(self) -> list[str]:
        return sorted({n for t in self._targets() for n in dir(importlib.import_module(t))})


class _AliasLoader(importlib.abc.Loader):
    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        return _Forwarding(spec.name)

    def exec_module(self, module: ModuleType) -> None:
        pass


class _AliasFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname: str, path: object = None, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if fullname not in ALIASES:
            return None
        # the parent is imported before its child is looked for: guard its function of the
        # old module's name before the import system binds the old module over it
        parent = sys.modules.get(fullname.rpartition(".")[0])
        if parent is not None and type(parent) is ModuleType:
            parent.__class__ = _Facade
        return importlib.util.spec_from_loader(fullname, _AliasLoader())


class _Facade(ModuleType):
    """A package holding old paths (``vadsim``, ``vadsim.model``, ...), which does not bind an
    old path's module to its short name.

    Python's import system sets ``vadsim.sweep`` once ``vadsim.sweep`` is imported; the short
    name would then skip the facade's ``__getattr__`` (and its warning), and ``import
    vadsim.simulate`` (or ``vadsim.model.simulate``) would replace the function of that name.
    Old paths stay reachable through ``sys.modules``; in a sub-package, an old path whose
    short name the package does not hold is bound as usual (``vadsim.fit.diagnose``)."""

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, _Forwarding) and (self.__name__ == "vadsim"
                                               or name in self.__dict__):
            return
        super().__setattr__(name, value)


def install() -> None:
    """Put the finder on ``sys.meta_path`` once, and keep old modules off the facade."""
    if not any(isinstance(f, _AliasFinder) for f in sys.meta_path):
        sys.meta_path.append(_AliasFinder())
    facade = sys.modules["vadsim"]
    if type(facade) is ModuleType:
        facade.__class__ = _Facade
