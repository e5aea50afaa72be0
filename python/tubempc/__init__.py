"""tubempc: tube-based MPC with online disturbance identification for asteroid proximity operations.

SI units throughout; frames are named in argument names and docstrings (see PAPER_NOTES.md).
"""

from __future__ import annotations

from . import _core, mpc
from ._core import build_info, so3
from .mpc import LinearizedModel, LtiModel, TubeMPC, solve_qp

__version__: str = _core.__version__

__all__ = [
    "LinearizedModel",
    "LtiModel",
    "TubeMPC",
    "__version__",
    "build_info",
    "mpc",
    "so3",
    "solve_qp",
]
