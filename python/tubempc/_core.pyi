"""Type stubs of the C++ extension tubempc._core."""

from typing import Any

import numpy as np
import numpy.typing as npt

from . import _dynamics as dynamics
from . import _so3 as so3

__all__ = ["GravityModel", "PointMassGravity", "__version__", "build_info", "dynamics", "so3"]

__version__: str

def build_info() -> dict[str, Any]: ...

class GravityModel:
    def evaluate(
        self, r_A: npt.ArrayLike
    ) -> tuple[float, npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    @property
    def gm(self) -> float: ...

class PointMassGravity(GravityModel):
    def __init__(self, gm: float) -> None: ...
