"""tubempc: tube-based MPC with online disturbance identification for asteroid proximity operations.

SI units throughout; frames are named in argument names and docstrings (see docs/model.md).
Data flow: configuration (:mod:`tubempc.config`) -> scenario (:mod:`tubempc.scenario`) -> closed loop
(:mod:`tubempc.closed_loop`) -> run record (:mod:`tubempc.results`) -> metrics (:mod:`tubempc.metrics`)
-> report (:mod:`tubempc.report`).

The names below are imported on first use (``import tubempc`` loads only the compiled core), so that
the command line starts at once; ``tubempc.<module>`` works for every submodule.
"""

from __future__ import annotations

import importlib
from typing import Any

from . import _core

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
    "GravityModel": ".dynamics",
    "Kinematics": ".dynamics",
    "ModelParams": ".dynamics",
    "PointMassGravity": ".dynamics",
    "ProximityModel": ".dynamics",
    "glide_slope_constraint": ".dynamics",
    "line_of_sight_constraint": ".dynamics",
    "state_to_truth": ".dynamics",
    "truth_to_state": ".dynamics",
    "ForgettingFactorIdentifier": ".identification",
    "LinearizedModel": ".mpc",
    "LtiModel": ".mpc",
    "TubeMPC": ".mpc",
    "solve_qp": ".mpc",
    "RunRecord": ".results",
    "Scenario": ".scenario",
    "ScenarioError": ".scenario",
    "build_scenario": ".scenario",
    "simulate": ".closed_loop",
    "ShapeError": ".shapes",
    "bennu_like_shape": ".shapes",
    "load_shape": ".shapes",
    "save_icq": ".shapes",
    "save_shape": ".shapes",
    "TubeDesigner": ".tube",
    "DesignResult": ".tube",
    "DesignStatus": ".tube",
    "BackgroundDesigns": ".tube_policy",
    "controller_designs": ".tube_library",
    "load_actuators": ".actuators",
    "new_controller": ".tube_library",
}

__all__ = [
    "GRAVITATIONAL_CONSTANT",
    "BackgroundDesigns",
    "Config",
    "ConfigError",
    "DesignResult",
    "DesignStatus",
    "ForgettingFactorIdentifier",
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
        return importlib.import_module(f".{name}", __name__)  # a submodule: tubempc.figures, ...
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
