"""Type stubs of the C++ extension tubempc._core."""

from typing import Any

from . import _actuators as actuators
from . import _control as control
from . import _dynamics as dynamics
from . import _gravity as gravity
from . import _io as io
from . import _mpc as mpc
from . import _nav as nav
from . import _so3 as so3

__all__ = ["__version__", "actuators", "build_info", "control", "dynamics", "gravity", "io", "mpc", "nav", "so3"]

__version__: str

def build_info() -> dict[str, Any]: ...
