"""The Basilisk plant (``simulation.plant = "basilisk"``; docs/model.md "Basilisk plant").

Basilisk (``bsk``, the optional extra ``basilisk``) propagates the truth instead of the project's C++
propagator: its rigid spacecraft hub, its polyhedral gravity (``PolyhedralGravityModel``, mu = G rho V
of the truth's shape and density) on a body that its ``planetEphemeris`` spins about z_L, the Sun as a
point mass on the scenario's circular orbit (the solar tide: Basilisk subtracts the Sun's pull on the
central body, exact rather than Hill's linear term), the SRP of its ``radiationPressure`` cannonball,
and with ``spacecraft.actuators`` its thruster and reaction-wheel effectors. The controller, the
actuators' allocation and modulation and the navigation are unchanged; what crosses between the two is
the state (read from Basilisk's hub, converted into L), the force and torque of each segment of the
period (``extForceTorque``) and the thrusters' and wheels' commands.

Frames: Basilisk's inertial frame N has its origin at the asteroid (``planetEphemeris.zeroBase``) and
the axes of L at t = 0; the Sun circles it at the orbital rate n, so C_NL(t) = Rz(n t).

The traps Basilisk sets for such a plant, and what this module does about each (each pinned by a test
in tests/py/sim/test_basilisk.py):

- heliocentric states (``r_BN_N`` with the asteroid at 1 AU) round relative positions to about 3e-5 m,
  and the effectors that read the hub's position (SRP, gravity gradient) take it as inertial while a
  central body makes it body-relative: N's origin is the asteroid, so both are the same;
- a body without ``planetBodyInMsg`` does not rotate: the asteroid's message comes from
  ``planetEphemeris`` (right ascension 0, declination 90 deg, lst_0 = the spin angle at t = 0, the
  signed spin rate), which runs before the spacecraft;
- Basilisk takes mu, not density: mu = the truth gravity's G M;
- effectors that read a command message (thrusters, wheels) read it when they run, before the
  spacecraft integrates the step that ends then; Basilisk's thruster counts its firing from that time
  and switches only at the integrator's stages: the plant ends a step at every pulse's end and rewrites
  the time-stamped commands at every step;
- the RKF45 integrator with a central body misreports ``r_BN_N``: the plant keeps Basilisk's RK4;
- ``PolyhedralGravityModel`` takes its volume as ``sum |r1 . (r2 x r3)| / 6``, the mesh's only if it is
  star-shaped about the origin: a physical body's lobe, off the origin, is given mu = G rho times that
  volume (:func:`basilisk_volume`);
- the gravity effector adds to the spacecraft the pull of every non-central body on the central body's
  origin: for the parts of a heterogeneous body that pull is internal, and the plant takes it off;
- the eclipse module knows a body's radius only by a planet's name or as "custom" (the ephemeris's name).

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
from ..scenario.physical import PhysicalTruth
from .plant import ProjectPlant

__all__ = ["BasiliskPlant", "BasiliskPlantError", "BasiliskTruth", "basilisk_version", "split_increment", "unsupported"]

Array = npt.NDArray[np.float64]

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


def unsupported(scn: Scenario) -> list[str]:
    """What the scenario asks that the Basilisk plant does not represent, one reason per field (empty:
    it flies)."""
    cfg = scn.config
    reasons = []
    if cfg.simulation.integrator != "rk4":
        reasons.append(
            f'simulation.integrator = "{cfg.simulation.integrator}": the Basilisk plant integrates with Basilisk\'s '
            'RK4 (its RKF45 misreports the hub with a central body); set "rk4"'
        )
    return reasons


def basilisk_volume(vertices: Array, faces: npt.NDArray[np.int64]) -> float:
    """The volume Basilisk's ``PolyhedralGravityModel`` takes for a mesh (m^3): ``sum |r1 . (r2 x r3)| / 6`` over
    the faces, which is the mesh's volume only if it is star-shaped about the origin (a part of a
    heterogeneous body away from the origin is not)."""
    r = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    return float(np.abs(np.einsum("ij,ij->i", r[:, 0], np.cross(r[:, 1], r[:, 2]))).sum() / 6.0)


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
    the project's side one segment at a time with a constant force (in L) and torque (in B), and, with an
    actuation system, Basilisk's thrusters (on or off over the segment) and reaction wheels (motor torques).

    The plant is Basilisk's scheduler: it calls the modules' ``UpdateState`` in the task's priority order
    (ephemeris, actuators, external force, SRP, spacecraft; the same sequence ``ExecuteSimulation`` runs, to
    the bit) at the end of each integrator step, so that a step can end at any nanosecond: at a pulse's
    end, a sensor sample or the half period."""

    def __init__(
        self, scn: Scenario, state: Array, actuation: Any = None, truth: Any = None, physical: PhysicalTruth | None = None
    ) -> None:
        """``truth`` (a ``ProximityModel``) and ``physical``: the run's truth (a campaign's run may fly a dispersed
        one, :func:`tubempc.sim.setup.run_truth`); None: the scenario's."""
        reasons = unsupported(scn)
        if reasons:
            raise BasiliskPlantError(
                f"{scn.config.source}: the Basilisk plant cannot fly this scenario: " + "; ".join(reasons)
            )
        from Basilisk.architecture import astroConstants, messaging
        from Basilisk.simulation import extForceTorque, planetEphemeris, radiationPressure, spacecraft
        from Basilisk.simulation.polyhedralGravityModel import PolyhedralGravityModel
        from Basilisk.utilities import SimulationBaseClass, simIncludeGravBody

        truth, cfg = scn.truth if truth is None else truth, scn.config
        p = truth.params
        self.n = float(truth.mean_motion)
        self.R = float(p.orbit_radius)
        phys = scn.physical if physical is None else physical
        if phys is not None:  # the truth's mass and inertia
            self.mass, self.inertia_B = float(phys.mass_true), np.asarray(phys.inertia_true_B, dtype=np.float64)
        else:
            self.mass = IDEAL_MASS_KG if actuation is None else float(actuation.settings.mass)
            self.inertia_B = np.asarray(p.inertia_B, dtype=np.float64)
        self.max_step_ns = max(1, round(cfg.mpc.dt / cfg.simulation.substeps * _NS))
        self.t_ns = 0
        self._messaging = messaging
        sim = SimulationBaseClass.SimBaseClass()
        sim.SetProgressBar(False)
        process = sim.CreateNewProcess("tubempc")
        process.addTask(sim.CreateNewTask("plant", self.max_step_ns))
        eph = planetEphemeris.PlanetEphemeris()
        eph.ModelTag = "asteroid_ephemeris"
        # "custom": the name Basilisk's eclipse module needs to take the body's radius from rEqCustom
        eph.setPlanetNames(planetEphemeris.StringVector(["custom"]))
        oe = planetEphemeris.ClassicElements()
        oe.a, oe.e, oe.i, oe.Omega, oe.omega, oe.f = self.R, 0.0, 0.0, 0.0, 0.0, 0.0
        eph.planetElements = planetEphemeris.classicElementVector([oe])
        eph.rightAscension = planetEphemeris.DoubleVector([0.0])
        eph.declination = planetEphemeris.DoubleVector([math.pi / 2])
        eph.lst0 = planetEphemeris.DoubleVector([float(p.spin_angle0)])
        eph.rotRate = planetEphemeris.DoubleVector([float(p.spin_rate)])
        eph.zeroBase = "custom"  # N's origin at the asteroid: no heliocentric rounding, correct body-relative effectors
        gravity = truth.gravity
        factory = simIncludeGravBody.gravBodyFactory()
        sun = factory.createSun()
        sun.mu = float(p.mu_sun)
        self._sun_msg = messaging.SpicePlanetStateMsg()
        self._write_sun(0)
        sun.planetBodyInMsg.subscribeTo(self._sun_msg)
        # (name, vertices in A (m), faces, G M): the truth's homogeneous mesh, or its physical parts
        if phys is None:
            parts = [("asteroid", np.asarray(gravity.vertices), np.asarray(gravity.faces), float(gravity.gm))]
        else:
            g = float(_core.gravity.GRAVITATIONAL_CONSTANT)
            parts = []
            for i, part in enumerate(phys.parts):
                vertices, faces = np.asarray(part.shape.vertices) + part.offset_A, np.asarray(part.shape.faces)
                # Basilisk's density is mu / volPoly; its volPoly is right only for a mesh star-shaped about
                # the origin (module docstring): the mu it is given makes mu / volPoly = G rho
                parts.append(
                    (
                        "asteroid" if i == 0 else part.name,
                        vertices,
                        faces,
                        g * part.density * basilisk_volume(vertices, faces),
                    )
                )
        self.part_names = [name for name, *_ in parts]
        self.part_mu = [float(gm) for *_, gm in parts]  # m^3/s^2, as Basilisk was given them
        # Basilisk adds to the spacecraft's acceleration each non-central body's pull on the central body's
        # origin; for parts of the central body that pull is internal: the plant takes it off (in A, below)
        self._internal_pull_A = np.zeros(3)
        for i, (name, vertices, faces, gm) in enumerate(parts):
            body = factory.createCustomGravObject(name, gm)
            poly = PolyhedralGravityModel()
            poly.xyzVertex = np.asarray(vertices, dtype=np.float64).tolist()
            poly.orderFacet = (np.asarray(faces) + 1).tolist()
            body.gravityModel = poly
            body.planetBodyInMsg.subscribeTo(eph.planetOutMsgs[0])
            if i == 0:
                body.isCentralBody = True
            else:
                poly.muBody = gm
                poly.initializeParameters()
                self._internal_pull_A += np.asarray(poly.computeField([0.0, 0.0, 0.0]), dtype=np.float64).ravel()
        self._spin = (float(p.spin_angle0), float(p.spin_rate))
        sc = spacecraft.Spacecraft()
        sc.ModelTag = "spacecraft"
        factory.addBodiesTo(sc)
        models: list[tuple[Any, int]] = [(eph, 300)]  # the ephemeris first: gravity reads this step's body
        self.thrusters = self.wheels = None
        self._thruster_msg = self._wheel_msg = None
        hub_mass, hub_inertia = self.mass, self.inertia_B.copy()
        if actuation is not None:
            hub_mass, hub_inertia = self._add_actuators(sc, actuation, models, hub_mass, hub_inertia)
        sc.hub.mHub = hub_mass
        sc.hub.IHubPntBc_B = hub_inertia.tolist()
        self.hub_inertia_B = hub_inertia
        ext = extForceTorque.ExtForceTorque()
        ext.ModelTag = "command_and_disturbance"
        sc.addDynamicEffector(ext)
        if phys is None:
            srp = radiationPressure.RadiationPressure()
            srp.ModelTag = "srp"
            srp.setUseCannonballModel()
            a_srp = float(np.asarray(truth.srp_acceleration_L)[0])
            srp.coefficientReflection = 1.0
            # cannonball: |F| = C_R A (flux / c) (1 AU / d)^2; A from beta_SRP / R^2 = |F| / m at d = R
            au_m = astroConstants.AU * 1000.0
            srp.area = (
                a_srp * self.R**2 * self.mass * astroConstants.SPEED_LIGHT / (astroConstants.SOLAR_FLUX_EARTH * au_m**2)
            )
            srp.sunEphmInMsg.subscribeTo(self._sun_msg)
            self.srp_description: dict[str, Any] = {"model": "cannonball", "area_m2": float(srp.area)}
        else:
            srp = self._physical_effectors(sc, phys, models, eph)
        sc.addDynamicEffector(srp)
        models += [(ext, 200), (srp, 200), (sc, 100)]
        for model, priority in models:
            sim.AddModelToTask("plant", model, priority)
        r_N, v_N, sigma, omega = self.to_basilisk(0.0, state)
        sc.hub.r_CN_NInit = r_N.tolist()
        sc.hub.v_CN_NInit = v_N.tolist()
        sc.hub.sigma_BNInit = sigma.tolist()
        sc.hub.omega_BN_BInit = omega.tolist()
        sim.InitializeSimulation()
        self.sim, self.sc, self.ext = sim, sc, ext
        self._models = [m for m, _ in sorted(models, key=lambda mp: -mp[1])]
        self._states = [sc.dynManager.getStateObject(n) for n in ("hubPosition", "hubVelocity", "hubSigma", "hubOmega")]

    def _physical_effectors(self, sc: Any, phys: Any, models: list[tuple[Any, int]], eph: Any) -> Any:
        """The physical environment's terms in Basilisk: the flat plates (``facetSRPDynamicEffector``; areas
        scaled by the environment's solar pressure over Basilisk's 1368 W/m^2 / c, which it hard-codes), the
        body's shadow (``eclipse``: a sphere of the shadow radius, with penumbra, against the project's
        cylinder) and the gravity-gradient torque of every part (``GravityGradientEffector``, point masses
        at the origin whose mu add up to the truth's G M). Returns the SRP effector."""
        from Basilisk.simulation import GravityGradientEffector, eclipse, facetSRPDynamicEffector

        facet = facetSRPDynamicEffector.FacetSRPDynamicEffector()
        facet.ModelTag = "plates"
        bsk_pressure = 1368.0 / 299792458.0 * (149597870700.0 / self.R) ** 2
        scale = float(phys.pressure) / bsk_pressure if phys.srp else 0.0
        facet.setNumFacets(len(phys.plates))
        for plate in phys.plates:
            facet.addFacet(
                float(plate.area) * scale,
                np.eye(3).tolist(),
                np.asarray(plate.normal_B, dtype=np.float64).tolist(),
                [1.0, 0.0, 0.0],  # articulation axis, unused
                np.asarray(plate.center_B, dtype=np.float64).tolist(),
                float(plate.diffuse),
                float(plate.specular),
            )
        facet.sunInMsg.subscribeTo(self._sun_msg)
        if phys.shadow_radius > 0.0:
            shadow = eclipse.Eclipse()
            shadow.ModelTag = "shadow"
            shadow.sunInMsg.subscribeTo(self._sun_msg)
            shadow.addSpacecraftToModel(sc.scStateOutMsg)
            shadow.addPlanetToModel(eph.planetOutMsgs[0])
            shadow.rEqCustom = float(phys.shadow_radius)
            facet.sunEclipseInMsg.subscribeTo(shadow.eclipseOutMsgs[0])
            models.append((shadow, 280))
        if phys.gravity_gradient:
            gg = GravityGradientEffector.GravityGradientEffector()
            gg.ModelTag = "gravity_gradient"
            for name in self.part_names:
                gg.addPlanetName(name)
            sc.addDynamicEffector(gg)
            models.append((gg, 200))
        self.srp_description = {
            "model": "facetSRPDynamicEffector",
            "plates": len(phys.plates),
            "area_scale": scale,
            "shadow": "eclipse" if phys.shadow_radius > 0.0 else None,
            "gravity_gradient": bool(phys.gravity_gradient),
        }
        return facet

    def _add_actuators(
        self, sc: Any, actuation: Any, models: list[tuple[Any, int]], mass: float, inertia_B: Array
    ) -> tuple[float, Array]:
        """Basilisk's thruster and wheel effectors for the run's truth thrusters (position, misaligned
        direction, scale error as ``thrusterMagDisp``; minimum on-time 0: the project's modulation keeps it)
        and wheels (balanced, at the centre of mass, HR16-class rotor: Js = h_max / 6000 rpm); returns the
        hub's mass and inertia so that the spacecraft's totals are the scenario's."""
        from Basilisk.architecture import messaging
        from Basilisk.simulation import THRSimConfig, reactionWheelStateEffector, thrusterDynamicEffector

        cluster = actuation.cluster
        true_map = np.asarray(cluster.true_mapping, dtype=np.float64)
        thr = thrusterDynamicEffector.ThrusterDynamicEffector()
        thr.ModelTag = "thrusters"
        for j in range(len(cluster)):
            spec = cluster.thruster(j)
            force = true_map[:3, j]
            c = THRSimConfig.THRSimConfig()
            c.thrLoc_B = np.asarray(spec.position_B, dtype=np.float64).tolist()
            c.thrDir_B = (force / np.linalg.norm(force)).tolist()
            c.MaxThrust = float(spec.max_thrust)
            c.thrusterMagDisp = float(np.linalg.norm(force)) - 1.0
            c.steadyIsp = float(spec.isp)
            c.MinOnTime = 0.0
            thr.addThruster(c)
        self._thruster_msg = messaging.THRArrayOnTimeCmdMsg()
        thr.cmdsInMsg.subscribeTo(self._thruster_msg)
        sc.addDynamicEffector(thr)
        wheels = actuation.wheels
        h0 = np.asarray(wheels.momentum, dtype=np.float64)
        axes = np.asarray(wheels.axes_B, dtype=np.float64)
        rw = reactionWheelStateEffector.ReactionWheelStateEffector()
        rw.ModelTag = "wheels"
        omega_max = 6000.0 * 2.0 * math.pi / 60.0  # HR16-class rotor (Basilisk's Honeywell_HR16 preset)
        spin_inertia = []
        for j in range(len(wheels)):
            spec = wheels.wheel(j)
            g = axes[:, j] / np.linalg.norm(axes[:, j])
            seed = np.eye(3)[int(np.argmin(np.abs(g)))]
            w2 = np.cross(g, seed)
            w2 /= np.linalg.norm(w2)
            c = reactionWheelStateEffector.RWConfigPayload()
            c.gsHat_B = [[v] for v in g]
            c.w2Hat0_B = [[v] for v in w2]
            c.w3Hat0_B = [[v] for v in np.cross(g, w2)]
            c.rWB_B = [[0.0], [0.0], [0.0]]
            c.Js = float(spec.max_momentum) / omega_max
            c.Jt = c.Jg = 0.5 * c.Js
            c.mass = 0.0  # the wheels' mass is in the scenario's total; their inertia is taken off the hub's
            c.Omega = float(h0[j] / c.Js)
            c.Omega_max = omega_max
            c.u_max = float(spec.max_torque)
            c.u_min = 0.0
            c.fCoulomb = 0.0
            c.RWModel = messaging.BalancedWheels
            c.label = f"RW{j + 1}"
            rw.addReactionWheel(c)
            inertia_B = inertia_B - (c.Js * np.outer(g, g) + c.Jt * (np.eye(3) - np.outer(g, g)))
            spin_inertia.append(c.Js)
        sc.addStateEffector(rw)
        self._wheel_msg = messaging.ArrayMotorTorqueMsg()
        rw.rwMotorCmdInMsg.subscribeTo(self._wheel_msg)
        self.wheel_spin_inertia = np.array(spin_inertia)
        self.wheel_axes_B = axes / np.linalg.norm(axes, axis=0)
        self.thrusters, self.wheels = thr, rw
        models += [(thr, 250), (rw, 250)]
        return mass, inertia_B

    def _write_sun(self, t_ns: int) -> None:
        """The Sun's state relative to the asteroid at t_ns (the scenario's circular orbit, seen from the
        asteroid), time-stamped: Basilisk's gravity steps it by its velocity from there."""
        C_NL = _rz(self.n * t_ns / _NS)
        payload = self._messaging.SpicePlanetStateMsgPayload()
        payload.PositionVector = (-self.R * C_NL[:, 0]).tolist()
        payload.VelocityVector = (-self.R * self.n * C_NL[:, 1]).tolist()
        payload.J20002Pfix = np.eye(3).tolist()
        self._sun_msg.write(payload, t_ns)

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

    def wheel_momentum(self) -> Array:
        """The wheels' axial angular momenta Js (Omega + g^T omega_BN_B) (N m s; Omega relative to the body,
        from Basilisk's wheel states): what the motor torques change, h_j' = -u_j."""
        if self.wheels is None:
            return np.zeros(0)
        speeds = np.asarray(self.wheels.rwSpeedOutMsg.read().wheelSpeeds, dtype=np.float64)[: len(self.wheel_spin_inertia)]
        omega_BN_B = np.asarray(self._states[3].getState(), dtype=np.float64).ravel()
        return self.wheel_spin_inertia * (speeds + self.wheel_axes_B.T @ omega_BN_B)

    def advance(
        self,
        end_ns: int,
        a_L: Array,
        torque_B: Array,
        thrusters_on: npt.NDArray[np.bool_] | None = None,
        wheel_torque: Array | None = None,
    ) -> None:
        """Runs Basilisk to ``end_ns`` (ns) in equal steps of at most dt / simulation.substeps with the force
        m a_L (a_L in L, turned into N at the segment's midpoint: the controller holds u_p in L), the torque
        ``torque_B`` (N m, in B), the thrusters ``thrusters_on`` firing throughout and the wheels exerting
        ``wheel_torque`` (N m, on the spacecraft, about their axes) held."""
        if end_ns <= self.t_ns:
            raise ValueError(f"segment end {end_ns} ns is not after {self.t_ns} ns")
        mid = 0.5 * (self.t_ns + end_ns) / _NS
        theta = self._spin[0] + self._spin[1] * mid  # C_NA = Rz(theta_0 + omega_A t)
        internal = _rz(theta) @ self._internal_pull_A
        self.ext.extForce_N = (self.mass * (self.C_NL(mid) @ a_L - internal)).tolist()
        self.ext.extTorquePntB_B = np.asarray(torque_B, dtype=np.float64).tolist()
        n = -(-(end_ns - self.t_ns) // self.max_step_ns)
        start = self.t_ns
        for i in range(1, n + 1):
            t = start + (end_ns - start) * i // n
            self._write_sun(start + (end_ns - start) * (i - 1) // n)
            if self._thruster_msg is not None and thrusters_on is not None:
                cmd = self._messaging.THRArrayOnTimeCmdMsgPayload()
                # on over the step that ends now: a command of 1 ns from now (Basilisk honours a firing while
                # start + on-time >= the stage's time); rewritten, with its time stamp, at every step
                cmd.OnTimeRequest = np.where(thrusters_on, 1e-9, 0.0).tolist()
                self._thruster_msg.write(cmd, t)
            if self._wheel_msg is not None and wheel_torque is not None:
                motor = self._messaging.ArrayMotorTorqueMsgPayload()
                motor.motorTorque = (-np.asarray(wheel_torque, dtype=np.float64)).tolist()  # on the wheel
                self._wheel_msg.write(motor, t)
            for model in self._models:
                model.UpdateState(t)
        self.t_ns = end_ns


@dataclass
class BasiliskPlant(ProjectPlant):
    """The plant of one run in Basilisk (same interface as :class:`ProjectPlant`; ``propagator`` is
    unused: Basilisk integrates)."""

    bsk: BasiliskTruth | None = field(default=None, init=False)
    #: each thruster's force when it fires (N, in B: its true column of M34 times F_max), with actuators
    thrust_B: Array = field(default_factory=lambda: np.zeros((3, 0)), init=False)

    NAME = "basilisk"
    #: The drawn disturbance as forces and torques over the period's two halves (B1): the accelerometer is not
    #: told the forces (they stand for unmodelled gravity), the gyro measures the rate the torques give.
    DISTURBANCE_DELIVERY = "half_period_forces"

    def __post_init__(self) -> None:
        super().__post_init__()
        self.bsk = BasiliskTruth(self.scn, self.state, self.actuation, self.truth_model, self.physical)
        if self.actuation is not None:
            cluster = self.actuation.cluster
            self.thrust_B = np.asarray(cluster.true_mapping, dtype=np.float64)[:3] * np.asarray(
                cluster.max_thrust, dtype=np.float64
            )

    def step(self, k: int, u: Array) -> tuple[Array, Array]:
        """Propagates one control period in Basilisk with input ``u`` and the period's drawn disturbance
        (as a force and torque); returns x_{k+1} and the draw. With actuators, Basilisk's thrusters fire
        the truth's on-times as pulses centred in the period and its wheels exert the allocated torques."""
        assert self.bsk is not None
        scn, dt = self.scn, self.scn.config.mpc.dt
        t0_ns, dt_ns = round(k * dt * _NS), round(dt * _NS)
        if self.environment is None:
            u_applied = self.apply_actuators(k, u)
            w_p, w_r = self.disturbance.sample(k)
        else:  # physical: no draw; ideal actuators deliver with the truth's mass and errors (as the project's plant)
            if self.actuation is None:
                u_applied = np.asarray(self.environment.deliver(u, self.state[6:10]), dtype=np.float64)
                self.delivered = (u_applied, None)
            else:  # Basilisk's thrusters, with their own errors, deliver to the truth's mass
                u_applied = self.apply_actuators(k, u)
            w_p = w_r = np.zeros(6)
        half = 0.5 * dt
        a = split_increment(w_p[0:3], w_p[3:6], half)
        phi = np.asarray(_core.so3.log_map(self.state[6:10]), dtype=np.float64)
        d_theta_B = np.asarray(_core.so3.right_jacobian(phi), dtype=np.float64) @ w_r[0:3]
        alpha = split_increment(d_theta_B, w_r[3:6], half)
        nav = self.nav
        samples = {} if nav is None else {t0_ns + round((j + 1) * nav.h * _NS): j for j in range(nav.n_sub)}
        ends = {*samples, t0_ns + dt_ns // 2, t0_ns + dt_ns}
        st = self.delivered[1]
        pulse_start = pulse_end = wheel_torque = None
        # with thrusters and navigation: the velocity their pulses give per unit mass over each sub-step (B, m/s),
        # what an integrating accelerometer senses (the period-average u_applied is not what Basilisk applies)
        sensed_B = np.zeros((nav.n_sub, 3)) if nav is not None and st is not None else None
        if st is not None:  # Basilisk's thrusters and wheels deliver; the command itself is not applied
            # each pulse centred in the period (M34): its impulse's centroid is the period-average force's
            on_ns = np.round(np.asarray(st.on_time, dtype=np.float64) * _NS).astype(np.int64)
            pulse_start = t0_ns + (dt_ns - on_ns) // 2
            pulse_end = pulse_start + on_ns
            ends |= {int(e) for e in (*pulse_start, *pulse_end) if t0_ns < e < t0_ns + dt_ns}
            wheel_torque = np.asarray(st.wheel_torque, dtype=np.float64)
        start = t0_ns
        for end_ns in sorted(ends):
            second = int(start + end_ns > 2 * t0_ns + dt_ns)  # the segment's midpoint is in the second half
            a_L, torque = a[second], self.bsk.inertia_B @ alpha[second]
            if st is None:
                a_L, torque = a_L + u_applied[:3], torque + u_applied[3:]
                self.bsk.advance(end_ns, a_L, torque)
            else:
                assert pulse_start is not None and pulse_end is not None
                on = (pulse_start <= start) & (pulse_end >= end_ns) & (pulse_end > pulse_start)
                self.bsk.advance(end_ns, a_L, torque, on, wheel_torque)
                if sensed_B is not None and nav is not None:  # a segment lies inside one sub-step
                    sub = int((start - t0_ns) * nav.n_sub // dt_ns)
                    sensed_B[sub] += self.thrust_B @ on.astype(np.float64) * ((end_ns - start) / _NS / self.bsk.mass)
            if nav is not None and end_ns in samples:
                j = samples[end_ns]
                nav.t[j], nav.truth[j] = end_ns / _NS, self.bsk.state()
                srp_L = nav.srp_L if self.environment is None else self.environment.srp_acceleration_L(nav.truth[j])
                # the accelerometer senses the thrust and the SRP, not the drawn disturbance's forces (docs/model.md M39)
                if sensed_B is None:
                    thrust_L = u_applied[:3]
                else:  # the sub-step's mean, turned into L with the attitude the IMU turns it back with
                    C_LB = np.asarray(_core.so3.rotation_matrix(nav.truth[j][6:10]), dtype=np.float64)
                    thrust_L = C_LB @ sensed_B[j] / nav.h
                nav.accel[j] = thrust_L + np.asarray(srp_L, dtype=np.float64)
            start = end_ns
        self.state = state = self.bsk.state()
        x_next = self.truth_model.truth_to_state(state, scn.reference.x[k + 1, 6:9])
        return x_next, np.concatenate([w_p, w_r])

    def describe(self) -> dict[str, Any]:
        """Basilisk's version, its integrator step and the SRP area it flies (saved with the run)."""
        assert self.bsk is not None
        return {
            "name": self.NAME,
            "bsk": basilisk_version(),
            "integrator": "rk4",
            "max_step_s": self.bsk.max_step_ns / _NS,
            "mass_kg": self.bsk.mass,
            "srp": self.bsk.srp_description,
            "actuators": "ideal (extForceTorque)"
            if self.bsk.thrusters is None
            else "thrusterDynamicEffector, reactionWheelStateEffector",
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


def cross_check(
    scn: Scenario, inputs: Array | None = None, steps: int | None = None, *, dispersed_seed: int | None = None
) -> CrossCheck:
    """Flies ``inputs`` ((T, 6) [u_p (m/s^2, L); T (N m, B)]; default the reference's) open loop through
    both plants from x0, ideal actuators without mismatch and no additive disturbance (in a physical
    environment, its nominal truth, or with ``dispersed_seed`` the truth a campaign's run of that seed flies,
    :func:`tubempc.sim.setup.run_truth`). The project's plant evaluates its gravity field at every stage here
    (simulation.gravity_expansion_tolerance 0): the check is of the physics; the held expansion's own error
    against the exact field is ``tubempc bench integrator``'s."""
    import time

    from ..models.disturbances import ActuatorMismatch, AdditiveDisturbance
    from ..scenario.build import propagator_settings
    from .setup import run_truth

    truth, physical = run_truth(scn, 0 if dispersed_seed is None else dispersed_seed, dispersed_seed is not None)

    u_seq = np.asarray(scn.reference.u if inputs is None else inputs, dtype=np.float64)
    T = len(u_seq) if steps is None else min(int(steps), len(u_seq))
    zero = np.zeros((6, 6))
    state0 = scn.model.state_to_truth(scn.x0)
    settings = propagator_settings(scn.config)
    settings.gravity_expansion_tolerance = 0.0
    plants: list[ProjectPlant] = []
    for kind in (ProjectPlant, BasiliskPlant):
        plants.append(
            kind(
                scn,
                AdditiveDisturbance(zero, zero, seed=0),
                ActuatorMismatch(0, 0.0, 0.0, 0.0, 0.0),
                settings,
                state0.copy(),
                environment=None if physical is None else physical.environment(),
                truth=truth,
                physical=physical,
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
