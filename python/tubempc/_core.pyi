"""Type stubs of the C++ extension tubempc._core."""

from typing import Any

from . import _mpc as mpc
from . import _so3 as so3

__all__ = ["__version__", "build_info", "mpc", "so3"]

__version__: str

def build_info() -> dict[str, Any]: ...
