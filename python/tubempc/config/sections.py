"""The sections of the configuration but [navigation] (navigation.py): frozen dataclasses in SI whose
fields each carry their declaration (fields.py) with its documentation line."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .fields import (
    AT_LEAST_ONE,
    HALF_TURN,
    NONNEGATIVE,
    NONZERO,
    POSITIVE,
    UNIT_INTERVAL,
    boolean,
    integer,
    number,
    option,
    quantity,
)

FloatArray = NDArray[np.float64]

_FRACTION = (lambda v: 0.0 <= v < 1.0, "in [0, 1)")
_SIGN = (lambda v: v in (-1, 1), "+1 or -1")
_INCREASING_POSITIVE = (lambda v: bool(0.0 < v[0] < v[1]), "two increasing values > 0")
_TOUCHDOWN_SPEED = (lambda v: 0.0 <= v <= 1.0, "in [0, 1] m/s")
_SPD = (
    lambda v: bool(np.allclose(v, np.asarray(v).T) and np.linalg.eigvalsh(v).min() > 0.0),
    "symmetric positive definite",
)


@dataclass(frozen=True, eq=False)
class EnvironmentSection:
    """Sun and solar radiation pressure (docs/model.md "Translational dynamics")."""

    mu_sun: float = field(metadata=quantity("gravitational parameter", "the Sun's gravitational parameter", check=POSITIVE))
    R: float = field(metadata=quantity("length", "heliocentric distance of the asteroid", check=POSITIVE))
    beta_srp: float = field(
        metadata=quantity("SRP coefficient", "SRP coefficient: a_SRP = beta_srp / R^2 along +x_L", check=POSITIVE)
    )


@dataclass(frozen=True, eq=False)
class AsteroidSection:
    """Bennu gravity, spin and shape (docs/model.md "Gravity"). The gravitational constant is the core's
    (``tubempc.GRAVITATIONAL_CONSTANT``, CODATA 2018)."""

    density: float = field(metadata=quantity("density", "bulk density of the body", check=POSITIVE))
    spin_period: float = field(metadata=quantity("time", "rotation period", check=POSITIVE))
    spin_sign: int = field(metadata=integer("+1: spin along +z_L (= z_A), -1: along -z_L", check=_SIGN))
    shape: str = field(
        metadata=option("\"generated\" (the project's Bennu-like body) or a shape file's path (relative to the TOML file)")
    )
    shape_unit: str = field(
        metadata=option(
            "unit of a shape file's coordinates (PDS radar models: km); a file naming a shape gives it", "km", "m"
        )
    )


@dataclass(frozen=True, eq=False)
class SpacecraftSection:
    """Inertia, input bounds, boresight and actuators (docs/model.md "Attitude", "Constraints",
    "Actuators in the closed loop")."""

    J: FloatArray = field(metadata=quantity("moment of inertia", "inertia matrix in the B principal axes", (3, 3), _SPD))
    u_max: float = field(metadata=quantity("acceleration", "per-axis bound of the translational input", check=POSITIVE))
    T_max: float = field(metadata=quantity("torque", "per-axis bound of the torque", check=POSITIVE))
    boresight_B: FloatArray = field(metadata=number("optical axis in B (the line-of-sight cone's axis)", (3,), NONZERO))
    input_gain_error: float = field(
        metadata=number(
            "ideal actuators: bound on the delivered input's relative error (the mass and thrust scale known to this "
            "fraction), carried by both methods' tubes as an input-error set (M38); 0: the paper's exact input",
            check=(lambda v: 0.0 <= v < 1.0, "in [0, 1)"),
        )
    )
    actuators: str = field(
        metadata=option(
            '"ideal" (the paper\'s continuous input within u_max, T_max) or an actuator preset name or TOML path, '
            "whose achievable box then caps the bounds (tubempc.scenario.actuators)"
        )
    )


@dataclass(frozen=True, eq=False)
class ConstraintsSection:
    """Glide-slope and line-of-sight cones (docs/model.md "Constraints"). The glide-slope cone is fixed in
    the body frame A; an apex or axis other than the paper's needs boundary.terminal = "site"."""

    glide_slope_angle: float = field(metadata=quantity("angle", "glide-slope half-angle (phi)", check=HALF_TURN))
    los_angle: float = field(metadata=quantity("angle", "line-of-sight half-angle (theta_LOS)", check=HALF_TURN))
    glide_slope_apex: str = field(
        metadata=option('the cone\'s apex: "centre" (the paper\'s) or "site" (the site\'s surface point)', "centre", "site")
    )
    glide_slope_axis: str = field(
        metadata=option(
            'the cone\'s axis: "z" (z_A = z_L, the paper\'s), "normal" (the site\'s outward surface normal) or '
            '"radial" (centre to site)',
            "z",
            "normal",
            "radial",
        )
    )


@dataclass(frozen=True, eq=False)
class MpcSection:
    """Discretisation, horizon, SCP and weights (docs/model.md "Linearisation", "Tube MPC"). Weights are
    diagonals, dimensionless as in Table 1."""

    dt: float = field(metadata=quantity("time", "control period", check=POSITIVE))
    horizon: int = field(metadata=integer("prediction horizon N (nodes)", check=AT_LEAST_ONE))
    t_f: float = field(metadata=quantity("time", "flight time, a multiple of dt", check=POSITIVE))
    scp_eps: float = field(metadata=number("SCP stop on ||z* - z_ref|| (inf-norm)", check=POSITIVE))
    Q_p: FloatArray = field(metadata=number("state weight of the translation", (6,), NONNEGATIVE))
    Q_r: FloatArray = field(metadata=number("state weight of the attitude", (6,), NONNEGATIVE))
    R_p: FloatArray = field(metadata=number("input weight of the translation", (3,), POSITIVE))
    R_r: FloatArray = field(metadata=number("input weight of the attitude", (3,), POSITIVE))
    kinematics: str = field(
        metadata=option(
            '"first_order" (the paper\'s phi\' = w) or "exact" (phi\' = Jr^-1(phi) w)', *_core.dynamics.Kinematics.names()
        )
    )
    input_cost: str = field(
        metadata=option(
            '"absolute" (||v||^2_R, the paper\'s Problem 2) or "deviation" (||v - u_ref||^2_R)',
            *_core.mpc.InputCost.names(),
        )
    )
    linearization: str = field(
        metadata=option(
            '"reuse" (model data linearised within scp_eps of the plan are kept, across steps and SCP iterations) '
            'or "every_iteration" (Algorithm 1 literally: every node re-linearised at every SCP iteration)',
            *_core.mpc.Linearization.names(),
        )
    )
    qp_solver: str = field(
        metadata=option(
            '"active_set" (warm-started primal-dual active set, PIQP when it does not verify the KKT conditions) '
            'or "piqp" (PIQP\'s interior point only)',
            *_core.mpc.QpSolver.names(),
        )
    )
    scp_mode: str = field(
        metadata=option(
            '"converge" (SCP iterations until the plan moves less than scp_eps, Algorithm 1) or "real_time" '
            "(one QP per step; the nodes it moved are re-linearised at the next step)",
            *_core.mpc.ScpMode.names(),
        )
    )

    @property
    def n_steps(self) -> int:
        """T = t_f / dt control steps."""
        return round(self.t_f / self.dt)


@dataclass(frozen=True, eq=False)
class BoundarySection:
    """Initial and terminal states (Table 2; docs/model.md "Scenario"): r, v in L, phi the rotation vector
    of q_B/L, w = omega_B/L in B. A landing site is fixed in the body frame A and moves in L as the body
    turns; its surface point is found by ray casting on the shape, the target lies terminal_altitude
    above it along the local normal, and the terminal velocity is the site's."""

    r0: FloatArray = field(metadata=quantity("length", "initial position in L", (3,)))
    v0: FloatArray = field(metadata=quantity("velocity", "initial velocity in L", (3,)))
    phi0: FloatArray = field(metadata=quantity("angle", "initial attitude (rotation vector of q_B/L)", (3,)))
    w0: FloatArray = field(metadata=quantity("angular velocity", "initial angular velocity omega_B/L in B", (3,)))
    rf: FloatArray = field(metadata=quantity("length", "terminal position in L", (3,)))
    vf: FloatArray = field(metadata=quantity("velocity", "terminal velocity in L", (3,)))
    phi_f: FloatArray = field(metadata=quantity("angle", "terminal attitude (rotation vector of q_B/L)", (3,)))
    wf: FloatArray = field(metadata=quantity("angular velocity", "terminal angular velocity omega_B/L in B", (3,)))
    terminal: str = field(
        metadata=option(
            '"paper" (rf, vf, phi_f, wf as given), "altitude" (rf moved along its direction to terminal_altitude '
            'above the surface) or "site" (a landing site fixed in the body frame A)',
            "paper",
            "altitude",
            "site",
        )
    )
    terminal_altitude: float = field(metadata=quantity("length", "target height above the surface", check=POSITIVE))
    site: str = field(
        metadata=option(
            'how the site is given: "lat_lon" (site_latitude, site_longitude) or "vector" (site_A)', "lat_lon", "vector"
        )
    )
    site_A: FloatArray = field(metadata=quantity("length", 'a point above the site in A (site = "vector")', (3,)))
    site_latitude: float = field(metadata=quantity("angle", "planetocentric latitude of the site"))
    site_longitude: float = field(metadata=quantity("angle", "longitude of the site, from x_A about z_A"))
    terminal_attitude: str = field(
        metadata=option(
            '"given" (phi_f, wf) or "boresight_down" (boresight along the inward normal, turning with the body; '
            "the attitude nearest phi_f)",
            "given",
            "boresight_down",
        )
    )
    initial: str = field(
        metadata=option(
            '"given" (r0, v0, phi0, w0) or "hover" (hovering hover_altitude above the site along its normal, turning '
            "with the body, boresight down, the attitude nearest phi0)",
            "given",
            "hover",
        )
    )
    hover_altitude: float = field(
        metadata=quantity("length", 'initial height above the site (initial = "hover")', check=POSITIVE)
    )
    touchdown_speed: float = field(
        metadata=quantity(
            "velocity",
            "terminal speed along the inward normal relative to the rotating surface, a touch-and-go contact "
            '(> 0 needs terminal = "site")',
            check=_TOUCHDOWN_SPEED,
        )
    )


@dataclass(frozen=True, eq=False)
class IdentificationSection:
    """Forgetting-factor identification (docs/model.md "Disturbance identification"). Priors per 3-axis
    block: w0_* the mean, S0_* the per-axis variances (Table 1)."""

    lambda_p: float = field(metadata=number("forgetting factor of the translation", check=UNIT_INTERVAL))
    lambda_r: float = field(metadata=number("forgetting factor of the attitude", check=UNIT_INTERVAL))
    measured_input: str = field(
        metadata=option('"residual" or "reference_deviation" (literal Eq. 26)', *_core.control.MeasuredInput.names())
    )
    prior_memory: float = field(
        metadata=number(
            "the prior's weight zeta(0) in units of the steady-state weight q / (1 - q), q = e^(lambda - 1): "
            "1 counts it as one full memory, 0 is the paper's literal recursion (docs/decisions.md)",
            check=NONNEGATIVE,
        )
    )
    pw_scale: float = field(metadata=number("P_W = pw_scale S^", check=POSITIVE))
    eig_floor: float = field(metadata=number("floor of S^'s eigenvalues, relative to the prior's variances", check=POSITIVE))
    feedforward: bool = field(
        metadata=boolean("TBMPC-FFA cancels the identified mean input through its command (M43; the paper: false)")
    )
    feedforward_limit: float = field(
        metadata=number(
            "each feed-forward component within this fraction of the input bound (a box the tube carries)",
            check=UNIT_INTERVAL,
        )
    )
    w0_p_position: FloatArray = field(metadata=quantity("length", "prior mean of the position disturbance", (3,)))
    w0_p_velocity: FloatArray = field(metadata=quantity("velocity", "prior mean of the velocity disturbance", (3,)))
    w0_r_attitude: FloatArray = field(metadata=quantity("angle", "prior mean of the attitude disturbance", (3,)))
    w0_r_rate: FloatArray = field(metadata=quantity("angular velocity", "prior mean of the rate disturbance", (3,)))
    S0_p_position: FloatArray = field(
        metadata=quantity("length^2", "prior variances of the position disturbance", (3,), POSITIVE)
    )
    S0_p_velocity: FloatArray = field(
        metadata=quantity("velocity^2", "prior variances of the velocity disturbance", (3,), POSITIVE)
    )
    S0_r_attitude: FloatArray = field(
        metadata=quantity("angle^2", "prior variances of the attitude disturbance", (3,), POSITIVE)
    )
    S0_r_rate: FloatArray = field(
        metadata=quantity("angular velocity^2", "prior variances of the rate disturbance", (3,), POSITIVE)
    )

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
    """Simulated disturbance (tubempc.models.disturbances): model = "drawn", additive, uniform in the
    ellipsoids with the per-axis squared semi-axes S_*, plus actuator mismatch (drawn in every run); model =
    "physical", the [physical] environment of the truth and no draw, the same actuator errors applied in B as
    dispersions (drawn in a Monte Carlo campaign's runs; a single run flies error-free actuators). Project
    defaults, not the paper's (which does not give its realisation)."""

    seed: int = field(metadata=integer("seed of the draws", check=NONNEGATIVE))
    model: str = field(
        metadata=option(
            '"drawn" (an additive draw per step, uniform in the S_* ellipsoids, the model the identification assumes) '
            'or "physical" (no draw: the [physical] environment of the truth; docs/model.md "Physical environment")',
            "drawn",
            "physical",
        )
    )
    S_p_position: FloatArray = field(
        metadata=quantity("length^2", "squared semi-axes of the position disturbance", (3,), NONNEGATIVE)
    )
    S_p_velocity: FloatArray = field(
        metadata=quantity("velocity^2", "squared semi-axes of the velocity disturbance", (3,), NONNEGATIVE)
    )
    S_r_attitude: FloatArray = field(
        metadata=quantity("angle^2", "squared semi-axes of the attitude disturbance", (3,), NONNEGATIVE)
    )
    S_r_rate: FloatArray = field(
        metadata=quantity("angular velocity^2", "squared semi-axes of the rate disturbance", (3,), NONNEGATIVE)
    )
    growth_p: float = field(
        metadata=number(
            "the translational semi-axes grow linearly from 1 x at the first step to this at the last (1: stationary)",
            check=NONNEGATIVE,
        )
    )
    growth_r: float = field(
        metadata=number(
            "the attitude semi-axes grow linearly from 1 x at the first step to this at the last (1: stationary)",
            check=NONNEGATIVE,
        )
    )
    scale_error_p: float = field(metadata=number("thrust scale error (ideal actuators only)", check=_FRACTION))
    misalignment_p: float = field(metadata=quantity("angle", "thrust misalignment (ideal actuators only)", check=_FRACTION))
    scale_error_r: float = field(metadata=number("torque scale error (ideal actuators only)", check=_FRACTION))
    misalignment_r: float = field(metadata=quantity("angle", "torque misalignment (ideal actuators only)", check=_FRACTION))

    @property
    def S_p(self) -> FloatArray:
        return np.diag(np.concatenate([self.S_p_position, self.S_p_velocity]))

    @property
    def S_r(self) -> FloatArray:
        return np.diag(np.concatenate([self.S_r_attitude, self.S_r_rate]))


@dataclass(frozen=True, eq=False)
class TubeSection:
    """Tube design (paper Eq. 25; tubempc.design) and update (the C++ controller,
    cpp/include/tubempc/control/tube_update.hpp). TBMPC-FFA: every step flies the certified Lyapunov
    update of the current design's K and alpha for (1 + redesign_margin) P_W, else for P_W, else of a
    library design (the designs for P_W = c P_W0, c = library_ratio^j within library_range, computed at
    set-up); a new design is due every alpha_search_period steps and after a step that could not keep
    the margin."""

    weighting: str = field(
        metadata=option(
            '"mpc" (C = [Q^1/2; 0], B2 = [0; R^1/2] from the MPC weights, the paper\'s) or "normalized" (Tr(Pe) '
            "weighted by the inverse prior disturbance variances, Tr(Z) by 1/u_max^2: one scale)",
            "mpc",
            "normalized",
        )
    )
    input_weight: float = field(metadata=number('multiplies the input term of the "normalized" weighting', check=POSITIVE))
    max_solves: int = field(metadata=integer("LMI solves per subsystem and design when warm-started", check=AT_LEAST_ONE))
    alpha_search_period: int = field(metadata=integer("steps between due designs (alpha searches)", check=AT_LEAST_ONE))
    redesign_margin: float = field(metadata=number("designs are for (1 + redesign_margin) P_W", check=NONNEGATIVE))
    update: str = field(
        metadata=option('"lyapunov": the certified per-step update (no semidefinite program inside a step)', "lyapunov")
    )
    design_delay: int = field(
        metadata=integer("a background design is adopted this many steps after it starts", check=AT_LEAST_ONE)
    )
    design_adoption: str = field(
        metadata=option(
            '"deterministic" (after design_delay: a reproducible run, the same numbers with every worker) or '
            '"when_ready" (as soon as done; never waits; needs a concurrent worker)',
            "deterministic",
            "when_ready",
        )
    )
    design_worker: str = field(
        metadata=option(
            'where a due LMI design runs: "process", "thread" or "inline" (tubempc.design.policy); "none": taken '
            "from the library at once (what a C++ program without Python flies)",
            "process",
            "thread",
            "inline",
            "none",
        )
    )
    library_range: FloatArray = field(
        metadata=number("range of c of the library's P_W = c P_W0", (2,), check=_INCREASING_POSITIVE)
    )
    library_ratio: float = field(
        metadata=number("ratio between the library's successive c", check=(lambda v: v > 1.0, "> 1"))
    )


#: The values of ``simulation.plant`` (tubempc.sim.plant, tubempc.sim.basilisk).
PLANTS = ("project", "basilisk")


@dataclass(frozen=True, eq=False)
class SimulationSection:
    """Truth simulation (project options; docs/model.md "Attitude": the truth integrates the quaternion),
    and the model mismatch between the controller and the truth."""

    plant: str = field(
        metadata=option(
            'who propagates the truth: "project" (the C++ propagator) or "basilisk" (Basilisk, the extra basilisk)',
            *PLANTS,
        )
    )
    integrator: str = field(
        metadata=option('"rk4" (substeps per control step) or "dopri5" (adaptive, rtol)', *_core.dynamics.Integrator.names())
    )
    substeps: int = field(metadata=integer("RK4 steps per control step", check=AT_LEAST_ONE))
    rtol: float = field(metadata=number('relative tolerance of "dopri5"', check=POSITIVE))
    gravity_expansion_tolerance: float = field(
        metadata=quantity(
            "acceleration",
            "the truth's gravity is its first-order expansion, held while its predicted error stays below this (M42); "
            "0: the field at every evaluation",
            check=NONNEGATIVE,
        )
    )
    density_scale: float = field(metadata=number("truth density / asteroid.density", check=POSITIVE))
    srp_scale: float = field(metadata=number("truth SRP / environment.beta_srp", check=NONNEGATIVE))
    truth_shape_subdivisions: int = field(
        metadata=integer("resolution of the truth's shape (0: the controller's shape)", check=NONNEGATIVE)
    )
    reference_input_fraction: float = field(
        metadata=number(
            "the reference may use this fraction of u_max and T_max (margin for the tube)",
            check=(lambda v: 0.0 < v <= 1.0, "in (0, 1]"),
        )
    )
    unconverged_reference: str = field(
        metadata=option(
            'a reference whose SCP did not converge: "error", or "warn" (flown with a warning and recorded)',
            "error",
            "warn",
        )
    )


__all__ = [
    "PLANTS",
    "AsteroidSection",
    "BoundarySection",
    "ConstraintsSection",
    "DisturbanceSection",
    "EnvironmentSection",
    "FloatArray",
    "IdentificationSection",
    "MpcSection",
    "SimulationSection",
    "SpacecraftSection",
    "TubeSection",
]
