"""Type stubs of tubempc._core.dynamics: the 6-DOF proximity model (C++)."""

import enum
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from ._mpc import _OptionNames

_Vec = npt.ArrayLike
_Arr = npt.NDArray[np.float64]

class Kinematics(_OptionNames, enum.Enum):
    FirstOrder = 0
    Exact = 1

class Integrator(_OptionNames, enum.Enum):
    RK4 = 0
    DOPRI5 = 1

class PropagationStatus(_OptionNames, enum.Enum):
    Success = 0
    MaxStepsReached = 1
    StepTooSmall = 2
    NonFinite = 3

class ModelParams:
    def __init__(self) -> None: ...
    @staticmethod
    def field_names() -> list[str]: ...
    mu_sun: float
    orbit_radius: float
    beta_srp: float
    srp_enabled: bool
    inertia_B: _Arr
    spin_rate: float
    spin_angle0: float
    kinematics: Kinematics
    glide_slope_angle: float
    los_angle: float
    boresight_B: _Arr
    glide_slope_apex_A: _Arr
    glide_slope_axis_A: _Arr
    def validate(self) -> None: ...
    def mean_motion(self) -> float: ...

class PropagatorSettings:
    def __init__(self) -> None: ...
    def validate(self) -> None: ...
    @staticmethod
    def field_names() -> list[str]: ...
    method: Integrator
    substeps: int
    rtol: float
    atol: float
    max_steps: int
    initial_step: float

class PropagationResult:
    @property
    def status(self) -> PropagationStatus: ...
    @property
    def status_name(self) -> str: ...
    @property
    def state(self) -> _Arr: ...
    @property
    def t(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def rejected_steps(self) -> int: ...
    @property
    def evaluations(self) -> int: ...

class ProximityModel:
    def __init__(self, gravity: Any, params: ModelParams = ...) -> None: ...
    @property
    def params(self) -> ModelParams: ...
    @property
    def mean_motion(self) -> float: ...
    def spin_angle(self, t: float) -> float: ...
    def glide_slope_cone_L(self, t: float) -> tuple[_Arr, _Arr]: ...
    def C_AL(self, t: float) -> _Arr: ...
    def q_AL(self, t: float) -> _Arr: ...
    def gravity_L(self, t: float, r_L: _Vec) -> tuple[_Arr, _Arr]: ...
    def f(self, t: float, x: _Vec, u: _Vec) -> _Arr: ...
    def linearize(self, t: float, x: _Vec, u: _Vec) -> tuple[_Arr, _Arr, _Arr]: ...
    def discretize(self, t: float, dt: float, x_ref: _Vec, u_ref: _Vec) -> tuple[_Arr, _Arr, _Arr]: ...
    def discretize_horizon(self, t0: float, dt: float, x_ref: _Vec, u_ref: _Vec) -> tuple[_Arr, _Arr, _Arr]: ...
    def constraints(self, t: float, x: _Vec) -> tuple[_Arr, _Arr]: ...
    def truth_derivative(self, t: float, state: _Vec, u: _Vec, disturbance: _Vec) -> _Arr: ...
    def propagate(
        self,
        t0: float,
        state: _Vec,
        u: _Vec,
        dt: float,
        method: Integrator,
        substeps: int,
        rtol: float,
        atol: float,
        max_steps: int,
        initial_step: float,
        disturbance: _Vec,
        callback: Callable[[float, _Arr], _Vec] | None,
    ) -> PropagationResult: ...

def truth_to_state(state: _Vec, phi_ref: _Vec) -> _Arr: ...
def state_to_truth(x: _Vec) -> _Arr: ...
def glide_slope_constraint(
    x: _Vec, glide_slope_angle: float, apex_L: _Vec = ..., axis_L: _Vec = ...
) -> tuple[float, _Arr]: ...
def line_of_sight_constraint(x: _Vec, los_angle: float, boresight_B: _Vec) -> tuple[float, _Arr]: ...
def time_kernels(
    model: ProximityModel, t0: float, dt: float, x_ref: _Vec, u_ref: _Vec, repeats: int, batches: int
) -> dict[str, float]: ...
