"""tubempc: tube-based MPC with online disturbance identification for asteroid proximity operations.

SI units throughout; frames are named in argument names and docstrings (see docs/model.md).
The package's rooms follow the data (docs/layout.md): configuration (:mod:`tubempc.config`) -> models
(:mod:`tubempc.models`) -> scenario set-up (:mod:`tubempc.scenario`) -> tube designs
(:mod:`tubempc.design`) -> results (:mod:`tubempc.results`) -> closed loop (:mod:`tubempc.sim`) ->
analysis and reports (:mod:`tubempc.analysis`), with the command line (:mod:`tubempc.commands`) and the
benchmarks (:mod:`tubempc.benchmarks`) on top.

The names below are imported on first use (``import tubempc`` loads only the compiled core), so that
the command line starts at once; ``tubempc.<module>`` works for every submodule.
"""

from __future__ import annotations

import importlib
from typing import Any

from . import _core, compat

compat.install()

__version__: str = _core.__version__

#: Public name -> the module that defines it (imported on first access).
_LAZY = {
    "GRAVITATIONAL_CONSTANT": "._core.gravity",
    "PolyhedronGravity": "._core.gravity",
    "Shape": "._core.gravity",
    "ShapeRepair": "._core.gravity",
    "build_info": "._core",
    "so3": "._core",
    "Config": ".config",
    "ConfigError": ".config",
    "load_config": ".config",
    "GravityModel": ".models.dynamics",
    "Kinematics": ".models.dynamics",
    "ModelParams": ".models.dynamics",
    "PointMassGravity": ".models.dynamics",
    "ProximityModel": ".models.dynamics",
    "glide_slope_constraint": ".models.dynamics",
    "line_of_sight_constraint": ".models.dynamics",
    "state_to_truth": ".models.dynamics",
    "truth_to_state": ".models.dynamics",
    "LinearizedModel": ".models.mpc",
    "LtiModel": ".models.mpc",
    "TubeMPC": ".models.mpc",
    "solve_qp": ".models.mpc",
    "RunRecord": ".results.records",
    "Scenario": ".scenario.build",
    "ScenarioError": ".scenario.build",
    "build_scenario": ".scenario.build",
    "simulate": ".sim.closed_loop",
    "ShapeError": ".scenario.shapes",
    "bennu_like_shape": ".scenario.shapes",
    "load_shape": ".scenario.shapes",
    "save_icq": ".scenario.shapes",
    "save_shape": ".scenario.shapes",
    "TubeDesigner": ".design.tube",
    "DesignResult": ".design.tube",
    "DesignStatus": ".design.tube",
    "BackgroundDesigns": ".design.policy",
    "controller_designs": ".design.library",
    "load_actuators": ".scenario.actuators",
    "new_controller": ".design.library",
}

__all__ = [
    "GRAVITATIONAL_CONSTANT",
    "BackgroundDesigns",
    "Config",
    "ConfigError",
    "DesignResult",
    "DesignStatus",
    "GravityModel",
    "Kinematics",
    "LinearizedModel",
    "LtiModel",
    "ModelParams",
    "PointMassGravity",
    "PolyhedronGravity",
    "ProximityModel",
    "RunRecord",
    "Scenario",
    "ScenarioError",
    "Shape",
    "ShapeError",
    "ShapeRepair",
    "TubeDesigner",
    "TubeMPC",
    "__version__",
    "bennu_like_shape",
    "build_info",
    "build_scenario",
    "controller_designs",
    "glide_slope_constraint",
    "line_of_sight_constraint",
    "load_actuators",
    "load_config",
    "load_shape",
    "new_controller",
    "save_icq",
    "save_shape",
    "simulate",
    "so3",
    "solve_qp",
    "state_to_truth",
    "truth_to_state",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    try:
        return importlib.import_module(f".{name}", __name__)  # a room (tubempc.scenario) or an old module path
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
    return compat.moved_name(__name__, name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
