"""The import paths of vadsim 0.1 (``vadsim.sweep``, ``vadsim.presets``, ...), kept working.

Why this module exists: users' scripts import ``from vadsim.sweep import sweep``; the package
now keeps each layer in its own folder (``vadsim.studies.sweep``). A meta-path finder maps each
old name to its new module, so both names give the same module object (no copies, no shims),
and the lazy modules stay lazy.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
from types import ModuleType

__all__ = ["ALIASES", "install"]

ALIASES: dict[str, str] = {
    "vadsim.presets": "vadsim.model.presets",
    "vadsim.simulate": "vadsim.model.simulate",
    "vadsim.labels": "vadsim.signals.labels",
    "vadsim.features": "vadsim.signals.features",
    "vadsim.sensor": "vadsim.signals.sensor",
    "vadsim.recordings": "vadsim.campaigns",
    "vadsim.synthetic": "vadsim.campaigns.synthetic",
    "vadsim.validate": "vadsim.fit.validate",
    "vadsim.calibrate": "vadsim.fit.calibrate",
    "vadsim.diagnose": "vadsim.fit.diagnose",
    "vadsim.candidates": "vadsim.fit.candidates",
    "vadsim.locate": "vadsim.fit.locate",
    "vadsim.sweep": "vadsim.studies.sweep",
    "vadsim.design": "vadsim.studies.design",
    "vadsim.thesis": "vadsim.studies.thesis",
}
"""Old module path -> the module that now holds it."""


class _AliasLoader(importlib.abc.Loader):
    def __init__(self, target: str) -> None:
        self.target = target
        self.spec: importlib.machinery.ModuleSpec | None = None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        module = importlib.import_module(self.target)
        self.spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        # the import system stamped the alias' spec on the real module: give it its own back
        module.__spec__ = self.spec


class _AliasFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname: str, path: object = None, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        new = ALIASES.get(fullname)
        if new is None:
            return None
        return importlib.util.spec_from_loader(fullname, _AliasLoader(new))


def install(eager: tuple[str, ...] = ()) -> None:
    """Put the finder on ``sys.meta_path`` once; register ``eager`` aliases (of modules already
    imported) now, so that their first import cannot replace an attribute of ``vadsim`` that
    has the same name (``vadsim.simulate`` is the function, not the module)."""
    if not any(isinstance(f, _AliasFinder) for f in sys.meta_path):
        sys.meta_path.append(_AliasFinder())
    for old in eager:
        sys.modules.setdefault(old, sys.modules[ALIASES[old]])
