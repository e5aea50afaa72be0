"""tubempc: tube-based MPC with online disturbance identification for asteroid proximity operations.

SI units throughout; frames are named in argument names and docstrings (see PAPER_NOTES.md).
"""

from __future__ import annotations

from . import _core
from ._core import build_info, so3
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

__version__: str = _core.__version__

__all__ = [
    "GravityModel",
    "Kinematics",
    "ModelParams",
    "PointMassGravity",
    "ProximityModel",
    "__version__",
    "build_info",
    "glide_slope_constraint",
    "line_of_sight_constraint",
    "so3",
    "state_to_truth",
    "truth_to_state",
]
