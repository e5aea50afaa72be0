"""The scenario: everything a closed-loop run needs that follows from the configuration alone.

The scenario room's entry (docs/layout.md): the models, shape, site, boundary states, reference, input
bounds, MPC and propagator settings of a configuration, checked before anything flies. Every mapping
from a configuration option to a C++ setting of the models and the MPC lives here, once; the tube
designs are :mod:`tubempc.design`'s and what a run takes from its scenario :mod:`tubempc.sim.setup`'s.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..config import Config
from ..models.dynamics import ProximityModel
from .actuators import ActuatorConfigError, ScenarioActuation, scenario_actuation
from .physical import PhysicalConfigError, PhysicalTruth, physical_truth
from .reference import ReferenceSettings, ReferenceTrajectory, load_or_generate_reference
from .shapes import Shape, bennu_like_shape, load_shape
from .sites import Site, inside, ray_cast, site_from_lat_lon, site_from_vector, terminal_state

__all__ = [
    "METHODS",
    "Scenario",
    "ScenarioError",
    "build_scenario",
    "ideal_counterpart",
    "input_bounds",
    "landing_geometry",
    "landing_site",
    "model_params",
    "mpc_settings",
    "propagator_settings",
    "scenario_shape",
]

Array = npt.NDArray[np.float64]
METHODS: tuple[str, ...] = tuple(_core.control.Method.names())  # "tbmpc", "ffa" (control::Method's table)
P_STATES, R_STATES = slice(0, 6), slice(6, 12)  # translational x_p = [r_L, v_L], rotational x_r = [phi, omega_BL_B]
P_INPUTS, R_INPUTS = slice(0, 3), slice(3, 6)  # u_p (m/s^2, L), T (N m, B)


class ScenarioError(ValueError):
    """A configuration that cannot be flown as stated (the message names the field)."""


#: Centre-of-mass offset (m) above which a shape is refused: the model puts the origin of A at it.
COM_TOLERANCE_FRACTION = 0.01
#: The range of a body's mean radius (m) the proximity model is meant for: a shape outside it was
#: read in the wrong unit (asteroid.shape_unit) far more often than it is meant.
BODY_MEAN_RADIUS_RANGE = (5.0, 100e3)
#: A start farther than this many mean radii from the centre: the body is too small for the mission
#: (a km file read in metres) and is refused.
MAX_START_DISTANCE_IN_RADII = 100.0
#: How deep (m) below the surface along its radius the target of boundary.terminal = "paper" may lie:
#: the paper's own rf = [0, 0, 246.5] m is 6.7 m below the radar model's pole (docs/model.md "Scenario")
#: and is flown with a warning; anything deeper is refused.
PAPER_TARGET_MAX_DEPTH = 6.75


@dataclass
class Scenario:
    """Everything a closed-loop run needs that does not depend on the method or the seed.

    ``model`` is the controller's model, ``truth`` the simulated plant (it may differ in density, SRP
    and shape resolution; with disturbance.model = "physical" its gravity is the heterogeneous body of
    ``physical``, its inertia the truth's and its SRP the flat plates'); ``x0``, ``xf`` the boundary states
    [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)]; ``reference`` the fixed-time reference trajectory
    (paper Section 3.1).
    """

    config: Config
    shape: Shape
    shape_source: str
    model: ProximityModel
    truth: ProximityModel
    x0: Array
    xf: Array
    reference: ReferenceTrajectory
    site: Site | None = None
    #: The actuators of spacecraft.actuators (None: "ideal").
    actuation: ScenarioActuation | None = None
    #: The truth's physical environment of disturbance.model = "physical" (None: "drawn"), the one description
    #: of its physics (tubempc.scenario.physical).
    physical: PhysicalTruth | None = None
    #: LMI designs computed once for this scenario (tubempc.design.library.controller_designs).
    tube_designs: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)
    #: What the closed loop takes from the configuration, built once (tubempc.sim.setup.loop_setup).
    loop_setup: Any = field(default=None, init=False, repr=False, compare=False)
    #: Controllers and safe aborts set up for the mission, kept between runs
    #: (tubempc.design.library.kept_for_the_mission).
    controllers: dict[Any, list[Any]] = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def n_steps(self) -> int:
        """Number of control steps T = t_f / dt."""
        return int(self.reference.u.shape[0])

    @property
    def input_bounds(self) -> tuple[float, float]:
        """The controller's input bounds (u_max (m/s^2), T_max (N m)): spacecraft.u_max and T_max, capped
        by the actuators' achievable box (:attr:`actuation`)."""
        return input_bounds(self.config, self.actuation)


def input_bounds(cfg: Config, actuation: ScenarioActuation | None) -> tuple[float, float]:
    """(u_max (m/s^2), T_max (N m)): the configured bounds, or the actuators' (capped by them)."""
    if actuation is None:
        return cfg.spacecraft.u_max, cfg.spacecraft.T_max
    return actuation.u_max, actuation.T_max


def model_params(cfg: Config, srp_scale: float = 1.0, site: Site | None = None) -> dict[str, Any]:
    """Parameters of :class:`tubempc.models.dynamics.ProximityModel` for a configuration (SI units);
    ``srp_scale`` multiplies the SRP constant (the truth's mismatch). The density is the gravity's.
    ``site``: the landing site when the glide-slope cone is the site's (constraints.glide_slope_*).
    """
    e, a, s, c = cfg.environment, cfg.asteroid, cfg.spacecraft, cfg.constraints
    cone: dict[str, Any] = {}
    if c.glide_slope_apex == "site" or c.glide_slope_axis != "z":
        if site is None:
            raise ScenarioError(f"{cfg.source}: constraints.glide_slope_apex/axis: the site's cone needs a site")
        axis = {
            "z": np.array([0.0, 0.0, 1.0]),
            "normal": site.normal_A,
            "radial": site.surface_A / np.linalg.norm(site.surface_A),
        }[c.glide_slope_axis]
        apex = site.surface_A if c.glide_slope_apex == "site" else np.zeros(3)
        cone = {"glide_slope_apex_A": apex.tolist(), "glide_slope_axis_A": axis.tolist()}
    return {
        "mu_sun": e.mu_sun,
        "orbit_radius": e.R,
        "beta_srp": e.beta_srp * srp_scale,
        "inertia_B": np.asarray(s.J).tolist(),
        "spin_rate": a.spin_sign * 2.0 * np.pi / a.spin_period,
        "kinematics": cfg.mpc.kinematics,
        "glide_slope_angle": c.glide_slope_angle,
        "los_angle": c.los_angle,
        "boresight_B": np.asarray(s.boresight_B, dtype=float).tolist(),
        **cone,
    }


def scenario_shape(cfg: Config, subdivisions: int | None = None) -> tuple[Shape, str]:
    """The asteroid's shape and a description of where it came from.

    ``asteroid.shape = "generated"`` (or ``subdivisions``) gives the generated Bennu-like body
    (:func:`tubempc.scenario.shapes.bennu_like_shape`); otherwise the file in ``asteroid.shape_unit``, a
    relative path taken against the configuration file's folder (the packaged scenarios' folder for
    a packaged configuration). The shape's centre of mass must be the origin (the model's A frame):
    an offset over 1 % of its extent is refused.
    """
    src = cfg.asteroid.shape
    if src == "generated" or subdivisions:
        n = subdivisions or 12
        return bennu_like_shape(n_subdivisions=n), f"generated bennu_like_shape(n_subdivisions={n})"
    path = Path(src)
    if not path.is_absolute():
        path = config_folder(cfg) / path
    if not path.exists():
        raise ScenarioError(
            f"{cfg.source}: asteroid.shape: {path}: no such file (a relative path is taken against "
            "the configuration file's folder)"
        )
    shape = load_shape(path, unit=cfg.asteroid.shape_unit)
    check_body_size(cfg, shape, path)
    v = np.asarray(shape.vertices)
    extent = float(np.max(np.linalg.norm(v, axis=1)))
    offset = float(np.linalg.norm(shape.center_of_mass))
    if offset > COM_TOLERANCE_FRACTION * extent:
        raise ScenarioError(
            f"{cfg.source}: asteroid.shape: {path}: the centre of mass lies {offset:.4g} m from the origin "
            f"({100 * offset / extent:.2g} % of the body's {extent:.4g} m extent); the model takes the origin of "
            "the body frame at the centre of mass: translate the mesh (tubempc make-body writes centred meshes)"
        )
    return shape, str(path)


def check_body_size(cfg: Config, shape: Shape, path: Path) -> None:
    """Refuses a body whose mean radius lies outside :data:`BODY_MEAN_RADIUS_RANGE` (the file's unit is
    most likely wrong: the message gives the size in the other unit) or whose start lies farther than
    :data:`MAX_START_DISTANCE_IN_RADII` mean radii from its centre."""
    unit = cfg.asteroid.shape_unit
    radius = float(shape.mean_radius)
    lo, hi = BODY_MEAN_RADIUS_RANGE
    other, factor = ("m", 1e-3) if unit == "km" else ("km", 1e3)
    if not lo <= radius <= hi:
        raise ScenarioError(
            f"{cfg.source}: asteroid.shape_unit: {path} read in {unit} is a body of {radius:.4g} m mean radius, "
            f"outside the {lo:g} m to {hi / 1e3:g} km of the small bodies this model is for; in {other} it would be "
            f"{radius * factor:.4g} m: check the file's unit (asteroid.shape_unit, or --shape-unit with --shape)"
        )
    b = cfg.boundary
    if b.initial == "hover":
        start, what = b.hover_altitude + radius, "boundary.hover_altitude"
    else:
        start, what = float(np.linalg.norm(b.r0)), "boundary.r0"
    if start > MAX_START_DISTANCE_IN_RADII * radius:
        raise ScenarioError(
            f"{cfg.source}: asteroid.shape_unit: {path} read in {unit} is a body of {radius:.4g} m mean radius, "
            f"{start / radius:.4g} radii from the start ({what}); the body is too small for the mission: check the "
            f"file's unit (in {other} it would be {radius * factor:.4g} m) or the start"
        )


def check_gravity(cfg: Config, model: ProximityModel, xf: Array, u_max: float | None = None) -> None:
    """Refuses a body whose gravity at the terminal target exceeds the reference's input bound
    (simulation.reference_input_fraction x spacecraft.u_max): the spacecraft could not hover there."""
    r_A = np.asarray(model.C_AL(cfg.mpc.t_f)) @ xf[:3]
    g = float(np.linalg.norm(model.gravity.evaluate_point(r_A)[1]))
    bound = cfg.simulation.reference_input_fraction * (cfg.spacecraft.u_max if u_max is None else u_max)
    if not g < bound:
        raise ScenarioError(
            f"{cfg.source}: spacecraft.u_max: the body's gravity at the terminal target is {g:.4g} m/s^2, more than "
            f"the reference's input bound {bound:.4g} m/s^2 (simulation.reference_input_fraction x u_max): the "
            "spacecraft cannot hover there; check asteroid.shape_unit and asteroid.density"
        )


def config_folder(cfg: Config) -> Path:
    """The folder relative paths of a configuration are taken against (its file's; the packaged
    data folder for the packaged scenarios; the working directory for an in-memory one)."""
    src = cfg.source.removesuffix(" (override)")
    if src.startswith("<package>/"):
        import importlib.resources

        return Path(str(importlib.resources.files("tubempc").joinpath(src.removeprefix("<package>/")))).parent
    if src in ("<memory>", ""):
        return Path.cwd()
    return Path(src).parent


def landing_site(cfg: Config, shape: Shape) -> Site | None:
    """The landing site of ``boundary.terminal = "site"`` (None otherwise)."""
    b = cfg.boundary
    if b.terminal != "site":
        return None
    try:
        if b.site == "lat_lon":
            return site_from_lat_lon(shape, b.site_latitude, b.site_longitude, b.terminal_altitude)
        return site_from_vector(shape, b.site_A, b.terminal_altitude)
    except ValueError as exc:
        raise ScenarioError(f"{cfg.source}: boundary.site: {exc}") from exc


def boundary_states(
    cfg: Config, shape: Shape, model: ProximityModel | None = None, site: Site | None = None
) -> tuple[Array, Array]:
    """x0 and x_f (12,) of the configuration. ``boundary.terminal = "altitude"`` moves r_f along its
    direction to ``terminal_altitude`` above the surface point on that ray (the outermost one, with the
    body as it is at t_f; ``model`` gives its rotation); ``"site"`` puts x_f at the site's
    target at t_f, at rest relative to the surface (``model`` gives the body's rotation) or, with
    ``boundary.touchdown_speed``, moving that fast along the inward normal relative to it."""
    b = cfg.boundary
    x0 = np.concatenate([b.r0, b.v0, b.phi0, b.w0])
    if b.initial == "hover":
        if site is None or model is None:
            raise ScenarioError(f'{cfg.source}: boundary.initial: "hover" needs the site and the model')
        x0 = terminal_state(
            site.surface_A + b.hover_altitude * site.normal_A,
            site.normal_A,
            model.C_AL(0.0),
            model.rotation_rate_AL,
            cfg.spacecraft.boresight_B,
            b.phi0,
        )
    rf = np.asarray(b.rf, dtype=float)
    if b.terminal == "altitude":
        if model is None:
            raise ScenarioError(f'{cfg.source}: boundary.terminal: "altitude" needs the model')
        if not np.linalg.norm(rf) > 0.0:
            raise ScenarioError(f'{cfg.source}: boundary.rf: "altitude" needs a non-zero direction')
        C_AL = np.asarray(model.C_AL(cfg.mpc.t_f))  # the body at t_f: the surface point along rf then
        try:
            surface_A = ray_cast(shape, C_AL @ rf)
        except ValueError as exc:
            raise ScenarioError(f"{cfg.source}: boundary.rf: {exc}") from exc
        rf = rf / np.linalg.norm(rf) * (float(np.linalg.norm(surface_A)) + b.terminal_altitude)
    if b.terminal != "site":
        return x0, np.concatenate([rf, b.vf, b.phi_f, b.wf])
    if site is None or model is None:
        raise ScenarioError(f'{cfg.source}: boundary.terminal: "site" needs the site and the model')
    t_f = cfg.mpc.t_f
    xf = terminal_state(
        site.target_A, site.normal_A, model.C_AL(t_f), model.rotation_rate_AL, cfg.spacecraft.boresight_B, b.phi_f
    )
    if b.terminal_attitude == "given":
        xf[6:9], xf[9:12] = b.phi_f, b.wf
    if b.touchdown_speed > 0.0:  # contact speed along the inward normal, relative to the turning surface
        xf[3:6] -= b.touchdown_speed * (np.asarray(model.C_AL(t_f)).T @ site.normal_A)
    return x0, xf


def check_boundary(cfg: Config, shape: Shape, model: ProximityModel, x0: Array, xf: Array) -> None:
    """Refuses boundary states the mission cannot fly: a start or target inside the body, or a start
    outside a cone. The paper's own target (boundary.terminal = "paper") lies 6.7 m below the radar
    model's pole (docs/model.md "Scenario"): a "paper" target at most :data:`PAPER_TARGET_MAX_DEPTH`
    below the surface (along its radius) is flown with a warning, as the paper does; a deeper one is
    refused."""
    src = cfg.source
    checks = (("boundary.r0", "initial position", x0, 0.0), ("boundary.rf", "terminal position", xf, cfg.mpc.t_f))
    for field_name, what, x, t in checks:
        r_A = np.asarray(model.C_AL(t)) @ x[:3]
        if not inside(shape, r_A)[0]:
            continue
        message = f"{src}: {field_name}: the {what} {np.round(x[:3], 3).tolist()} m lies inside the body"
        depth = target_depth(shape, r_A)
        if cfg.boundary.terminal == "paper" and field_name == "boundary.rf" and depth <= PAPER_TARGET_MAX_DEPTH:
            warnings.warn(
                message + f", {depth:.3g} m below the surface (the paper's target lies 6.7 m below the radar model's "
                'pole; boundary.terminal = "altitude" or "site" puts it above the surface)',
                RuntimeWarning,
                stacklevel=3,
            )
        else:
            deeper = (
                f', {depth:.4g} m below the surface (a "paper" target may lie at most {PAPER_TARGET_MAX_DEPTH:g} m '
                'below it, as the paper\'s own does; boundary.terminal = "altitude" or "site" puts it above the surface)'
                if field_name == "boundary.rf"
                else ""
            )
            raise ScenarioError(message + deeper)
    g0 = model.glide_slope(x0, 0.0)[0]
    if g0 > 0.0:
        raise ScenarioError(
            f"{src}: boundary.r0: the initial position is outside the glide-slope cone by {g0:.4g} m "
            f"(constraints.glide_slope_angle = {np.degrees(cfg.constraints.glide_slope_angle):.4g} deg)"
        )
    l0 = model.line_of_sight(x0)[0]
    if l0 > 0.0:
        raise ScenarioError(
            f"{src}: boundary.phi0: the initial attitude is outside the line-of-sight cone by {l0:.4g} m "
            f"(constraints.los_angle = {np.degrees(cfg.constraints.los_angle):.4g} deg)"
        )
    lf = model.line_of_sight(xf)[0]
    if lf > 1e-9:
        raise ScenarioError(
            f"{src}: boundary.phi_f: the terminal attitude is outside the line-of-sight cone by "
            f"{lf:.4g} m (constraints.los_angle)"
        )


def _file_sha256(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def target_depth(shape: Shape, r_A: Array) -> float:
    """How far (m) the point r_A (A) lies below the outermost surface point on its ray from the centre
    (0 at or above it)."""
    r = float(np.linalg.norm(r_A))
    if r == 0.0:
        return float(np.linalg.norm(ray_cast(shape, np.array([0.0, 0.0, 1.0]))))
    return max(0.0, float(np.linalg.norm(ray_cast(shape, r_A))) - r)


def build_scenario(
    cfg: Config,
    shape_path: str | Path | None = None,
    cache_dir: str | Path | None = None,
    *,
    shape_unit: str | None = None,
) -> Scenario:
    """The controller's and the truth's models and the reference trajectory for a configuration.

    ``shape_path`` overrides ``asteroid.shape`` and needs ``shape_unit`` ("m" or "km": the unit of
    its coordinates; the configuration's unit belongs to the configuration's shape); ``cache_dir``
    keeps generated references on disk.
    """
    if shape_path is not None:
        if shape_unit is None:
            raise ScenarioError(
                f"{shape_path}: a shape given apart from the configuration needs its own unit (--shape-unit m|km; "
                "shape_unit= in Python)"
            )
        cfg = cfg.with_overrides({"asteroid.shape": str(Path(shape_path).resolve()), "asteroid.shape_unit": shape_unit})
    shape, shape_src = scenario_shape(cfg)
    site = landing_site(cfg, shape)
    gravity = _core.gravity.PolyhedronGravity(shape.vertices, shape.faces, cfg.asteroid.density)
    model = ProximityModel(gravity, model_params(cfg, site=site))
    sim = cfg.simulation
    truth_shape = shape if sim.truth_shape_subdivisions == 0 else scenario_shape(cfg, sim.truth_shape_subdivisions)[0]
    physical = None
    if cfg.disturbance.model == "physical":
        try:
            physical = physical_truth(cfg, gravity, truth_shape)
        except PhysicalConfigError as exc:
            raise ScenarioError(str(exc)) from exc
        truth_params = {
            **model_params(cfg, site=site),
            "inertia_B": physical.inertia_true_B.tolist(),
            "srp_enabled": False,  # the flat plates' SRP, in the environment
        }
        truth = ProximityModel(physical.gravity(), truth_params)
    else:
        truth_gravity = _core.gravity.PolyhedronGravity(
            truth_shape.vertices, truth_shape.faces, cfg.asteroid.density * sim.density_scale
        )
        truth = ProximityModel(truth_gravity, model_params(cfg, sim.srp_scale, site=site))
    x0, xf = boundary_states(cfg, shape, model, site)
    check_boundary(cfg, shape, model, x0, xf)
    try:
        actuation = scenario_actuation(
            cfg.spacecraft.actuators, config_folder(cfg), cfg.mpc.dt, cfg.spacecraft.u_max, cfg.spacecraft.T_max
        )
    except ActuatorConfigError as exc:
        raise ScenarioError(f"{cfg.source}: spacecraft.actuators: {exc}") from exc
    if physical is not None and actuation is not None and actuation.suite.mass != cfg.physical.mass:
        raise ScenarioError(
            f"{cfg.source}: physical.mass: {cfg.physical.mass:g} kg, but the actuators' preset "
            f"({cfg.spacecraft.actuators!r}) is {actuation.suite.mass:g} kg: the controller knows one mass"
        )
    u_max, T_max = input_bounds(cfg, actuation)
    check_gravity(cfg, model, xf, u_max)
    frac = sim.reference_input_fraction
    key = {
        "model": model_params(cfg, site=site),
        # the file's content, not its path: a results folder moved elsewhere keeps its cached reference
        "shape": shape_src if cfg.asteroid.shape == "generated" else f"sha256:{_file_sha256(Path(shape_src))}",
        "n_faces": len(shape.faces),
        "volume": float(shape.volume),
        "density": cfg.asteroid.density,
    }
    try:
        ref = load_or_generate_reference(
            model,
            x0,
            xf,
            cache_dir=cache_dir,
            key_extra=key,
            dt=cfg.mpc.dt,
            n_steps=cfg.mpc.n_steps,
            u_max=frac * u_max,
            T_max=frac * T_max,
            glide_slope_angle=cfg.constraints.glide_slope_angle,
            settings=ReferenceSettings(),
        )
    except RuntimeError as exc:
        raise ScenarioError(
            f"{cfg.source}: the reference trajectory is infeasible ({exc}): no path from x0 to x_f in mpc.t_f = "
            f"{cfg.mpc.t_f:g} s within {frac:g} x the input bounds (spacecraft.u_max = {u_max:g} m/s^2, "
            f"T_max = {T_max:g} N m{_bounds_origin(cfg, actuation)}) and the cones; lengthen mpc.t_f, raise the bounds "
            "or move the boundary states"
        ) from exc
    if not ref.converged:
        message = (
            f"{cfg.source}: the reference trajectory did not converge in {ref.iterations} SCP iterations "
            f"(largest step {ref.max_step:.3g}, dynamics defect {ref.max_defect:.3g})"
        )
        if sim.unconverged_reference == "error":
            raise ScenarioError(message + '; simulation.unconverged_reference = "warn" flies it anyway')
        warnings.warn(message + '; flown anyway (simulation.unconverged_reference = "warn")', RuntimeWarning, stacklevel=2)
    return Scenario(cfg, shape, shape_src, model, truth, x0, xf, ref, site, actuation, physical)


def _bounds_origin(cfg: Config, actuation: ScenarioActuation | None) -> str:
    """Where the bounds of an infeasible reference came from, for its message."""
    if actuation is None:
        return ""
    return f"; the achievable box of spacecraft.actuators = {cfg.spacecraft.actuators!r} with one thruster failed"


def _model_structure(scn: Scenario) -> tuple[Array, Array, Array]:
    """Nonzero patterns of the model's A (12, 12), B (12, 6) and G (2, 12) over the reference."""
    ref, dt = scn.reference, scn.config.mpc.dt
    Ad, Bd, _ = scn.model.discretize(0.0, ref.x[:-1], ref.u, dt)
    G = np.array([scn.model.constraints(k * dt, ref.x[k])[0] for k in range(0, len(ref.x), 10)])
    return (
        (np.abs(Ad) > 0).any(axis=0).astype(float),
        (np.abs(Bd) > 0).any(axis=0).astype(float),
        (np.abs(G) > 0).any(axis=0).astype(float),
    )


def mpc_settings(scn: Scenario) -> Any:
    """The C++ tube MPC's settings (``_core.mpc.Settings``) of the closed loop: horizon, dt, weights,
    input bounds, SCP threshold, input cost, linearisation re-use, QP solver and the model's declared
    structure; the core's defaults for the rest."""
    cfg = scn.config
    m = cfg.mpc
    st = _core.mpc.Settings()
    st.A_structure, st.B_structure, st.G_structure = _model_structure(scn)
    st.horizon = m.horizon
    st.dt = m.dt
    st.Q = np.diag(np.concatenate([m.Q_p, m.Q_r]))
    st.R = np.diag(np.concatenate([m.R_p, m.R_r]))
    u_max, T_max = scn.input_bounds
    st.u_max = np.r_[[u_max] * 3, [T_max] * 3]
    st.scp_eps = m.scp_eps
    # configuration options are the C++ enums' names (their from_string, as in scenario files)
    st.input_cost = _core.mpc.InputCost.from_string(m.input_cost)
    st.linearization = _core.mpc.Linearization.from_string(m.linearization)
    st.qp_solver = _core.mpc.QpSolver.from_string(m.qp_solver)
    st.scp_mode = _core.mpc.ScpMode.from_string(m.scp_mode)
    return st


def propagator_settings(cfg: Config) -> Any:
    """The truth propagator (``_core.dynamics.PropagatorSettings``) of the closed loop and of scenario
    files (``[simulation]``; the core's defaults for the rest)."""
    sim = cfg.simulation
    prop = _core.dynamics.PropagatorSettings()
    prop.method = _core.dynamics.Integrator.from_string(sim.integrator)
    if prop.method == _core.dynamics.Integrator.RK4:
        prop.substeps = sim.substeps
    else:
        prop.rtol = sim.rtol
    prop.gravity_expansion_tolerance = sim.gravity_expansion_tolerance
    return prop


def landing_geometry(scn: Scenario, t: float) -> tuple[Array, Array, Array, Array]:
    """The body and the glide-slope cone in the orbital frame L at time ``t`` (s): the shape's
    vertices in L (m, (n, 3)), its faces ((m, 3), 0-based), the cone's apex in L (m) and its unit axis."""
    vertices_L = np.asarray(scn.shape.vertices) @ np.asarray(scn.model.C_AL(t))
    apex_L, axis_L = scn.model.glide_slope_cone_L(t)
    return vertices_L, np.asarray(scn.shape.faces), np.asarray(apex_L), np.asarray(axis_L)


def ideal_counterpart(cfg: Config, scn: Scenario, cache_dir: str | Path | None = None) -> tuple[Config, Scenario]:
    """The mission of ``scn`` (built from ``cfg``) with ideal actuators and its input bounds: the same reference.
    ValueError if the references differ."""
    u_max, T_max = scn.input_bounds
    ideal_cfg = cfg.with_overrides({"spacecraft.actuators": "ideal", "spacecraft.u_max": u_max, "spacecraft.T_max": T_max})
    ideal = build_scenario(ideal_cfg, cache_dir=cache_dir)
    if not np.array_equal(ideal.reference.x, scn.reference.x):
        raise ValueError("the ideal run's reference differs from the actuated run's")
    return ideal_cfg, ideal
