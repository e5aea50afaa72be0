"""Scenario configuration: one TOML file with units, parsed into SI (docs/model.md
"Scenario", which names each value's setting and source).

Quantities are written with units: a scalar as a string ("0.55 m/s^2", "70 deg"), a vector
or matrix as a table {value = [...], unit = "m"}; dimensionless numbers (N, forgetting
factors, weights) as plain numbers; options as strings. Parsing uses pint; the result is a
tree of frozen dataclasses holding SI floats and read-only numpy arrays (angles in rad).
Every problem raises ConfigError naming the file and the dotted field.
"""

from __future__ import annotations

import hashlib
import importlib.resources
import json
import math
import re
import tomllib
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pint
import tomli_w
from numpy.typing import NDArray

from .. import _core

FloatArray = NDArray[np.float64]

_UREG: Any = pint.UnitRegistry()
_ANGLE_UNITS = frozenset({"radian", "degree", "arcminute", "arcsecond", "turn", "revolution", "milliradian"})
_DEFAULT = "bennu_paper.toml"


_Meta = dict[str, Any]


class ConfigError(ValueError):
    """Invalid scenario configuration; the message names the file and the dotted field."""


@dataclass(frozen=True)
class _Spec:
    """How one field is written in TOML and checked.

    unit: SI unit string of a quantity ("" for a dimensionless number), None for a string
    option or an integer; quantity: its name in messages; shape: () for a scalar; check: a
    predicate on the SI value with its description.
    """

    unit: str | None = ""
    quantity: str = "dimensionless"
    shape: tuple[int, ...] = ()
    check: tuple[Callable[[Any], bool], str] | None = None
    choices: tuple[str, ...] | None = None
    integer: bool = False
    boolean: bool = False


_Check = tuple[Callable[[Any], bool], str] | None


def _q(unit: str, quantity: str, shape: tuple[int, ...] = (), check: _Check = None) -> _Meta:
    """Field metadata of a quantity with an SI unit."""
    return {"spec": _Spec(unit, quantity, shape, check)}


def _num(shape: tuple[int, ...] = (), check: _Check = None) -> _Meta:
    """Field metadata of a dimensionless number or array."""
    return {"spec": _Spec("", "dimensionless", shape, check)}


def _int(check: _Check = None) -> _Meta:
    """Field metadata of an integer."""
    return {"spec": _Spec(None, "integer", (), check, integer=True)}


def _bool() -> _Meta:
    """Field metadata of a boolean (true or false)."""
    return {"spec": _Spec(None, "boolean", boolean=True)}


def _opt(*choices: str) -> _Meta:
    """Field metadata of a string option (any non-empty string if no choices)."""
    return {"spec": _Spec(None, "option", (), None, choices or None)}


_POS = (lambda v: bool(np.all(np.asarray(v) > 0.0)), "> 0")
_NONNEG = (lambda v: bool(np.all(np.asarray(v) >= 0.0)), ">= 0")
_UNIT_INTERVAL = (lambda v: 0.0 < v < 1.0, "in (0, 1)")
_FRACTION = (lambda v: 0.0 <= v < 1.0, "in [0, 1)")
_HALF_TURN = (lambda v: 0.0 < v < math.pi, "in (0, 180) deg")
_SIGN = (lambda v: v in (-1, 1), "+1 or -1")
_GE1 = (lambda v: v >= 1, ">= 1")
_INCREASING_POS = (lambda v: bool(0.0 < v[0] < v[1]), "two increasing values > 0")
_NONZERO = (lambda v: float(np.linalg.norm(v)) > 0.0, "non-zero")
_TOUCHDOWN_SPEED = (lambda v: 0.0 <= v <= 1.0, "in [0, 1] m/s")
_SPD = (
    lambda v: bool(np.allclose(v, np.asarray(v).T) and np.linalg.eigvalsh(v).min() > 0.0),
    "symmetric positive definite",
)


@dataclass(frozen=True, eq=False)
class EnvironmentSection:
    """Sun and solar radiation pressure (docs/model.md "Translational dynamics")."""

    mu_sun: float = field(metadata=_q("m^3/s^2", "gravitational parameter", check=_POS))
    R: float = field(metadata=_q("m", "length", check=_POS))  # heliocentric distance of the asteroid
    beta_srp: float = field(metadata=_q("m^3/s^2", "SRP coefficient", check=_POS))  # a_SRP = beta / R^2


@dataclass(frozen=True, eq=False)
class AsteroidSection:
    """Bennu gravity, spin and shape (docs/model.md "Gravity").

    shape: "generated" (the project's Bennu-like body) or a path to a shape file (relative paths
    are relative to the TOML file) whose coordinates are in ``shape_unit`` ("km" or "m"). spin_sign:
    +1 for a spin along +z_L (= z_A), -1 along -z_L. The gravitational constant is the core's
    (``tubempc.GRAVITATIONAL_CONSTANT``, CODATA 2018).
    """

    density: float = field(metadata=_q("kg/m^3", "density", check=_POS))
    spin_period: float = field(metadata=_q("s", "time", check=_POS))
    spin_sign: int = field(metadata=_int(check=_SIGN))
    shape: str = field(metadata=_opt())
    shape_unit: str = field(metadata=_opt("km", "m"))


@dataclass(frozen=True, eq=False)
class SpacecraftSection:
    """Inertia (B principal axes), input bounds, boresight and actuators (docs/model.md "Attitude",
    "Constraints", "Actuators in the closed loop"). actuators: "ideal" (the paper's continuous input
    inside u_max, T_max) or a preset name or TOML path (tubempc.scenario.actuators) whose achievable box then
    caps the bounds."""

    J: FloatArray = field(metadata=_q("kg*m^2", "moment of inertia", (3, 3), _SPD))
    u_max: float = field(metadata=_q("m/s^2", "acceleration", check=_POS))
    T_max: float = field(metadata=_q("N*m", "torque", check=_POS))
    boresight_B: FloatArray = field(metadata=_num((3,), _NONZERO))
    actuators: str = field(metadata=_opt())


@dataclass(frozen=True, eq=False)
class ConstraintsSection:
    """Glide-slope and line-of-sight half-angles (docs/model.md "Constraints"). The glide-slope cone
    is fixed in the body frame A: glide_slope_apex "centre" (the paper's) or "site" (the landing
    site's surface point; needs boundary.terminal = "site"); glide_slope_axis "z" (z_A = z_L, the
    paper's), "normal" (the site's outward surface normal) or "radial" (centre to site)."""

    glide_slope_angle: float = field(metadata=_q("rad", "angle", check=_HALF_TURN))
    los_angle: float = field(metadata=_q("rad", "angle", check=_HALF_TURN))
    glide_slope_apex: str = field(metadata=_opt("centre", "site"))
    glide_slope_axis: str = field(metadata=_opt("z", "normal", "radial"))


@dataclass(frozen=True, eq=False)
class MpcSection:
    """Discretisation, horizon, SCP threshold and weights (docs/model.md "Linearisation",
    "Tube MPC"). Weights are diagonals, dimensionless as in Table 1. horizon: N (nodes). scp_eps:
    the SCP stop on ||z* - z_ref|| (inf-norm). kinematics: "first_order" (the paper's phi' = w) or
    "exact" (phi' = Jr^-1(phi) w). input_cost: "absolute" (||v||^2_R, the paper's Problem 2) or
    "deviation" (||v - u_ref||^2_R). linearization: "reuse" (model data whose linearisation point
    lies within scp_eps of the plan are kept, across steps and SCP iterations) or "every_iteration"
    (Algorithm 1 literally: every node re-linearised about the latest plan at every SCP iteration).
    qp_solver: "active_set" (a primal-dual active set warm-started from the previous QP's active set,
    PIQP when it does not verify the KKT conditions) or "piqp" (PIQP's interior point only).
    scp_mode: "converge" (SCP iterations until the plan moves less than scp_eps, Algorithm 1) or
    "real_time" (one QP per step; the nodes it moved are re-linearised at the next step)."""

    dt: float = field(metadata=_q("s", "time", check=_POS))
    horizon: int = field(metadata=_int(check=_GE1))
    t_f: float = field(metadata=_q("s", "time", check=_POS))
    scp_eps: float = field(metadata=_num(check=_POS))
    Q_p: FloatArray = field(metadata=_num((6,), _NONNEG))
    Q_r: FloatArray = field(metadata=_num((6,), _NONNEG))
    R_p: FloatArray = field(metadata=_num((3,), _POS))
    R_r: FloatArray = field(metadata=_num((3,), _POS))
    kinematics: str = field(metadata=_opt(*_core.dynamics.Kinematics.names()))
    input_cost: str = field(metadata=_opt(*_core.mpc.InputCost.names()))
    linearization: str = field(metadata=_opt(*_core.mpc.Linearization.names()))
    qp_solver: str = field(metadata=_opt(*_core.mpc.QpSolver.names()))
    scp_mode: str = field(metadata=_opt(*_core.mpc.ScpMode.names()))

    @property
    def n_steps(self) -> int:
        """T = t_f / dt control steps."""
        return round(self.t_f / self.dt)


@dataclass(frozen=True, eq=False)
class BoundarySection:
    """Initial and terminal states (Table 2; docs/model.md "Scenario"): r, v in L (m, m/s),
    phi the rotation vector of q_B/L (rad), w = omega_B/L in B (rad/s). terminal: "paper"
    (rf, vf, phi_f, wf as given, in L), "altitude" (rf moved along its direction to
    terminal_altitude above the surface) or "site" (a landing site fixed in the body frame A,
    which moves in L as the body turns: site = "lat_lon" (site_latitude, site_longitude,
    planetocentric, longitude from x_A about z_A) or "vector" (below site_A, m in A); the surface
    point is found by ray casting on the shape and the target lies terminal_altitude above it
    along the local normal; the terminal velocity is the site's). terminal_attitude: "given"
    (phi_f, wf) or "boresight_down" (boresight along the inward normal, turning with the body;
    the attitude nearest phi_f). initial: "given" (r0, v0, phi0, w0) or "hover" (with a site:
    hovering hover_altitude above the site's surface point along its normal at t = 0, turning
    with the body, boresight down, the attitude nearest phi0). touchdown_speed (m/s, in [0, 1],
    default 0; needs terminal = "site" when > 0): the terminal velocity is the site's plus this speed
    along the inward normal, relative to the rotating surface (a touch-and-go contact)."""

    r0: FloatArray = field(metadata=_q("m", "length", (3,)))
    v0: FloatArray = field(metadata=_q("m/s", "velocity", (3,)))
    phi0: FloatArray = field(metadata=_q("rad", "angle", (3,)))
    w0: FloatArray = field(metadata=_q("rad/s", "angular velocity", (3,)))
    rf: FloatArray = field(metadata=_q("m", "length", (3,)))
    vf: FloatArray = field(metadata=_q("m/s", "velocity", (3,)))
    phi_f: FloatArray = field(metadata=_q("rad", "angle", (3,)))
    wf: FloatArray = field(metadata=_q("rad/s", "angular velocity", (3,)))
    terminal: str = field(metadata=_opt("paper", "altitude", "site"))
    terminal_altitude: float = field(metadata=_q("m", "length", check=_POS))
    site: str = field(metadata=_opt("lat_lon", "vector"))
    site_A: FloatArray = field(metadata=_q("m", "length", (3,)))
    site_latitude: float = field(metadata=_q("rad", "angle"))
    site_longitude: float = field(metadata=_q("rad", "angle"))
    terminal_attitude: str = field(metadata=_opt("given", "boresight_down"))
    initial: str = field(metadata=_opt("given", "hover"))
    hover_altitude: float = field(metadata=_q("m", "length", check=_POS))
    touchdown_speed: float = field(metadata=_q("m/s", "velocity", check=_TOUCHDOWN_SPEED))


@dataclass(frozen=True, eq=False)
class IdentificationSection:
    """Forgetting-factor identification (docs/model.md "Disturbance identification").

    measured_input: "residual" (default) or "reference_deviation" (literal Eq. 26);
    prior_memory: the prior's weight zeta(0) in units of the recursion's steady-state weight
    q / (1 - q), q = e^(lam - 1): 1 (default) counts the prior as one full memory, forgotten like
    every measurement at the rate q per step; 0 = the paper's literal recursion (forgotten at once);
    see identification.py and docs/decisions.md;
    pw_scale: P_W = pw_scale * S^; eig_floor: see ForgettingFactorIdentifier;
    feedforward: TBMPC-FFA cancels the identified mean input through its command (docs/model.md M43;
    false, the paper's method, by default), each component within feedforward_limit of the input bound
    (a box the tube's input-error set carries). Priors per 3-axis block: w0_* the mean, S0_* the per-axis
    variances (Table 1).
    """

    lambda_p: float = field(metadata=_num(check=_UNIT_INTERVAL))
    lambda_r: float = field(metadata=_num(check=_UNIT_INTERVAL))
    measured_input: str = field(metadata=_opt(*_core.control.MeasuredInput.names()))
    prior_memory: float = field(metadata=_num(check=_NONNEG))
    pw_scale: float = field(metadata=_num(check=_POS))
    eig_floor: float = field(metadata=_num(check=_POS))
    feedforward: bool = field(metadata=_bool())
    feedforward_limit: float = field(metadata=_num(check=_UNIT_INTERVAL))
    w0_p_position: FloatArray = field(metadata=_q("m", "length", (3,)))
    w0_p_velocity: FloatArray = field(metadata=_q("m/s", "velocity", (3,)))
    w0_r_attitude: FloatArray = field(metadata=_q("rad", "angle", (3,)))
    w0_r_rate: FloatArray = field(metadata=_q("rad/s", "angular velocity", (3,)))
    S0_p_position: FloatArray = field(metadata=_q("m^2", "length^2", (3,), _POS))
    S0_p_velocity: FloatArray = field(metadata=_q("m^2/s^2", "velocity^2", (3,), _POS))
    S0_r_attitude: FloatArray = field(metadata=_q("rad^2", "angle^2", (3,), _POS))
    S0_r_rate: FloatArray = field(metadata=_q("rad^2/s^2", "angular velocity^2", (3,), _POS))

    @property
    def w0_p(self) -> FloatArray:
        return np.concatenate([self.w0_p_position, self.w0_p_velocity])

    @property
    def w0_r(self) -> FloatArray:
        return np.concatenate([self.w0_r_attitude, self.w0_r_rate])

    @property
    def S0_p(self) -> FloatArray:
        return np.diag(np.concatenate([self.S0_p_position, self.S0_p_velocity]))

    @property
    def S0_r(self) -> FloatArray:
        return np.diag(np.concatenate([self.S0_r_attitude, self.S0_r_rate]))


@dataclass(frozen=True, eq=False)
class DisturbanceSection:
    """Simulated disturbance (disturbances.py): additive, uniform in the ellipsoids with the
    per-axis squared semi-axes S_*, plus actuator mismatch. Project defaults, not the
    paper's (which does not give its realisation). growth_p, growth_r: the ellipsoids' semi-axes
    grow linearly in time from 1 x at the first step to growth_* x at the last (1: stationary)."""

    seed: int = field(metadata=_int(check=(lambda v: v >= 0, ">= 0")))
    S_p_position: FloatArray = field(metadata=_q("m^2", "length^2", (3,), _NONNEG))
    S_p_velocity: FloatArray = field(metadata=_q("m^2/s^2", "velocity^2", (3,), _NONNEG))
    S_r_attitude: FloatArray = field(metadata=_q("rad^2", "angle^2", (3,), _NONNEG))
    S_r_rate: FloatArray = field(metadata=_q("rad^2/s^2", "angular velocity^2", (3,), _NONNEG))
    growth_p: float = field(metadata=_num(check=_NONNEG))
    growth_r: float = field(metadata=_num(check=_NONNEG))
    scale_error_p: float = field(metadata=_num(check=_FRACTION))
    misalignment_p: float = field(metadata=_q("rad", "angle", check=_FRACTION))
    scale_error_r: float = field(metadata=_num(check=_FRACTION))
    misalignment_r: float = field(metadata=_q("rad", "angle", check=_FRACTION))

    @property
    def S_p(self) -> FloatArray:
        return np.diag(np.concatenate([self.S_p_position, self.S_p_velocity]))

    @property
    def S_r(self) -> FloatArray:
        return np.diag(np.concatenate([self.S_r_attitude, self.S_r_rate]))


@dataclass(frozen=True, eq=False)
class TubeSection:
    """Tube design (paper Eq. 25; tube.py, tube_library.py) and update (the C++ controller,
    cpp/include/tubempc/control/tube_update.hpp). weighting: "mpc" takes C = [Q^1/2; 0],
    B2 = [0; R^1/2] from the MPC weights (the paper's choice); "normalized" weights Tr(Pe) by the
    inverse prior disturbance variances and Tr(Z) by 1/u_max^2, so the two terms are of one scale
    (project option). max_solves: cap on LMI solves per subsystem and design when warm-started.
    TBMPC-FFA: every step flies the certified Lyapunov update ("lyapunov", the only ``update``: no
    semidefinite program runs inside a step) of the current design's K and alpha for
    (1 + redesign_margin) P_W, else for P_W, else of a library design (the designs for
    P_W = c P_W0, c = library_ratio^j within library_range, computed at set-up); a new design is due
    every alpha_search_period steps and after a step that could not keep the margin. design_worker
    "process", "thread" or "inline": the due design is an LMI design computed in the background
    (tube_policy.py) and adopted design_delay >= 1 steps after it starts ("deterministic", a
    reproducible run, the same numbers with every worker) or as soon as it is done ("when_ready",
    never waits; needs a concurrent worker); "none": the due design is taken from the library at
    once (what a C++ program without Python flies)."""

    weighting: str = field(metadata=_opt("mpc", "normalized"))
    input_weight: float = field(metadata=_num(check=_POS))
    max_solves: int = field(metadata=_int(check=_GE1))
    alpha_search_period: int = field(metadata=_int(check=_GE1))
    redesign_margin: float = field(metadata=_num(check=_NONNEG))
    update: str = field(metadata=_opt("lyapunov"))
    design_delay: int = field(metadata=_int(check=_GE1))
    design_adoption: str = field(metadata=_opt("deterministic", "when_ready"))
    design_worker: str = field(metadata=_opt("process", "thread", "inline", "none"))
    library_range: FloatArray = field(metadata=_num((2,), check=_INCREASING_POS))
    library_ratio: float = field(metadata=_num(check=(lambda v: v > 1.0, "> 1")))


@dataclass(frozen=True, eq=False)
class SimulationSection:
    """Truth simulation (project options; docs/model.md "Attitude": the truth integrates the
    quaternion). integrator "rk4" with ``substeps`` per control step or "dopri5" (adaptive, rtol).
    Model mismatch between the controller and the truth: truth density = density_scale *
    asteroid.density, truth SRP = srp_scale * beta_srp, truth shape resolution
    ``truth_shape_subdivisions`` (0: the controller's shape). reference_input_fraction: the
    reference trajectory may use this fraction of u_max and T_max (margin for the tube).
    unconverged_reference: a reference whose SCP did not converge is an "error" (default) or, with
    "warn", flown with a warning and recorded as such."""

    integrator: str = field(metadata=_opt(*_core.dynamics.Integrator.names()))
    substeps: int = field(metadata=_int(check=_GE1))
    rtol: float = field(metadata=_num(check=_POS))
    density_scale: float = field(metadata=_num(check=_POS))
    srp_scale: float = field(metadata=_num(check=_NONNEG))
    truth_shape_subdivisions: int = field(metadata=_int(check=(lambda v: v >= 0, ">= 0")))
    reference_input_fraction: float = field(metadata=_num(check=(lambda v: 0.0 < v <= 1.0, "in (0, 1]")))
    unconverged_reference: str = field(metadata=_opt("error", "warn"))


_PROBABILITY = (lambda v: 0.0 <= v <= 1.0, "in [0, 1]")
_OPEN_PROBABILITY = (lambda v: 0.0 < v < 1.0, "in (0, 1)")
_RIGHT_ANGLE = (lambda v: 0.0 < v <= math.pi / 2, "in (0, 90] deg")
_FRAME_CAPACITY = (
    lambda v: 1 <= v <= _core.nav.MAX_LANDMARKS_PER_FRAME,
    f"in [1, {_core.nav.MAX_LANDMARKS_PER_FRAME}] (nav::kMaxLandmarksPerFrame)",
)


@dataclass(frozen=True, eq=False)
class NavigationSection:
    """Navigation in the loop (docs/model.md "Navigation", "Output-feedback tube"; navigation.py).
    enabled = false (default): the controller reads the true state, as the paper's. true: the plant is
    propagated in sub-steps of imu_period, the sensors sample it at their periods (each an integer
    multiple of imu_period, as mpc.dt is), the landmark catalogue holds ``landmarks`` points spread over
    the body plus ``site_landmarks`` on a disc of radius site_landmark_radius about the landing site (a
    site map, as OSIRIS-REx's natural-feature catalogue), the filter's estimate is what the controller flies on, and
    the state constraints are also tightened by the estimation-error set: the filter covariance's
    chi-square ellipsoid of probability error_set_probability (a probabilistic bound). The sensors'
    noise is also the filter's model of it. altimeter_boresight_B and camera_boresight_B: the beam and
    the optical axis in B (a file that leaves one out gets spacecraft.boresight_B:
    :data:`BORESIGHT_DEFAULTS`). period_noise: "disturbance" (the filter adds the covariance
    of the [disturbance] draw, at its largest growth, times period_noise_scale^2 at each period's end)
    or "none". Seeded from the run's seed."""

    enabled: bool = field(metadata=_bool())
    imu_period: float = field(metadata=_q("s", "time", check=_POS))
    gyro_noise_density: float = field(metadata=_q("rad/s/Hz^0.5", "angle random walk", check=_NONNEG))
    gyro_bias_sigma: float = field(metadata=_q("rad/s", "angular velocity", check=_NONNEG))
    gyro_bias_random_walk: float = field(metadata=_q("rad/s^2/Hz^0.5", "rate random walk", check=_NONNEG))
    accel_noise_density: float = field(metadata=_q("m/s^2/Hz^0.5", "velocity random walk", check=_NONNEG))
    accel_bias_sigma: float = field(metadata=_q("m/s^2", "acceleration", check=_NONNEG))
    accel_bias_random_walk: float = field(metadata=_q("m/s^3/Hz^0.5", "acceleration random walk", check=_NONNEG))
    imu_dropout: float = field(metadata=_num(check=_PROBABILITY))
    altimeter_boresight_B: FloatArray = field(metadata=_num((3,), _NONZERO))
    altimeter_period: float = field(metadata=_q("s", "time", check=_POS))
    altimeter_sigma: float = field(metadata=_q("m", "length", check=_NONNEG))
    altimeter_bias: float = field(metadata=_q("m", "length"))
    altimeter_min_range: float = field(metadata=_q("m", "length", check=_NONNEG))
    altimeter_max_range: float = field(metadata=_q("m", "length", check=_POS))
    altimeter_dropout: float = field(metadata=_num(check=_PROBABILITY))
    camera_boresight_B: FloatArray = field(metadata=_num((3,), _NONZERO))
    camera_period: float = field(metadata=_q("s", "time", check=_POS))
    camera_fov: float = field(metadata=_q("rad", "angle", check=_HALF_TURN))
    camera_pixels: int = field(metadata=_int(check=_GE1))
    camera_pixel_sigma: float = field(metadata=_num(check=_POS))
    camera_max_emission_angle: float = field(metadata=_q("rad", "angle", check=_RIGHT_ANGLE))
    camera_max_incidence_angle: float = field(
        metadata=_q("rad", "angle", check=(lambda v: 0.0 < v <= math.pi, "in (0, 180] deg"))
    )
    camera_min_range: float = field(metadata=_q("m", "length", check=_NONNEG))
    camera_max_range: float = field(metadata=_q("m", "length", check=_POS))
    camera_max_landmarks: int = field(metadata=_int(check=_FRAME_CAPACITY))
    camera_dropout: float = field(metadata=_num(check=_PROBABILITY))
    landmarks: int = field(metadata=_int(check=_GE1))
    site_landmarks: int = field(metadata=_int(check=(lambda v: v >= 0, ">= 0")))
    site_landmark_radius: float = field(metadata=_q("m", "length", check=_POS))
    star_tracker_period: float = field(metadata=_q("s", "time", check=_POS))
    star_tracker_sigma_B: FloatArray = field(metadata=_q("rad", "angle", (3,), _NONNEG))
    star_tracker_dropout: float = field(metadata=_num(check=_PROBABILITY))
    altimeter_terrain_sigma: float = field(metadata=_q("m", "length", check=_NONNEG))
    accel_model_noise: float = field(metadata=_q("m/s^2/Hz^0.5", "velocity random walk", check=_NONNEG))
    innovation_gate: float = field(metadata=_num(check=_POS))
    gravity_relinearization_distance: float = field(metadata=_q("m", "length", check=_NONNEG))
    gravity_expansion_tolerance: float = field(metadata=_q("m/s^2", "acceleration", check=_NONNEG))
    covariance_step: float = field(metadata=_q("s", "time", check=_NONNEG))
    initial_sigma_position: float = field(metadata=_q("m", "length", check=_NONNEG))
    initial_sigma_velocity: float = field(metadata=_q("m/s", "velocity", check=_NONNEG))
    initial_sigma_attitude: float = field(metadata=_q("rad", "angle", check=_NONNEG))
    period_noise: str = field(metadata=_opt("disturbance", "none"))
    period_noise_scale: float = field(metadata=_num(check=_NONNEG))
    error_set_probability: float = field(metadata=_num(check=_OPEN_PROBABILITY))


_SECTIONS: dict[str, type] = {
    "environment": EnvironmentSection,
    "asteroid": AsteroidSection,
    "spacecraft": SpacecraftSection,
    "constraints": ConstraintsSection,
    "mpc": MpcSection,
    "boundary": BoundarySection,
    "identification": IdentificationSection,
    "disturbance": DisturbanceSection,
    "tube": TubeSection,
    "simulation": SimulationSection,
    "navigation": NavigationSection,
}


@dataclass(frozen=True, eq=False)
class Config:
    """The whole scenario in SI. `source` (the file it came from) is not part of the content:
    it is left out of to_dict(), equality and hash()."""

    environment: EnvironmentSection
    asteroid: AsteroidSection
    spacecraft: SpacecraftSection
    constraints: ConstraintsSection
    mpc: MpcSection
    boundary: BoundarySection
    identification: IdentificationSection
    disturbance: DisturbanceSection
    tube: TubeSection
    simulation: SimulationSection
    navigation: NavigationSection
    source: str = "<memory>"
    defaulted: tuple[str, ...] = ()  # "section.field" taken from the packaged defaults (not content)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """TOML-ready content in SI units (load(save(c)) == c exactly)."""
        return {name: _section_to_dict(getattr(self, name)) for name in _SECTIONS}

    def save(self, path: str | Path) -> None:
        Path(path).write_bytes(tomli_w.dumps(self.to_dict()).encode())

    def hash(self) -> str:
        """sha256 of the canonical content (sorted JSON of to_dict())."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def with_overrides(self, overrides: Mapping[str, Any]) -> Config:
        """Copy with dotted fields replaced, e.g. {"identification.lambda_p": 0.97}.

        A value is SI (number or nested list) or, for a quantity, a string with its unit or
        a {value, unit} table; the result is validated like a file.
        """
        data = self.to_dict()
        for key, value in overrides.items():
            section, _, name = key.partition(".")
            if section not in data or name not in data[section]:
                raise ConfigError(f"{self.source} (override): {key}: unknown field")
            spec = _spec_of(_SECTIONS[section], name)
            data[section][name] = _encode(spec, value) if _is_si(spec, value) else value
        if "spacecraft.boresight_B" in overrides:  # a sensor left out of the file follows the boresight
            for section, name in BORESIGHT_DEFAULTS:
                if f"{section}.{name}" in self.defaulted and f"{section}.{name}" not in overrides:
                    data[section][name] = data["spacecraft"]["boresight_B"]
        changed = _parse(data, f"{self.source} (override)")
        return Config(
            **{name: getattr(changed, name) for name in _SECTIONS}, source=changed.source, defaulted=self.defaulted
        )

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Config) and self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(self.hash())


def _spec_of(cls: type, name: str) -> _Spec:
    for f in fields(cls):
        if f.name == name:
            spec: _Spec = f.metadata["spec"]
            return spec
    raise KeyError(name)


def _is_si(spec: _Spec, value: Any) -> bool:
    return bool(spec.unit) and not isinstance(value, (str, Mapping))


def _encode(spec: _Spec, value: Any) -> Any:
    """SI value -> its TOML form."""
    if spec.unit is None:
        return value
    if spec.shape == ():
        v = float(value)
        return f"{v!r} {spec.unit}" if spec.unit else v
    lst = np.asarray(value, dtype=np.float64).tolist()
    return {"value": lst, "unit": spec.unit} if spec.unit else lst


def _section_to_dict(section: Any) -> dict[str, Any]:
    return {f.name: _encode(f.metadata["spec"], getattr(section, f.name)) for f in fields(section)}


def _parse_field(spec: _Spec, raw: Any, where: str) -> Any:
    if spec.boolean:
        if not isinstance(raw, bool):
            raise ConfigError(f"{where}: expected true or false, got {raw!r}")
        return raw
    if spec.choices is not None or (spec.unit is None and not spec.integer):
        if not isinstance(raw, str) or not raw:
            raise ConfigError(f"{where}: expected a non-empty string, got {raw!r}")
        if spec.choices is not None and raw not in spec.choices:
            raise ConfigError(f"{where}: expected one of {list(spec.choices)}, got {raw!r}")
        return raw
    if spec.integer:
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise ConfigError(f"{where}: expected an integer, got {raw!r}")
        value: Any = raw
    elif spec.unit:
        value = _parse_quantity(spec, raw, where)
    else:
        value = _parse_array(spec, raw, where)
    if spec.check is not None:
        predicate, text = spec.check
        if not predicate(value):
            raise ConfigError(f"{where}: expected {text}, got {raw!r}")
    return value


def _parse_array(spec: _Spec, raw: Any, where: str) -> Any:
    if isinstance(raw, (bool, str, Mapping)):
        raise ConfigError(f"{where}: expected a number or array of numbers, got {raw!r}")
    try:
        arr = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: expected numbers, got {raw!r}") from exc
    if arr.shape != spec.shape:
        raise ConfigError(f"{where}: expected shape {spec.shape}, got {arr.shape} ({raw!r})")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"{where}: non-finite value in {raw!r}")
    if spec.shape == ():
        return float(arr)
    arr.setflags(write=False)
    return arr


def _angle_power(q: Any) -> int:
    """Total exponent of angle units in q (pint treats angles as dimensionless)."""
    return sum(round(float(p)) for name, p in q.unit_items() if name in _ANGLE_UNITS)


def _describe(q: Any) -> str:
    """Name of q's kind among the quantities of the schema, else its pint dimensionality."""
    for cls in _SECTIONS.values():
        for f in fields(cls):
            spec: _Spec = f.metadata["spec"]
            if spec.unit:
                ref = _UREG.Quantity(1.0, spec.unit)
                same = ref.dimensionality == q.dimensionality
                if same and _angle_power(ref) == _angle_power(q):
                    return spec.quantity
    return "dimensionless" if q.dimensionless else str(q.dimensionality)


# A power operator and what follows it: an exponent must be a plain number, not another power.
_POWER = re.compile(r"(?:\*\*|\^)\s*\(?\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)?\s*\)?\s*(\*\*|\^)?")
_MAX_EXPONENT = 10.0
_MAX_QUANTITY_CHARS = 200


def _check_powers(text: str, where: str) -> None:
    """Rejects what pint would take very long to evaluate (``10**10**10``: Python integers)."""
    if len(text) > _MAX_QUANTITY_CHARS:
        raise ConfigError(f"{where}: quantity text longer than {_MAX_QUANTITY_CHARS} characters")
    for m in _POWER.finditer(text):
        exponent, chained = m.group(1), m.group(2)
        try:
            ok = exponent is not None and chained is None and abs(float(exponent)) <= _MAX_EXPONENT
        except ValueError:
            ok = False
        if not ok:
            raise ConfigError(
                f"{where}: in {text[:60]!r}, every power must be a single number of magnitude "
                f"<= {_MAX_EXPONENT:g} (e.g. 'kg/m^3')"
            )


def _parse_quantity(spec: _Spec, raw: Any, where: str) -> Any:
    if spec.shape == ():
        if not isinstance(raw, str):
            raise ConfigError(f"{where}: expected a string with a unit like '1 {spec.unit}', got {raw!r}")
        text, magnitude = raw, None
    else:
        if not isinstance(raw, Mapping) or set(raw) != {"value", "unit"}:
            raise ConfigError(f'{where}: expected a table {{value = [...], unit = "{spec.unit}"}}, got {raw!r}')
        if not isinstance(raw["unit"], str):
            raise ConfigError(f"{where}.unit: expected a string, got {raw['unit']!r}")
        text, magnitude = (
            raw["unit"],
            _parse_array(spec, raw["value"], f"{where}.value"),
        )
    _check_powers(text, where)
    try:
        q: Any = _UREG.Quantity(text)
    except Exception as exc:  # pint raises several unrelated exception types
        raise ConfigError(f"{where}: cannot parse {text!r} as a quantity: {exc}") from exc
    if not all(math.isfinite(float(p)) for _, p in q.unit_items()):
        raise ConfigError(f"{where}: non-finite unit exponent in {text!r}")
    expected = _UREG.Quantity(1.0, spec.unit)
    if q.dimensionality != expected.dimensionality or _angle_power(q) != _angle_power(expected):
        raise ConfigError(f"{where}: expected {spec.quantity} [{spec.unit}], got {raw!r} [{_describe(q)}]")
    factor = float(q.to(spec.unit).magnitude)
    if magnitude is None:
        if not math.isfinite(factor):
            raise ConfigError(f"{where}: non-finite value {raw!r}")
        return factor
    scale = float(_UREG.Quantity(1.0, text).to(spec.unit).magnitude)
    arr = magnitude * scale
    arr.setflags(write=False)
    return arr


_S = TypeVar("_S")


class ConfigDeprecationWarning(FutureWarning):
    """A configuration file uses an old spelling (still read) or a field that is now ignored."""


#: Old field names (section, old) -> new name; read with a warning.
RENAMED_FIELDS: dict[tuple[str, str], str] = {("mpc", "N"): "horizon", ("mpc", "eps"): "scp_eps"}
#: Old option values (section, field, old) -> new value; read with a warning.
RENAMED_VALUES: dict[tuple[str, str, str], str] = {
    ("mpc", "input_cost", "paper"): "absolute",
    ("simulation", "integrator", "dopri"): "dopri5",
}
#: Fields that nothing read; ignored with a warning.
REMOVED_FIELDS: frozenset[tuple[str, str]] = frozenset(
    {("asteroid", "G"), ("asteroid", "shape_mean_radius"), ("disturbance", "model")}
)

#: Old fields whose meaning changed (section, old) -> how to write it now; a ConfigError.
REPLACED_FIELDS: dict[tuple[str, str], str] = {
    ("identification", "prior_weight"): (
        "replaced by prior_memory, the prior's weight in units of the steady-state weight q / (1 - q), "
        "q = e^(lambda - 1) (1: one full memory, the default; 0: the literal recursion, as prior_weight = 0)"
    ),
}


def _upgrade(section: str, raw: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The section with old spellings replaced (each with a ConfigDeprecationWarning)."""
    out: dict[str, Any] = {}
    for key, value in raw.items():
        if (section, key) in REPLACED_FIELDS:
            raise ConfigError(f"{where}.{key}: {REPLACED_FIELDS[(section, key)]}")
        if (section, key) in REMOVED_FIELDS:
            warnings.warn(
                f"{where}.{key}: the field is no longer used and is ignored; remove it",
                ConfigDeprecationWarning,
                stacklevel=4,
            )
            continue
        new = RENAMED_FIELDS.get((section, key))
        if new is not None:
            if new in raw:
                raise ConfigError(f"{where}.{key}: old name of {new}, which is also given; keep only {new}")
            warnings.warn(f"{where}.{key}: renamed to {new}; read as {new}", ConfigDeprecationWarning, stacklevel=4)
            key = new
        if isinstance(value, str) and (section, key, value) in RENAMED_VALUES:
            new_value = RENAMED_VALUES[(section, key, value)]
            warnings.warn(
                f"{where}.{key}: value {value!r} renamed to {new_value!r}; read as {new_value!r}",
                ConfigDeprecationWarning,
                stacklevel=4,
            )
            value = new_value
        out[key] = value
    return out


def _parse_section(
    cls: type[_S], section: str, raw: Any, where: str, defaults: Mapping[str, Any] | None, defaulted: list[str]
) -> _S:
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{where}: expected a table, got {raw!r}")
    raw = _upgrade(section, raw, where)
    names = [f.name for f in fields(cls)]  # type: ignore[arg-type]
    unknown = sorted(set(raw) - set(names))
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown field (known: {', '.join(names)})")
    missing = [n for n in names if n not in raw]
    if missing and defaults is None:
        raise ConfigError(f"{where}.{missing[0]}: missing field")
    raw = {**raw, **{n: defaults[n] for n in missing}} if defaults is not None else raw
    defaulted.extend(f"{section}.{n}" for n in missing)
    values = {
        f.name: _parse_field(f.metadata["spec"], raw[f.name], f"{where}.{f.name}")
        for f in fields(cls)  # type: ignore[arg-type]
    }
    return cls(**values)


#: Fields whose value in the paper scenario (bennu_paper.toml) belongs to that scenario alone: a file
#: that leaves them out (an own mission) gets these instead. The paper scenario's attitude disturbance
#: grows to 2.5x the prior's 3-sigma support (chosen to reproduce the paper's Figs. 10-11); an own
#: mission starts from a stationary disturbance inside the prior's 3-sigma ellipsoid.
OWN_MISSION_DEFAULTS: dict[tuple[str, str], Any] = {
    ("disturbance", "growth_p"): 1.0,
    ("disturbance", "growth_r"): 1.0,
}


#: Fields that a file leaving them out takes from its own spacecraft.boresight_B (not from the packaged
#: file): the altimeter's beam and the camera's optical axis lie along the boresight unless mounted otherwise.
BORESIGHT_DEFAULTS: tuple[tuple[str, str], ...] = (
    ("navigation", "altimeter_boresight_B"),
    ("navigation", "camera_boresight_B"),
)


def _with_boresight_defaults(data: Mapping[str, Any], defaults: Mapping[str, Any]) -> dict[str, Any]:
    """``defaults`` with the :data:`BORESIGHT_DEFAULTS` fields set to the boresight of ``data`` (the
    file's spacecraft.boresight_B, else the default's)."""
    spacecraft = data.get("spacecraft", {})
    given = spacecraft.get("boresight_B") if isinstance(spacecraft, Mapping) else None
    boresight = defaults["spacecraft"]["boresight_B"] if given is None else given
    out = {name: dict(section) for name, section in defaults.items()}
    for section, name in BORESIGHT_DEFAULTS:
        out[section][name] = boresight
    return out


def _packaged_defaults() -> dict[str, Any]:
    """The defaults of partial files: the packaged paper scenario's raw TOML content with
    :data:`OWN_MISSION_DEFAULTS` in place of the paper's engineered disturbance growth."""
    resource = importlib.resources.files("tubempc").joinpath("data", _DEFAULT)
    data = tomllib.loads(resource.read_text(encoding="utf-8"))
    for (section, name), value in OWN_MISSION_DEFAULTS.items():
        data[section][name] = value
    return data


def _check_shape_unit(data: Mapping[str, Any], source: str) -> None:
    """A partial file that names a shape file must say its unit: the packaged default ("km", for
    the PDS radar models) read a file in metres as a body 1000 times too large."""
    asteroid = data.get("asteroid", {})
    if not isinstance(asteroid, Mapping):
        return
    shape = asteroid.get("shape")
    if isinstance(shape, str) and shape != "generated" and "shape_unit" not in asteroid:
        raise ConfigError(
            f'{source}: asteroid.shape_unit: missing; give the unit of {shape!r}\'s coordinates, "m" or "km" '
            "(PDS radar models are in km, `tubempc make-body` writes metres); it is not inferred"
        )


def _parse(data: Mapping[str, Any], source: str, defaults: Mapping[str, Any] | None = None) -> Config:
    """A validated Config from TOML content; with ``defaults`` (raw content of a complete file),
    missing sections and fields are taken from it and listed in ``Config.defaulted``."""
    unknown = sorted(set(data) - set(_SECTIONS))
    if unknown:
        raise ConfigError(f"{source}: {unknown[0]}: unknown section (known: {', '.join(_SECTIONS)})")
    missing = [s for s in _SECTIONS if s not in data]
    if missing and defaults is None:
        raise ConfigError(f"{source}: {missing[0]}: missing section")
    if defaults is not None:
        defaults = _with_boresight_defaults(data, defaults)
    defaulted: list[str] = []
    sections: dict[str, Any] = {
        name: _parse_section(
            cls, name, data.get(name, {}), f"{source}: {name}", None if defaults is None else defaults[name], defaulted
        )
        for name, cls in _SECTIONS.items()
    }
    config = Config(**sections, source=source, defaulted=tuple(defaulted))
    _check_consistency(config)
    return config


def _multiple(period: float, base: float) -> bool:
    r = period / base
    return round(r) >= 1 and abs(r - round(r)) <= 1e-9 * r


def _check_navigation(c: Config) -> None:
    """The sensors' periods and mpc.dt are integer multiples of the IMU's; each range interval is non-empty."""
    n = c.navigation
    for name in ("altimeter_period", "camera_period", "star_tracker_period"):
        if not _multiple(getattr(n, name), n.imu_period):
            raise ConfigError(
                f"{c.source}: navigation.{name}: {getattr(n, name)} s is not an integer multiple of "
                f"navigation.imu_period = {n.imu_period} s"
            )
    if not _multiple(c.mpc.dt, n.imu_period):
        raise ConfigError(
            f"{c.source}: navigation.imu_period: mpc.dt = {c.mpc.dt} s is not an integer multiple of {n.imu_period} s"
        )
    if n.site_landmarks > 0 and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: navigation.site_landmarks: site landmarks need boundary.terminal = "site"')
    for sensor in ("altimeter", "camera"):
        lo, hi = getattr(n, f"{sensor}_min_range"), getattr(n, f"{sensor}_max_range")
        if not hi > lo:
            raise ConfigError(f"{c.source}: navigation.{sensor}_max_range: {hi} m must exceed {sensor}_min_range = {lo} m")


def _check_consistency(c: Config) -> None:
    _check_navigation(c)
    ratio = c.mpc.t_f / c.mpc.dt
    if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio):
        raise ConfigError(f"{c.source}: mpc.t_f: {c.mpc.t_f} s is not a multiple of mpc.dt = {c.mpc.dt} s")
    if c.constraints.glide_slope_apex == "site" and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: constraints.glide_slope_apex: "site" needs boundary.terminal = "site"')
    if c.constraints.glide_slope_axis != "z" and c.boundary.terminal != "site":
        raise ConfigError(
            f'{c.source}: constraints.glide_slope_axis: {c.constraints.glide_slope_axis!r} needs boundary.terminal = "site"'
        )
    if c.boundary.initial == "hover" and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: boundary.initial: "hover" needs boundary.terminal = "site"')
    if c.boundary.touchdown_speed > 0.0 and c.boundary.terminal != "site":
        raise ConfigError(f'{c.source}: boundary.touchdown_speed: a touchdown speed needs boundary.terminal = "site"')
    if c.mpc.scp_mode == "real_time" and c.mpc.linearization != "reuse":
        raise ConfigError(f'{c.source}: mpc.scp_mode: "real_time" needs mpc.linearization = "reuse"')
    if c.mpc.horizon > c.mpc.n_steps:
        raise ConfigError(f"{c.source}: mpc.horizon: horizon {c.mpc.horizon} exceeds t_f / dt = {c.mpc.n_steps} steps")
    if c.spacecraft.actuators != "ideal":
        for name in ("scale_error_p", "misalignment_p", "scale_error_r", "misalignment_r"):
            if getattr(c.disturbance, name) != 0.0:
                raise ConfigError(
                    f"{c.source}: disturbance.{name}: must be 0 with spacecraft.actuators = {c.spacecraft.actuators!r} "
                    "(the actuator model draws its own thruster errors within the preset's bounds)"
                )
    if c.tube.design_adoption == "when_ready" and c.tube.design_worker == "inline":
        raise ConfigError(f'{c.source}: tube.design_adoption: "when_ready" needs a concurrent tube.design_worker')


#: Packaged scenarios (``tubempc scenarios``): name -> (file under tubempc/data, one-line description).
SCENARIOS: dict[str, tuple[str, str]] = {
    "bennu-paper": (_DEFAULT, "the paper's landing at Bennu's pole (Tables 1-2); the default"),
    "bennu-paper-within-prior": (
        "scenarios/bennu_paper_within_prior.toml",
        "the paper's landing with a stationary attitude disturbance inside the prior's 3-sigma bound",
    ),
    "bennu-equator": (
        "scenarios/bennu_equator.toml",
        "a site near Bennu's equator, approached from hovering 500 m above it; the cone turns with Bennu",
    ),
    "bennu-tag": (
        "scenarios/bennu_tag.toml",
        "touch-and-go at 56 deg N (as OSIRIS-REx's Nightingale) from hovering 125 m above, contact at 0.1 m/s",
    ),
    "bennu-tag-nav": (
        "scenarios/bennu_tag_nav.toml",
        "bennu-tag flown on navigation (camera, altimeter, IMU, star tracker, EKF), a lit site at 180 deg",
    ),
    "bennu-tag-osirisrex": (
        "scenarios/bennu_tag_osirisrex.toml",
        "bennu-tag over the real TAG's 20 min, flown by the OSIRIS-REx-like thrusters and wheels (5 s period)",
    ),
    "bennu-paper-nav": (
        "scenarios/bennu_paper_nav.toml",
        "the paper's landing flown on navigation: a thermal-infrared camera and an altimeter mounted to see the body",
    ),
    "itokawa-like": (
        "scenarios/itokawa_like.toml",
        "a generated 535 x 294 x 209 m contact binary (1900 kg/m^3, 12.13 h), a site on its smaller lobe",
    ),
}


def scenario_file(name: str) -> str:
    """Package-relative file of a packaged scenario; ConfigError naming the known ones."""
    if name not in SCENARIOS:
        raise ConfigError(f"unknown scenario {name!r} (known: {', '.join(SCENARIOS)}; see 'tubempc scenarios')")
    return SCENARIOS[name][0]


def load_config(path: str | Path | None = None, *, scenario: str | None = None) -> Config:
    """Load and validate a scenario TOML: a file, or the packaged scenario ``scenario`` (None and None:
    the packaged bennu_paper.toml). A file may leave out sections and fields: they are taken from
    the packaged bennu_paper.toml (but :data:`OWN_MISSION_DEFAULTS`, the paper scenario's own
    disturbance growth) and listed in ``Config.defaulted``. A file that names a shape file must give
    its ``asteroid.shape_unit``."""
    if path is not None and scenario is not None:
        raise ConfigError("give a configuration file or a packaged scenario, not both")
    packaged = scenario_file(scenario or "bennu-paper") if path is None else None
    if packaged is not None:
        resource = importlib.resources.files("tubempc").joinpath("data", *packaged.split("/"))
        text, source = resource.read_text(encoding="utf-8"), f"<package>/data/{packaged}"
    else:
        source = str(path)
        try:
            text = Path(source).read_text(encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"{source}: cannot read: {exc}") from exc
        except UnicodeDecodeError as exc:
            line = Path(source).read_bytes()[: exc.start].count(b"\n") + 1
            raise ConfigError(f"{source}:{line}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x})") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: invalid TOML: {exc}") from exc
    if packaged != _DEFAULT:
        _check_shape_unit(data, source)
    return _parse(data, source, None if packaged == _DEFAULT else _packaged_defaults())


__all__ = [
    "BORESIGHT_DEFAULTS",
    "OWN_MISSION_DEFAULTS",
    "REMOVED_FIELDS",
    "RENAMED_FIELDS",
    "RENAMED_VALUES",
    "REPLACED_FIELDS",
    "SCENARIOS",
    "AsteroidSection",
    "BoundarySection",
    "Config",
    "ConfigDeprecationWarning",
    "ConfigError",
    "ConstraintsSection",
    "DisturbanceSection",
    "EnvironmentSection",
    "IdentificationSection",
    "MpcSection",
    "NavigationSection",
    "SimulationSection",
    "SpacecraftSection",
    "TubeSection",
    "load_config",
    "scenario_file",
]
