"""Old import paths, kept working for one release (0.2) with a :class:`DeprecationWarning`.

Until 0.1 the package was one flat folder; it is now in rooms that follow the data (docs/layout.md).
A module that moved (``tubempc.closed_loop`` is now ``tubempc.sim.closed_loop``) is still importable
under its old name, which gives the new module itself; a name that moved out of a module
(``tubempc.scenario.tube_designers``, :data:`MOVED_NAMES`) is still an attribute there. Each use warns,
naming the new path. Four old modules became the packages of their rooms (``tubempc.config``,
``tubempc.scenario``, ``tubempc.results``, ``tubempc.analysis``): their names stay where they were, as
the package's attributes, without a warning (:func:`package_attribute`).
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

__all__ = ["MOVED_MODULES", "MOVED_NAMES", "install", "package_attribute"]

#: Old module -> its new place (the module object is the same).
MOVED_MODULES: dict[str, str] = {
    "tubempc.actuators": "tubempc.scenario.actuators",
    "tubempc.bodies": "tubempc.scenario.bodies",
    "tubempc.campaign": "tubempc.analysis.campaign",
    "tubempc.claims": "tubempc.analysis.claims",
    "tubempc.closed_loop": "tubempc.sim.closed_loop",
    "tubempc.disturbances": "tubempc.models.disturbances",
    "tubempc.dynamics": "tubempc.models.dynamics",
    "tubempc.export": "tubempc.results.export",
    "tubempc.figures": "tubempc.analysis.figures",
    "tubempc.fuzz": "tubempc.testing.fuzz",
    "tubempc.identification": "tubempc.testing.identification",
    "tubempc.landing_site": "tubempc.scenario.sites",
    "tubempc.machine": "tubempc.results.machine",
    "tubempc.metrics": "tubempc.analysis.metrics",
    "tubempc.mpc": "tubempc.models.mpc",
    "tubempc.navigation": "tubempc.scenario.navigation",
    "tubempc.pinning": "tubempc.results.pinning",
    "tubempc.reference": "tubempc.scenario.reference",
    "tubempc.report": "tubempc.analysis.report",
    "tubempc.runner": "tubempc.analysis.runner",
    "tubempc.shapes": "tubempc.scenario.shapes",
    "tubempc.summaries": "tubempc.results.summaries",
    "tubempc.tube": "tubempc.design.tube",
    "tubempc.tube_library": "tubempc.design.library",
    "tubempc.tube_policy": "tubempc.design.policy",
    "tubempc.view3d": "tubempc.analysis.view3d",
}

#: (module, name) -> the module that now defines the name.
MOVED_NAMES: dict[tuple[str, str], str] = {
    ("tubempc", "ForgettingFactorIdentifier"): "tubempc.testing.identification",
    ("tubempc.scenario", "tube_designers"): "tubempc.design.library",
    ("tubempc.scenario", "memory_weight"): "tubempc.design.library",
    ("tubempc.scenario", "initial_tube"): "tubempc.design.library",
    ("tubempc.scenario", "identifiers"): "tubempc.testing.identification",
    ("tubempc.scenario", "LoopSetup"): "tubempc.sim.setup",
}


def _warn(old: str, new: str) -> None:
    warnings.warn(
        f"{old} moved to {new}; the old path works until tubempc 0.3 (docs/layout.md)", DeprecationWarning, stacklevel=3
    )


class _Alias(importlib.abc.Loader):
    """Loads an old module name as the module at its new place. The import system sets the module's
    ``__spec__`` to the old name's between the two calls; :meth:`exec_module` gives it its own back (its
    relative imports, pickling and ``python -m`` read it)."""

    def __init__(self, new: str) -> None:
        self.new = new
        self.spec: importlib.machinery.ModuleSpec | None = None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        _warn(spec.name, self.new)
        module = importlib.import_module(self.new)
        self.spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run (the new module is already imported): restores its own spec."""
        module.__spec__ = self.spec


class _MovedModules(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname: str, path: Any, target: ModuleType | None = None) -> importlib.machinery.ModuleSpec | None:
        new = MOVED_MODULES.get(fullname)
        return None if new is None else importlib.util.spec_from_loader(fullname, _Alias(new))


def install() -> None:
    """Makes the old module names importable (called once by ``import tubempc``)."""
    if not any(isinstance(f, _MovedModules) for f in sys.meta_path):
        sys.meta_path.append(_MovedModules())


def moved_name(module: str, name: str) -> Any:
    """The value of a name that moved out of ``module``, with a warning; AttributeError if it did not."""
    new = MOVED_NAMES.get((module, name))
    if new is None:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    _warn(f"{module}.{name}", f"{new}.{name}")
    return getattr(importlib.import_module(new), name)


def package_attribute(package: str, main: str, name: str) -> Any:
    """A package's attribute ``name``: a submodule, a public name of its main module ``main`` (the old
    module the package replaced; not a module it imports), or a moved name (:func:`moved_name`). For a
    package's module-level ``__getattr__``: nothing heavy is imported before a name is asked for, and a
    submodule is looked up first (``from . import figures`` inside the package imports no other module)."""
    if not name.startswith("_") and importlib.util.find_spec(f"{package}.{name}") is not None:
        return importlib.import_module(f"{package}.{name}")
    module = importlib.import_module(main)
    value = getattr(module, name, None) if not name.startswith("_") else None
    if value is not None and not isinstance(value, ModuleType):
        return value
    return moved_name(package, name)
