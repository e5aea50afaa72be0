"""Type stubs of the C++ extension tubempc._core."""

from typing import Any

from . import _so3

so3 = _so3

__version__: str

def build_info() -> dict[str, Any]: ...
