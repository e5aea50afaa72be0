"""Type stubs of the C++ extension tubempc._core."""

from typing import Any

import numpy as np
import numpy.typing as npt

from . import _mpc as mpc
from . import _so3 as so3

__version__: str

def build_info() -> dict[str, Any]: ...
