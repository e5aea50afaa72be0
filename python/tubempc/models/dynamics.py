"""6-DOF proximity dynamics around an asteroid (docs/model.md, "Frames" to "Linearisation and
discretisation"), on numpy arrays, over the C++ core (``tubempc._core.dynamics``).

State ``x = [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)]`` (12), input
``u = [u_p (m/s^2, in L), T (N m, in B)]`` (6); truth state ``[r_L, v_L, q_B/L ([x, y, z, w]),
omega_BL_B]`` (13). ``phi = log(q_B/L)`` with ``R(q_B/L) = C_LB`` (``tubempc.so3``).

Frames: L turns about z_L at the orbital rate n = sqrt(mu_sun / R^3); the asteroid spins about
z_A = z_L at the inertial rate ``spin_rate`` (omega_A), i.e. at omega_A - n relative to L:
``C_AL(t) = Rz(theta(t))^T``, ``theta(t) = spin_angle0 + (omega_A - n) t``.

Discretisation: exact zero-order hold about (x_ref, u_ref) through one 19x19 matrix exponential
(Pade 13), with the Jacobians taken at the node's start time and held over the step.

Constraints are written g(x) <= 0: glide slope ``g = |r| cos(phi_gs) - r . z_L`` and line of
sight ``g = |r| cos(theta_LOS) - r_B . b_B`` with ``r_B = -C_BL r_L`` (boresight ``b_B``, default
+z_B).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from .. import _core

_dyn = _core.dynamics

if TYPE_CHECKING:
    from .._dynamics import Kinematics, ModelParams, PropagationResult, PropagationStatus
    from .._gravity import GravityModel, PointMassGravity
else:
    ModelParams = _dyn.ModelParams
    Kinematics = _dyn.Kinematics
    PropagationResult = _dyn.PropagationResult
    PropagationStatus = _dyn.PropagationStatus
    GravityModel = _core.gravity.GravityModel
    PointMassGravity = _core.gravity.PointMassGravity

__all__ = [
    "GravityModel",
    "Kinematics",
    "ModelParams",
    "PointMassGravity",
    "PropagationResult",
    "PropagationStatus",
    "ProximityModel",
    "glide_slope_constraint",
    "line_of_sight_constraint",
    "model_params",
    "params_to_config",
    "state_to_truth",
    "truth_to_state",
]

_Arr = npt.NDArray[np.float64]
Disturbance = npt.ArrayLike | Callable[[float, _Arr], npt.ArrayLike] | None

#: The fields of ``ModelParams`` (its C++ table, ``dynamics::ModelParams::for_each_field``), in order.
_FIELDS: tuple[str, ...] = tuple(ModelParams.field_names())
#: Each field's default (its kind is the default's: float, bool, Kinematics or a float array).
_DEFAULTS: dict[str, Any] = {k: getattr(ModelParams(), k) for k in _FIELDS}


def model_params(config: ModelParams | Mapping[str, Any] | None = None) -> ModelParams:
    """A validated ``ModelParams`` from None (the paper's defaults), a ``ModelParams`` or a dict.

    Dict keys are the field names (SI units, angles in rad); ``kinematics`` is one of
    ``Kinematics.names()``; ``inertia_B`` a 3x3 matrix or its 3 principal moments. Unknown keys raise
    ValueError.
    """
    if isinstance(config, ModelParams):
        p = config
    else:
        p = ModelParams()
        for key, value in (config or {}).items():
            if key not in _DEFAULTS:
                raise ValueError(f"unknown model parameter {key!r}; known: {', '.join(_FIELDS)}")
            default = _DEFAULTS[key]
            if isinstance(default, Kinematics):
                if isinstance(value, Kinematics):
                    p.kinematics = value
                elif str(value).lower() in Kinematics.names():
                    p.kinematics = Kinematics.from_string(str(value).lower())
                else:
                    known = " or ".join(repr(n) for n in Kinematics.names())
                    raise ValueError(f"kinematics must be {known}, got {value!r}")
            elif isinstance(default, np.ndarray):
                a = np.asarray(value, dtype=float)
                if default.ndim == 2 and a.shape == (3,):  # a matrix (inertia_B) by its principal moments
                    a = np.diag(a)
                if a.shape != default.shape:
                    what = "3x3 or 3 principal moments" if default.ndim == 2 else "3 elements"
                    raise ValueError(f"{key} must have {what}, got shape {a.shape}")
                setattr(p, key, a)
            elif isinstance(default, bool):
                setattr(p, key, bool(value))
            else:
                setattr(p, key, float(value))
    p.validate()
    return p


def params_to_config(p: ModelParams) -> dict[str, Any]:
    """Plain dict (JSON-friendly) of a ``ModelParams``, in the table's order; ``model_params`` inverts it."""
    out: dict[str, Any] = {}
    for key in _FIELDS:
        value = getattr(p, key)
        if isinstance(value, Kinematics):
            out[key] = value.to_string()
        elif isinstance(value, np.ndarray):
            out[key] = value.tolist()
        elif isinstance(value, bool):
            out[key] = value
        else:
            out[key] = float(value)
    return out


class ProximityModel:
    """The 6-DOF proximity model around an asteroid (see the module docstring).

    ``gravity`` is a Python-visible gravity object (``PointMassGravity``, ``PolyhedronGravity``, ...)
    kept by the model and pickled with it (through the gravity object's own pickling); ``params`` a
    ``ModelParams``, a config dict or None for the paper's scenario.
    """

    nx: int = 12
    nu: int = 6

    def __init__(self, gravity: Any, params: ModelParams | Mapping[str, Any] | None = None) -> None:
        self._gravity = gravity
        self._params = model_params(params)
        self._impl = _dyn.ProximityModel(gravity, self._params)

    def __reduce__(self) -> tuple[Any, ...]:
        return (ProximityModel, (self._gravity, params_to_config(self._params)))

    def __repr__(self) -> str:
        return f"ProximityModel(gravity={self._gravity!r}, kinematics={self.config()['kinematics']!r})"

    @property
    def core(self) -> Any:
        """The C++ model (``tubempc._core.dynamics.ProximityModel``), e.g. for
        ``tubempc.models.mpc.LinearizedProximityModel``."""
        return self._impl

    @property
    def gravity(self) -> Any:
        """The gravity object (field in the asteroid frame A)."""
        return self._gravity

    @property
    def params(self) -> ModelParams:
        """A copy of the validated parameters."""
        return model_params(params_to_config(self._params))

    def config(self) -> dict[str, Any]:
        """The parameters as a plain dict."""
        return params_to_config(self._params)

    @property
    def mean_motion(self) -> float:
        """Orbital rate n (rad/s)."""
        return float(self._impl.mean_motion)

    @property
    def rotation_rate_AL(self) -> float:
        """The body's rotation rate relative to L about z_L = z_A, omega_A - n (rad/s)."""
        return float(self._impl.rotation_rate_AL)

    @property
    def srp_acceleration_L(self) -> _Arr:
        """The SRP acceleration in L (m/s^2): beta_SRP / R^2 along +x_L, zero when SRP is off."""
        return np.asarray(self._impl.srp_acceleration_L)

    def C_AL(self, t: float) -> _Arr:
        """C_AL(t) (r_A = C_AL r_L)."""
        return self._impl.C_AL(t)

    def q_AL(self, t: float) -> _Arr:
        """q_A/L(t) ([x, y, z, w]) with R(q_A/L) = C_AL."""
        return self._impl.q_AL(t)

    def gravity_L(self, t: float, r_L: npt.ArrayLike) -> tuple[_Arr, _Arr]:
        """Gravity acceleration a_L (m/s^2) and gradient G_L (1/s^2) at r_L (m), time t (s)."""
        return self._impl.gravity_L(t, np.asarray(r_L, dtype=float))

    def f(self, t: float, x: npt.ArrayLike, u: npt.ArrayLike) -> _Arr:
        """Continuous dynamics x' (12). ValueError for non-finite input."""
        return self._impl.f(t, _vec(x), _vec(u))

    def jacobians(self, t: float, x: npt.ArrayLike, u: npt.ArrayLike) -> tuple[_Arr, _Arr]:
        """A = df/dx (12, 12) and B = df/du (12, 6) at (t, x, u)."""
        _, A, B = self._impl.linearize(t, _vec(x), _vec(u))
        return A, B

    def linearize(self, t: float, x: npt.ArrayLike, u: npt.ArrayLike) -> tuple[_Arr, _Arr, _Arr]:
        """(f, A, B) at (t, x, u) with one gravity evaluation."""
        return self._impl.linearize(t, _vec(x), _vec(u))

    def discretize(self, t: float, x_ref: npt.ArrayLike, u_ref: npt.ArrayLike, dt: float) -> tuple[_Arr, _Arr, _Arr]:
        """Exact zero-order hold x+ = Ad x + Bd u + cd about (x_ref, u_ref) over dt (s).

        One node for x_ref (12,), u_ref (6,): Ad (12, 12), Bd (12, 6), cd (12). A horizon for
        x_ref (N, 12), u_ref (N, 6): node k at t + k dt, arrays (N, 12, 12), (N, 12, 6), (N, 12).
        ValueError for non-finite input or result.
        """
        X = np.asarray(x_ref, dtype=float)
        U = np.asarray(u_ref, dtype=float)
        if X.ndim == 2 or U.ndim == 2:
            return self._impl.discretize_horizon(t, dt, np.atleast_2d(X), np.atleast_2d(U))
        return self._impl.discretize(t, dt, X, U)

    def constraints(self, t: float, x_lin: npt.ArrayLike) -> tuple[_Arr, _Arr]:
        """Linearised [glide slope; line of sight] at x_lin: G (2, 12), h (2) with G x <= h."""
        return self._impl.constraints(t, _vec(x_lin))

    def glide_slope_cone_L(self, t: float) -> tuple[_Arr, _Arr]:
        """The glide-slope cone at time t (s) in L: apex (m) and unit axis (the cone is fixed in A)."""
        apex_L, axis_L = self._impl.glide_slope_cone_L(t)
        return np.asarray(apex_L), np.asarray(axis_L)

    def glide_slope(self, x: npt.ArrayLike, t: float = 0.0) -> tuple[float, _Arr]:
        """(g, dg/dx) of ``g = |r - p| cos(phi_gs) - (r - p) . a`` (<= 0 feasible) for the cone (p, a) at
        time t (s); the paper's cone (p = 0, a = z_L) does not depend on t."""
        apex_L, axis_L = self.glide_slope_cone_L(t)
        return glide_slope_constraint(x, self._params.glide_slope_angle, apex_L, axis_L)

    def line_of_sight(self, x: npt.ArrayLike) -> tuple[float, _Arr]:
        """(g, dg/dx) of ``g = |r| cos(theta_LOS) - r_B . b_B``, ``r_B = -C_BL r_L`` (<= 0 feasible)."""
        return line_of_sight_constraint(x, self._params.los_angle, self._params.boresight_B)

    def truth_derivative(
        self, t: float, state: npt.ArrayLike, u: npt.ArrayLike, disturbance: npt.ArrayLike | None = None
    ) -> _Arr:
        """Derivative of the 13-state [r, v, q_B/L, w] (quaternion kinematics) with an additive
        disturbance [acceleration in L; angular acceleration in B]."""
        w = np.zeros(6) if disturbance is None else _vec(disturbance)
        return self._impl.truth_derivative(t, _vec(state), _vec(u), w)

    def propagate(
        self,
        t0: float,
        state: npt.ArrayLike,
        u: npt.ArrayLike,
        dt: float,
        method: str = "rk4",
        *,
        substeps: int = 20,
        rtol: float = 1e-10,
        atol: float = 1e-12,
        max_steps: int = 100000,
        initial_step: float = 0.0,
        gravity_expansion_tolerance: float = 0.0,
        disturbance: Disturbance = None,
        settings: _dyn.PropagatorSettings | None = None,
        environment: _dyn.PhysicalEnvironment | None = None,
        gravity_hold: _core.gravity.ExpansionHold | None = None,
    ) -> PropagationResult:
        """Propagates the 13-state over dt (s) with u held constant (zero-order hold).

        method ``"rk4"`` (``substeps`` equal steps) or ``"dopri"`` (adaptive Dormand-Prince 5(4) with
        ``rtol``/``atol``, at most ``max_steps`` steps; ``gravity_expansion_tolerance`` > 0: the gravity held as its
        first-order expansion, docs/model.md M42); ``settings`` (a ``_core.dynamics.PropagatorSettings``,
        e.g. :func:`tubempc.scenario.propagator_settings`) replaces all of them. ``disturbance``: None, a
        constant 6-vector [acceleration in L (m/s^2); angular acceleration in B (rad/s^2)] or a callable
        ``(t, state) -> 6-vector``. ``environment``: a ``_core.dynamics.PhysicalEnvironment`` whose forces and
        torques the C++ propagation adds at every evaluation (then ``u`` is the delivered input,
        ``environment.deliver``, and ``disturbance`` must be None; this model must be the environment's truth:
        its inertia, its SRP off). ``gravity_hold``: with a positive ``gravity_expansion_tolerance``, the run's
        ``_core.gravity.ExpansionHold``, carried from call to call (None: a hold of this call alone). Numerical
        failures are reported in ``result.status``.
        """
        if settings is None:
            name = "dopri5" if method.lower() == "dopri" else method.lower()  # "dopri": dopri5's older name
            if name not in _dyn.Integrator.names():
                known = ", ".join(repr(n) for n in [*_dyn.Integrator.names(), "dopri"])
                raise ValueError(f"method must be one of {known}, got {method!r}")
            settings = _dyn.PropagatorSettings()
            settings.method, settings.substeps, settings.rtol, settings.atol = (
                _dyn.Integrator.from_string(name),
                substeps,
                rtol,
                atol,
            )
            settings.max_steps, settings.initial_step = max_steps, initial_step
            settings.gravity_expansion_tolerance = gravity_expansion_tolerance
        if environment is not None:
            if disturbance is not None:
                raise ValueError("propagate: give a disturbance or a physical environment, not both")
            return self._impl.propagate_physical(environment, t0, _vec(state), _vec(u), dt, settings, gravity_hold)
        constant = np.zeros(6)
        callback = None
        if callable(disturbance):
            callback = disturbance
        elif disturbance is not None:
            constant = _vec(disturbance)
        return self._impl.propagate(t0, _vec(state), _vec(u), dt, settings, constant, callback, gravity_hold)

    @staticmethod
    def truth_to_state(state: npt.ArrayLike, phi_ref: npt.ArrayLike | None = None) -> _Arr:
        """13-state -> 12-state (see ``truth_to_state``)."""
        return truth_to_state(state, phi_ref)

    @staticmethod
    def state_to_truth(x: npt.ArrayLike) -> _Arr:
        """12-state -> 13-state (q_B/L = exp_map(phi))."""
        return state_to_truth(x)


def truth_to_state(state: npt.ArrayLike, phi_ref: npt.ArrayLike | None = None) -> _Arr:
    """13-state -> 12-state: ``phi = log_map(q)`` (``|phi| <= pi``), then the equivalent rotation vector
    ``phi - 2 pi phi / |phi|`` is taken instead when it is nearer to ``phi_ref`` (default 0). Passing the
    previous phi keeps a trajectory continuous across ``|phi| = pi`` (``|phi|`` may then exceed pi)."""
    ref = np.zeros(3) if phi_ref is None else _vec(phi_ref)
    return _dyn.truth_to_state(_vec(state), ref)


def state_to_truth(x: npt.ArrayLike) -> _Arr:
    """12-state -> 13-state (q_B/L = exp_map(phi))."""
    return _dyn.state_to_truth(_vec(x))


def glide_slope_constraint(
    x: npt.ArrayLike,
    glide_slope_angle: float = np.deg2rad(70.0),
    apex_L: npt.ArrayLike = (0.0, 0.0, 0.0),
    axis_L: npt.ArrayLike = (0.0, 0.0, 1.0),
) -> tuple[float, _Arr]:
    """(g, dg/dx) of ``g = |r - p| cos(phi_gs) - (r - p) . a`` (<= 0 feasible) for the cone with apex p (m)
    and unit axis a in L (default: the paper's, apex at the centre, axis z_L); ValueError at r = p."""
    return _dyn.glide_slope_constraint(_vec(x), glide_slope_angle, _vec(apex_L), _vec(axis_L))


def line_of_sight_constraint(
    x: npt.ArrayLike, los_angle: float = np.deg2rad(80.0), boresight_B: npt.ArrayLike = (0.0, 0.0, 1.0)
) -> tuple[float, _Arr]:
    """(g, dg/dx) of ``g = |r| cos(theta_LOS) - r_B . b_B``, ``r_B = -C_BL r_L`` (<= 0 feasible)."""
    return _dyn.line_of_sight_constraint(_vec(x), los_angle, _vec(boresight_B))


def _vec(a: npt.ArrayLike) -> _Arr:
    return np.ascontiguousarray(a, dtype=float).reshape(-1)
