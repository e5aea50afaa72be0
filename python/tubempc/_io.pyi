"""Type stubs of tubempc._core.io: scenario files (see cpp/include/tubempc/io/scenario.hpp)."""

import numpy as np
import numpy.typing as npt

from ._actuators import ActuationSettings, MomentumDumpSettings, ReactionWheelSpec, ThrusterSpec
from ._control import AbortSettings, ControllerDesigns, ControllerSettings
from ._dynamics import ModelParams, PropagatorSettings
from ._mpc import Reference, Settings, Tube
from ._nav import Landmark, NavigationSettings

_Arr = npt.NDArray[np.float64]

__all__ = [
    "FORMAT_VERSION",
    "ActuatorScenario",
    "BodyModel",
    "NavigationScenario",
    "ScenarioFile",
    "read_scenario",
    "write_scenario",
]

FORMAT_VERSION: int

class BodyModel:
    params: ModelParams
    def __init__(self) -> None: ...
    @staticmethod
    def field_names() -> list[str]: ...
    density: float
    shape: str
    shape_unit_scale: float
    def validate(self) -> None: ...

class NavigationScenario:
    enabled: bool
    settings: NavigationSettings
    landmarks: list[Landmark]
    seed: int
    error_set_scale: float
    def __init__(self) -> None: ...

class ActuatorScenario:
    enabled: bool
    thrusters: list[ThrusterSpec]
    wheels: list[ReactionWheelSpec]
    momentum_dump: MomentumDumpSettings
    wheel_momentum: _Arr
    settings: ActuationSettings
    def __init__(self) -> None: ...

class AbortScenario:
    enabled: bool
    settings: AbortSettings
    hover: Reference
    designs: ControllerDesigns
    command_step: int
    def __init__(self) -> None: ...

class ScenarioFile:
    directory: str
    model: BodyModel
    truth: BodyModel
    propagator: PropagatorSettings
    settings: Settings
    reference: Reference
    tube: Tube
    has_controller: bool
    controller: ControllerSettings
    tbmpc_designs: ControllerDesigns
    ffa_designs: ControllerDesigns
    x0: _Arr
    xf: _Arr
    navigation: NavigationScenario
    abort: AbortScenario
    actuators: ActuatorScenario
    def __init__(self) -> None: ...
    @property
    def mission_steps(self) -> int: ...
    def resolve(self, path: str) -> str: ...

def read_scenario(path: str) -> ScenarioFile: ...
def write_scenario(path: str, scenario: ScenarioFile, comment: str = "") -> None: ...
