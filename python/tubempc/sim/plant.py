"""The simulated plants a closed-loop run flies in (``simulation.plant``; docs/model.md "Simulated
disturbance and truth" and "Basilisk plant").

A plant owns the truth of one run: it takes the controller's command of each control period, applies the
actuators (ideal with the scenario's mismatch, or the scenario's thrusters and wheels), propagates the
truth over the period (sampling it for the sensors with navigation) and returns the next state x_{k+1}
with the disturbance it applied. :class:`ProjectPlant` is the project's own (the C++ propagator and the
additive disturbance of paper Eq. 16 and 18); :class:`tubempc.sim.basilisk.BasiliskPlant` is Basilisk's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..models.disturbances import ActuatorMismatch, AdditiveDisturbance
from ..models.dynamics import ProximityModel
from ..scenario.actuators import actuate
from ..scenario.build import P_STATES, R_STATES, Scenario
from ..scenario.navigation import Navigation, propagate_sampled
from ..scenario.physical import PhysicalTruth

__all__ = ["ProjectPlant"]

Array = npt.NDArray[np.float64]


@dataclass
class ProjectPlant:
    """The project's plant of one run: truth model, actuators, disturbance and truth state."""

    scn: Scenario
    disturbance: AdditiveDisturbance
    actuators: ActuatorMismatch
    propagator: Any  # _core.dynamics.PropagatorSettings
    state: Array  # 13-state [r_L, v_L, q_B/L, omega_BL_B] of the truth
    actuation: Any = None  # _core.actuators.ActuationSystem (spacecraft.actuators), or None: ideal
    delivered: Any = None  # the last period's (u_delivered, ActuationStep or None)
    nav: Navigation | None = None  # with navigation: propagated in sub-steps the sensors sample
    nav_error_set: Array = field(default_factory=lambda: np.zeros((0, 0)))  # E of the estimate flown
    environment: Any = None  # _core.dynamics.PhysicalEnvironment (disturbance.model = "physical"), or None
    truth: ProximityModel | None = None  # the run's truth model (None: the scenario's, Scenario.truth)
    physical: PhysicalTruth | None = None  # the run's physical truth (None: the scenario's, Scenario.physical)
    # A disturbance burst (faults.kind = "disturbance_burst"): (start s, end s, scale); the draw of a period
    # starting in [start, end) is multiplied by scale (beyond the identified set; docs/model.md M51)
    burst: tuple[float, float, float] | None = None
    # The run's held expansion of the truth's gravity (_core.gravity.ExpansionHold; simulation.gravity_expansion_tolerance
    # > 0, docs/model.md M42), carried from period to period; None: the field at every evaluation
    gravity_hold: Any = None

    #: The name ``simulation.plant`` gives this plant.
    NAME = "project"
    #: How this plant delivers the drawn disturbance (:data:`tubempc.scenario.navigation.DISTURBANCE_DELIVERIES`):
    #: added to the state at the period's end, which no sensor senses (docs/model.md M39).
    DISTURBANCE_DELIVERY = "jump"

    def __post_init__(self) -> None:
        if self.truth is None:
            self.truth = self.scn.truth
        if self.physical is None:
            self.physical = self.scn.physical
        tol = self.propagator.gravity_expansion_tolerance
        if tol > 0.0 and self.gravity_hold is None:
            self.gravity_hold = _core.gravity.ExpansionHold(0.0, tol)

    @property
    def truth_model(self) -> ProximityModel:
        """The run's truth model (``truth``, set in ``__post_init__``)."""
        assert self.truth is not None
        return self.truth

    def apply_actuators(self, k: int, u: Array) -> Array:
        """The input the actuators deliver over period k for the command ``u`` (kept in ``delivered``)."""
        if self.actuation is None:
            u_applied = np.concatenate([self.actuators.apply_acceleration(u[:3]), self.actuators.apply_torque(u[3:])])
            self.delivered = (u_applied, None)
        else:
            self.delivered = actuate(self.actuation, k * self.scn.config.mpc.dt, u, self.state)
            u_applied = self.delivered[0]
        return np.asarray(u_applied, dtype=np.float64)

    def step(self, k: int, u: Array) -> tuple[Array, Array]:
        """Propagates one control period with input ``u``; returns x_{k+1} and the disturbance drawn (zero in
        the physical environment, which draws none)."""
        if self.environment is not None:
            return self._step_physical(k, u)
        scn, dt = self.scn, self.scn.config.mpc.dt
        u_applied = self.apply_actuators(k, u)
        if self.nav is not None:
            end = propagate_sampled(
                self.nav, self.truth_model, k * dt, self.state, u_applied, self.propagator, gravity_hold=self.gravity_hold
            )
        else:
            prop = self.truth_model.propagate(
                k * dt, self.state, u_applied, dt, settings=self.propagator, gravity_hold=self.gravity_hold
            )
            if prop.status.name != "Success":
                raise RuntimeError(f"truth propagation failed at step {k}: {prop.status.name}")
            end = np.asarray(prop.state)
        w_p, w_r = self.disturbance.sample(k)
        if self.burst is not None and self.burst[0] <= k * dt < self.burst[1]:
            w_p, w_r = self.burst[2] * w_p, self.burst[2] * w_r
        x_next = self.truth_model.truth_to_state(end, scn.reference.x[k + 1, 6:9])
        x_next[P_STATES] += w_p
        x_next[R_STATES] += w_r
        self.state = self.truth_model.state_to_truth(x_next)
        if self.nav is not None:
            self.nav.truth[-1] = self.state  # the sensors' last sample is after the disturbance
        return x_next, np.concatenate([w_p, w_r])

    def _step_physical(self, k: int, u: Array) -> tuple[Array, Array]:
        """One period in the physical environment: the command (through the actuators, if any) delivered with the
        truth's mass and actuator errors at the period's start attitude, the environment's forces and torques
        in the C++ propagation, no additive draw."""
        scn, dt, env = self.scn, self.scn.config.mpc.dt, self.environment
        if self.actuation is None:
            u_cmd, st = u, None
        else:
            u_cmd, st = actuate(self.actuation, k * dt, u, self.state)
        u_applied = np.asarray(env.deliver(u_cmd, self.state[6:10]), dtype=np.float64)
        self.delivered = (u_applied, st)
        if self.nav is not None:
            end = propagate_sampled(
                self.nav, self.truth_model, k * dt, self.state, u_applied, self.propagator, env, self.gravity_hold
            )
        else:
            prop = self.truth_model.propagate(
                k * dt, self.state, u_applied, dt, settings=self.propagator, environment=env, gravity_hold=self.gravity_hold
            )
            if prop.status.name != "Success":
                raise RuntimeError(f"truth propagation failed at step {k}: {prop.status.name}")
            end = np.asarray(prop.state)
        self.state = end
        return self.truth_model.truth_to_state(end, scn.reference.x[k + 1, 6:9]), np.zeros(12)

    def describe(self) -> dict[str, Any]:
        """The plant's name and what it integrates with (saved with the run)."""
        p = self.propagator
        out: dict[str, Any] = {"name": self.NAME, "integrator": p.method.name.lower(), "substeps": int(p.substeps)}
        if self.gravity_hold is not None:  # the held expansion's tolerance, evaluations and largest error found
            h = self.gravity_hold
            out["gravity_hold"] = {
                "tolerance": h.tolerance,
                "evaluations": int(h.evaluations),
                "largest_error": h.largest_error,
            }
        return out
