"""The Basilisk plant (``simulation.plant = "basilisk"``; docs/model.md "Basilisk plant").

Basilisk (``bsk``, the optional extra ``basilisk``) propagates the truth instead of the project's C++
propagator: its rigid spacecraft hub, its polyhedral gravity (``PolyhedralGravityModel``, mu = G rho V
of the truth's shape and density) on a body that its ``planetEphemeris`` moves on the scenario's
circular heliocentric orbit and spins about z_L, the Sun as a point mass (the solar tide: Basilisk
subtracts the Sun's pull on the central body, exact rather than Hill's linear term), and the SRP of its
``radiationPressure`` cannonball. The controller, the actuators' model and the navigation are unchanged;
what crosses between the two is the state (read from Basilisk's hub, converted into L) and the force
and torque of each segment of the period (``extForceTorque``).

Frames: Basilisk's inertial frame N is heliocentric; the asteroid is at +R x_N at t = 0 on a prograde
orbit in the x_N y_N plane, so that L = N at t = 0 and C_NL(t) = Rz(n t). The hub's states are read from
Basilisk's state engine, relative to the asteroid (the central body), not from ``r_BN_N``, which is
heliocentric and rounds relative positions to about 3e-5 m.

The traps Basilisk sets for such a plant, and what this module does about each:

- the SRP effector takes the hub position (relative to the central body) as inertial, so the Sun's
  message holds the Sun's position relative to the asteroid, -r_A(t), written every period;
- a body without ``planetBodyInMsg`` does not rotate: the asteroid's message comes from
  ``planetEphemeris`` (right ascension 0, declination 90 deg, lst_0 = the spin angle at t = 0, the
  signed spin rate), which runs before the spacecraft in the task;
- Basilisk takes mu, not density: mu = the truth gravity's G M;
- a pulse is resolved at the integrator step only: the task's step divides every segment of the period
  (the half periods of the injected disturbance and the navigation's sensor sub-steps);
- the RKF45 integrator with a central body misreports ``r_BN_N``: the plant keeps Basilisk's default RK4;
- ``planetEphemeris`` moves the asteroid with Basilisk's own MU_SUN: a scenario with another
  ``environment.mu_sun`` is refused.

The paper's drawn disturbance (``disturbance.model = "drawn"``) enters Basilisk as a force and a torque:
the draw w_k = [dr, dv] (and [dphi, domega]) becomes two constant accelerations on the two halves of the
period whose double-integrator response is exactly w_k (:func:`split_increment`); Basilisk's dynamics
then carry it, so the increment it produces differs from the draw by the coupling over the period.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..scenario.build import Scenario
from .plant import ProjectPlant

__all__ = ["BasiliskPlant", "BasiliskPlantError", "BasiliskTruth", "basilisk_version", "split_increment", "unsupported"]

Array = npt.NDArray[np.float64]

#: Relative difference between ``environment.mu_sun`` and Basilisk's MU_SUN above which the plant refuses
#: the scenario (its ephemeris would not be the orbit the Sun's gravity gives).
MU_SUN_TOLERANCE = 1e-9
#: The hub's mass (kg) when the scenario has no actuators: the controller commands accelerations, the
#: plant applies the force m u_p and sizes the cannonball SRP area from beta_SRP m, so the mass cancels.
IDEAL_MASS_KG = 1000.0
_NS = 1_000_000_000


class BasiliskPlantError(ValueError):
    """A scenario the Basilisk plant cannot represent (the message names the fields)."""


def basilisk_version() -> str:
    """The installed bsk's version, or an error saying how to install it."""
    try:
        return metadata.version("bsk")
    except metadata.PackageNotFoundError:
        raise BasiliskPlantError(
            'simulation.plant = "basilisk" needs Basilisk: pip install "tubempc[basilisk]" (bsk)'
        ) from None


def _ns(seconds: float, what: str) -> int:
    ns = round(seconds * _NS)
    if ns <= 0 or abs(ns - seconds * _NS) > 1e-3:
        raise BasiliskPlantError(f"{what} = {seconds:g} s is not a whole number of nanoseconds (Basilisk's clock)")
    return ns


def task_step_ns(scn: Scenario) -> int:
    """Basilisk's integrator step (ns): dt / simulation.substeps, refined so that it divides the half
    period (the injected disturbance's segments) and, with navigation, the IMU's sub-step."""
    cfg = scn.config
    dt_ns = _ns(cfg.mpc.dt, "mpc.dt")
    step = _ns(cfg.mpc.dt / cfg.simulation.substeps, "mpc.dt / simulation.substeps")
    if dt_ns % step:
        raise BasiliskPlantError(f"simulation.substeps = {cfg.simulation.substeps} does not divide mpc.dt in whole ns")
    step = math.gcd(step, dt_ns // 2) if dt_ns % 2 == 0 else math.gcd(step, dt_ns)
    if cfg.navigation.enabled:
        step = math.gcd(step, _ns(cfg.navigation.imu_period, "navigation.imu_period"))
    if step * 1000 < dt_ns / cfg.simulation.substeps:
        raise BasiliskPlantError(
            f"mpc.dt = {cfg.mpc.dt:g} s, simulation.substeps and navigation.imu_period have no common step above {step} ns"
        )
    return step


def unsupported(scn: Scenario) -> list[str]:
    """What the scenario asks that the Basilisk plant does not represent, one reason per field (empty:
    it flies)."""
    cfg, p = scn.config, scn.truth.params
    reasons = []
    if cfg.simulation.integrator != "rk4":
        reasons.append(
            f'simulation.integrator = "{cfg.simulation.integrator}": the Basilisk plant integrates with Basilisk\'s '
            'RK4 (its RKF45 misreports the hub with a central body); set "rk4"'
        )
    if scn.actuation is not None:
        reasons.append(
            f"spacecraft.actuators = {cfg.spacecraft.actuators!r}: Basilisk's thruster and wheel effectors are not "
            "driven by this version of the plant; fly it on the project's plant"
        )
    try:
        from Basilisk.architecture import astroConstants

        mu_bsk = astroConstants.MU_SUN * 1e9
        if abs(p.mu_sun / mu_bsk - 1.0) > MU_SUN_TOLERANCE:
            reasons.append(
                f"environment.mu_sun = {p.mu_sun:.12g} m^3/s^2: Basilisk's planetEphemeris moves the asteroid with its "
                f"MU_SUN = {mu_bsk:.12g} m^3/s^2"
            )
    except ImportError:
        pass
    try:
        task_step_ns(scn)
    except BasiliskPlantError as exc:
        reasons.append(str(exc))
    return reasons


def split_increment(d_pos: Array, d_vel: Array, half: float) -> tuple[Array, Array]:
    """The two constant accelerations, on [0, h] and [h, 2 h] (h = ``half``), whose double-integrator
    response over 2 h is the increment (``d_pos``, ``d_vel``): a1 = dr/h^2 - dv/(2 h), a2 = 3 dv/(2 h) - dr/h^2."""
    a1 = d_pos / half**2 - 0.5 * d_vel / half
    a2 = 1.5 * d_vel / half - d_pos / half**2
    return a1, a2


def _rz(angle: float) -> Array:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


_Z = np.array([0.0, 0.0, 1.0])


class BasiliskTruth:
    """Basilisk's simulation of one run: the spacecraft hub near the scenario's truth body, advanced from
    the project's side one segment at a time with a constant force (in L) and torque (in B)."""

    def __init__(self, scn: Scenario, state: Array, mass_kg: float = IDEAL_MASS_KG) -> None:
        reasons = unsupported(scn)
        if reasons:
            raise BasiliskPlantError(
                f"{scn.config.source}: the Basilisk plant cannot fly this scenario: " + "; ".join(reasons)
            )
        from Basilisk.architecture import astroConstants, messaging
        from Basilisk.simulation import extForceTorque, planetEphemeris, radiationPressure, spacecraft
        from Basilisk.simulation.polyhedralGravityModel import PolyhedralGravityModel
        from Basilisk.utilities import SimulationBaseClass, simIncludeGravBody

        truth = scn.truth
        p = truth.params
        self.n = float(truth.mean_motion)
        self.R = float(p.orbit_radius)
        self.mass = float(mass_kg)
        self.inertia_B = np.asarray(p.inertia_B, dtype=np.float64)
        self.step_ns = task_step_ns(scn)
        self.t_ns = 0
        self._messaging = messaging
        sim = SimulationBaseClass.SimBaseClass()
        sim.SetProgressBar(False)
        process = sim.CreateNewProcess("tubempc")
        process.addTask(sim.CreateNewTask("plant", self.step_ns))
        eph = planetEphemeris.PlanetEphemeris()
        eph.ModelTag = "asteroid_ephemeris"
        eph.setPlanetNames(planetEphemeris.StringVector(["asteroid"]))
        oe = planetEphemeris.ClassicElements()
        oe.a, oe.e, oe.i, oe.Omega, oe.omega, oe.f = self.R, 0.0, 0.0, 0.0, 0.0, 0.0
        eph.planetElements = planetEphemeris.classicElementVector([oe])
        eph.rightAscension = planetEphemeris.DoubleVector([0.0])
        eph.declination = planetEphemeris.DoubleVector([math.pi / 2])
        eph.lst0 = planetEphemeris.DoubleVector([float(p.spin_angle0)])
        eph.rotRate = planetEphemeris.DoubleVector([float(p.spin_rate)])
        gravity = truth.gravity
        factory = simIncludeGravBody.gravBodyFactory()
        sun = factory.createSun()
        sun.mu = float(p.mu_sun)
        body = factory.createCustomGravObject("asteroid", float(gravity.gm))
        body.isCentralBody = True
        poly = PolyhedralGravityModel()
        poly.xyzVertex = np.asarray(gravity.vertices, dtype=np.float64).tolist()
        poly.orderFacet = (np.asarray(gravity.faces) + 1).tolist()
        body.gravityModel = poly
        body.planetBodyInMsg.subscribeTo(eph.planetOutMsgs[0])
        sc = spacecraft.Spacecraft()
        sc.ModelTag = "spacecraft"
        sc.hub.mHub = self.mass
        sc.hub.IHubPntBc_B = self.inertia_B.tolist()
        factory.addBodiesTo(sc)
        ext = extForceTorque.ExtForceTorque()
        ext.ModelTag = "command_and_disturbance"
        sc.addDynamicEffector(ext)
        srp = radiationPressure.RadiationPressure()
        srp.ModelTag = "srp"
        srp.setUseCannonballModel()
        a_srp = float(np.asarray(truth.srp_acceleration_L)[0])
        srp.coefficientReflection = 1.0
        # cannonball: |F| = C_R A (flux / c) (1 AU / d)^2; A from beta_SRP / R^2 = |F| / m at d = R
        au_m = astroConstants.AU * 1000.0
        srp.area = a_srp * self.R**2 * self.mass * astroConstants.SPEED_LIGHT / (astroConstants.SOLAR_FLUX_EARTH * au_m**2)
        self._sun_msg = messaging.SpicePlanetStateMsg()
        self._write_sun(0.0)
        srp.sunEphmInMsg.subscribeTo(self._sun_msg)
        sc.addDynamicEffector(srp)
        # the ephemeris before the spacecraft: its gravity reads the body's state of this step
        sim.AddModelToTask("plant", eph, 300)
        sim.AddModelToTask("plant", ext, 200)
        sim.AddModelToTask("plant", srp, 200)
        sim.AddModelToTask("plant", sc, 100)
        r_N, v_N, sigma, omega = self.to_basilisk(0.0, state)
        sc.hub.r_CN_NInit = r_N.tolist()
        sc.hub.v_CN_NInit = v_N.tolist()
        sc.hub.sigma_BNInit = sigma.tolist()
        sc.hub.omega_BN_BInit = omega.tolist()
        sim.InitializeSimulation()
        self.sim, self.sc, self.ext = sim, sc, ext
        self._states = [sc.dynManager.getStateObject(n) for n in ("hubPosition", "hubVelocity", "hubSigma", "hubOmega")]
        self.srp_area = float(srp.area)

    def _write_sun(self, t: float) -> None:
        payload = self._messaging.SpicePlanetStateMsgPayload()
        payload.PositionVector = (-self.R * _rz(self.n * t)[:, 0]).tolist()
        self._sun_msg.write(payload)

    def C_NL(self, t: float) -> Array:
        """The rotation from L to N at t (s)."""
        return _rz(self.n * t)

    def to_basilisk(self, t: float, state: Array) -> tuple[Array, Array, Array, Array]:
        """The 13-state [r_L, v_L, q_B/L, omega_BL_B] at t as Basilisk's hub states (r_BN_N and v_BN_N
        relative to the asteroid, sigma_BN, omega_BN_B)."""
        from Basilisk.utilities import RigidBodyKinematics

        C_NL = self.C_NL(t)
        r_L, v_L, q, w = state[0:3], state[3:6], state[6:10], state[10:13]
        C_BL = np.asarray(_core.so3.rotation_matrix(q)).T
        r_N = C_NL @ r_L
        v_N = C_NL @ (v_L + self.n * np.cross(_Z, r_L))
        sigma = np.asarray(RigidBodyKinematics.C2MRP(C_BL @ C_NL.T), dtype=np.float64)
        return r_N, v_N, sigma, w + C_BL @ (self.n * _Z)

    def from_basilisk(self, t: float, r_N: Array, v_N: Array, sigma: Array, omega_BN_B: Array) -> Array:
        """Basilisk's hub states at t as the 13-state (the inverse of :meth:`to_basilisk`)."""
        from Basilisk.utilities import RigidBodyKinematics

        C_NL = self.C_NL(t)
        r_L = C_NL.T @ r_N
        v_L = C_NL.T @ v_N - self.n * np.cross(_Z, r_L)
        C_BL = np.asarray(RigidBodyKinematics.MRP2C(sigma), dtype=np.float64) @ C_NL
        q = np.asarray(_core.so3.quat_from_rotation_matrix(C_BL.T), dtype=np.float64)
        return np.concatenate([r_L, v_L, q, omega_BN_B - C_BL @ (self.n * _Z)])

    @property
    def t(self) -> float:
        """Basilisk's time (s)."""
        return self.t_ns / _NS

    def state(self) -> Array:
        """The hub's state now, as the 13-state."""
        r, v, s, w = (np.asarray(o.getState(), dtype=np.float64).ravel() for o in self._states)
        return self.from_basilisk(self.t, r, v, s, w)

    def advance(self, t_end: float, a_L: Array, torque_B: Array) -> None:
        """Runs Basilisk to ``t_end`` (s; a multiple of the task step) with the force m a_L (a_L in L, turned
        into N at the segment's midpoint: the controller holds u_p in L) and the torque ``torque_B`` (N m,
        in B) held."""
        end_ns = round(t_end * _NS)
        if end_ns <= self.t_ns or (end_ns - self.t_ns) % self.step_ns:
            raise ValueError(f"segment end {t_end:g} s is not a step of {self.step_ns} ns after {self.t:g} s")
        mid = 0.5 * (self.t + t_end)
        self.ext.extForce_N = (self.mass * self.C_NL(mid) @ a_L).tolist()
        self.ext.extTorquePntB_B = np.asarray(torque_B, dtype=np.float64).tolist()
        self._write_sun(mid)
        self.sim.ConfigureStopTime(end_ns)
        self.sim.ExecuteSimulation()
        self.t_ns = end_ns


@dataclass
class BasiliskPlant(ProjectPlant):
    """The plant of one run in Basilisk (same interface as :class:`ProjectPlant`; ``propagator`` is
    unused: Basilisk integrates)."""

    bsk: BasiliskTruth | None = field(default=None, init=False)

    NAME = "basilisk"

    def __post_init__(self) -> None:
        self.bsk = BasiliskTruth(self.scn, self.state)

    def step(self, k: int, u: Array) -> tuple[Array, Array]:
        """Propagates one control period in Basilisk with input ``u`` and the period's drawn disturbance
        (as a force and torque); returns x_{k+1} and the draw."""
        assert self.bsk is not None
        scn, dt = self.scn, self.scn.config.mpc.dt
        t0 = k * dt
        u_applied = self.apply_actuators(k, u)
        w_p, w_r = self.disturbance.sample(k)
        half = 0.5 * dt
        a = split_increment(w_p[0:3], w_p[3:6], half)
        phi = np.asarray(_core.so3.log_map(self.state[6:10]), dtype=np.float64)
        d_theta_B = np.asarray(_core.so3.right_jacobian(phi), dtype=np.float64) @ w_r[0:3]
        alpha = split_increment(d_theta_B, w_r[3:6], half)
        nav = self.nav
        samples = {} if nav is None else {round((t0 + (j + 1) * nav.h) * _NS): j for j in range(nav.n_sub)}
        start = t0
        for end_ns in sorted({*samples, round((t0 + half) * _NS), round((t0 + dt) * _NS)}):
            end = end_ns / _NS
            second = int(0.5 * (start + end) > t0 + half)
            a_L = u_applied[:3] + a[second]
            torque = u_applied[3:] + self.bsk.inertia_B @ alpha[second]
            self.bsk.advance(end, a_L, torque)
            if nav is not None and end_ns in samples:
                j = samples[end_ns]
                nav.t[j], nav.truth[j] = end, self.bsk.state()
                nav.accel[j] = u_applied[:3] + nav.srp_L
            start = end
        self.state = state = self.bsk.state()
        x_next = scn.truth.truth_to_state(state, scn.reference.x[k + 1, 6:9])
        return x_next, np.concatenate([w_p, w_r])

    def describe(self) -> dict[str, Any]:
        """Basilisk's version, its integrator step and the SRP area it flies (saved with the run)."""
        assert self.bsk is not None
        return {
            "name": self.NAME,
            "bsk": basilisk_version(),
            "integrator": "rk4",
            "step_s": self.bsk.step_ns / _NS,
            "mass_kg": self.bsk.mass,
            "srp": {"model": "cannonball", "area_m2": self.bsk.srp_area, "coefficient_reflection": 1.0},
        }


@dataclass(frozen=True)
class CrossCheck:
    """The same open-loop inputs through the project's plant and Basilisk's, without the additive
    disturbance (:func:`cross_check`): per step k = 1..T, the differences of the states at t_k."""

    position_m: Array  # |r_L,bsk - r_L,project| (m)
    velocity_m_s: Array  # |v_L,bsk - v_L,project| (m/s)
    attitude_rad: Array  # angle of q_bsk (x) q_project^* (rad)
    rate_rad_s: Array  # |omega_bsk - omega_project| (rad/s)
    seconds_per_step: dict[str, float]  # median wall time of a plant's step, per plant name


def cross_check(scn: Scenario, inputs: Array | None = None, steps: int | None = None) -> CrossCheck:
    """Flies ``inputs`` ((T, 6) [u_p (m/s^2, L); T (N m, B)]; default the reference's) open loop through
    both plants from x0, ideal actuators without mismatch and no additive disturbance."""
    import time

    from ..models.disturbances import ActuatorMismatch, AdditiveDisturbance
    from ..scenario.build import propagator_settings

    u_seq = np.asarray(scn.reference.u if inputs is None else inputs, dtype=np.float64)
    T = len(u_seq) if steps is None else min(int(steps), len(u_seq))
    zero = np.zeros((6, 6))
    state0 = scn.model.state_to_truth(scn.x0)
    plants: list[ProjectPlant] = []
    for kind in (ProjectPlant, BasiliskPlant):
        plants.append(
            kind(
                scn,
                AdditiveDisturbance(zero, zero, seed=0),
                ActuatorMismatch(0, 0.0, 0.0, 0.0, 0.0),
                propagator_settings(scn.config),
                state0.copy(),
            )
        )
    diffs = np.zeros((T, 4))
    times = np.zeros((T, 2))
    for k in range(T):
        for i, plant in enumerate(plants):
            t0 = time.perf_counter()
            plant.step(k, u_seq[k])
            times[k, i] = time.perf_counter() - t0
        a, b = plants[0].state, plants[1].state
        dq = _core.so3.quat_mul(b[6:10], _core.so3.quat_conj(a[6:10]))
        diffs[k] = (
            float(np.linalg.norm(b[0:3] - a[0:3])),
            float(np.linalg.norm(b[3:6] - a[3:6])),
            2.0 * math.atan2(float(np.linalg.norm(dq[:3])), abs(float(dq[3]))),
            float(np.linalg.norm(b[10:13] - a[10:13])),
        )
    median = np.median(times, axis=0)
    return CrossCheck(
        diffs[:, 0], diffs[:, 1], diffs[:, 2], diffs[:, 3], {p.NAME: float(m) for p, m in zip(plants, median, strict=True)}
    )
