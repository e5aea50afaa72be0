"""tubempc: tube-based MPC with online disturbance identification for asteroid proximity operations.

SI units throughout; frames are named in argument names and docstrings (see PAPER_NOTES.md).
"""

from __future__ import annotations

from . import _core, mpc
from ._core import build_info, so3
from ._core.gravity import GRAVITATIONAL_CONSTANT, PolyhedronGravity, Shape, ShapeRepair
from .config import Config, ConfigError, load_config
from .dynamics import (
    GravityModel,
    Kinematics,
    ModelParams,
    PointMassGravity,
    ProximityModel,
    glide_slope_constraint,
    line_of_sight_constraint,
    state_to_truth,
    truth_to_state,
)
from .identification import ForgettingFactorIdentifier
from .mpc import LinearizedModel, LtiModel, TubeMPC, solve_qp
from .shapes import ShapeError, bennu_like_shape, load_shape, save_icq, save_shape
from .tube import TubeDesigner, TubeResult, TubeStatus

__version__: str = _core.__version__

__all__ = [
    "GRAVITATIONAL_CONSTANT",
    "Config",
    "ConfigError",
    "ForgettingFactorIdentifier",
    "GravityModel",
    "Kinematics",
    "LinearizedModel",
    "LtiModel",
    "ModelParams",
    "PointMassGravity",
    "PolyhedronGravity",
    "ProximityModel",
    "Shape",
    "ShapeError",
    "ShapeRepair",
    "TubeDesigner",
    "TubeMPC",
    "TubeResult",
    "TubeStatus",
    "__version__",
    "bennu_like_shape",
    "build_info",
    "glide_slope_constraint",
    "line_of_sight_constraint",
    "load_config",
    "load_shape",
    "mpc",
    "save_icq",
    "save_shape",
    "so3",
    "solve_qp",
    "state_to_truth",
    "truth_to_state",
]
