"""Navigation in the closed loop (docs/model.md "Output-feedback tube", M39-M41; ``[navigation]``).

With ``navigation.enabled`` the plant is propagated in sub-steps of the IMU's period, the C++
navigation system (``_core.nav.NavigationSystem``: the four sensors and the joint EKF) samples them and
returns the estimate x^ with its covariance, and the controller flies on x^: its identification sees
x^, and its state constraints are also tightened by the estimation-error set
E = {e : e^T (c P_x)^-1 e <= 1}, c the chi-square quantile of ``navigation.error_set_probability`` with
12 degrees of freedom (a probabilistic bound, unlike the disturbance tube, which is certified for the
identified set). Everything per step runs in C++; this module builds the settings and holds the run's
state.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.linalg

from .. import _core
from ..config import Config

__all__ = [
    "DISTURBANCE_DELIVERIES",
    "NAV_SEED_OFFSET",
    "Navigation",
    "NavigationRecord",
    "error_set_scale",
    "landmark_catalogue",
    "navigation_settings",
    "new_navigation",
    "propagate_sampled",
    "sensor_caster",
    "site_landmarks",
    "tube_gauge",
]

Array = npt.NDArray[np.float64]

#: The navigation system's seed is the run's seed plus this (the disturbance takes the seed, the
#: actuator errors seed + 1); the system gives each sensor its own stream from it.
NAV_SEED_OFFSET = 1_000_003

#: How a plant delivers the drawn per-period disturbance (``disturbance.model = "drawn"``), which decides
#: what of it the IMU senses and so what the filter adds as process noise (docs/model.md M39): "jump" (the
#: project's plant adds it to the state at the period's end: nothing senses it, noise on r, v and theta at
#: the end) or "half_period_forces" (Basilisk's applies it as forces and torques over the two halves of the
#: period, B1: the forces stand for unmodelled gravity, which no accelerometer senses, noise on r and v at
#: the end; the gyro senses the torques' rotation, no noise on theta). Each plant names its own
#: (``ProjectPlant.DISTURBANCE_DELIVERY``).
DISTURBANCE_DELIVERIES = ("jump", "half_period_forces")


def error_set_scale(probability: float, dof: int = 12) -> float:
    """c with P(chi2_dof <= c) = probability: E = {e : e^T P^-1 e <= c} holds a Gaussian error of
    covariance P with that probability."""
    from scipy.stats import chi2

    return float(chi2.ppf(probability, dof))


def _uniform_ellipsoid_variance(S_diag: Array, growth: float, dim: int) -> Array:
    """Per-axis variance of a draw uniform in {w : w^T S^-1 w <= 1} (dimension ``dim``) with its semi-axes
    grown by ``growth``: S_ii growth^2 / (dim + 2)."""
    return np.asarray(S_diag, dtype=float) * growth**2 / (dim + 2)


def navigation_settings(cfg: Config, delivery: str = "jump") -> Any:
    """The C++ ``NavigationSettings`` of a configuration: the true sensors and the filter's identical
    model of them, the initial sigmas and the filter's model of the per-period disturbance as the plant
    delivers it (``delivery``, one of :data:`DISTURBANCE_DELIVERIES`; M39). Every [navigation] field that
    names its C++ member (``cpp="camera.min_range"``) sets it; the rest derive."""
    if delivery not in DISTURBANCE_DELIVERIES:
        raise ValueError(f"disturbance delivery {delivery!r}: must be one of {', '.join(DISTURBANCE_DELIVERIES)}")
    n, nav = cfg.navigation, _core.nav
    alt, cam, imu = nav.AltimeterSettings(), nav.CameraSettings(), nav.ImuSettings()
    star, filt = nav.StarTrackerSettings(), nav.FilterSettings()
    parts: dict[str, Any] = {"altimeter": alt, "camera": cam, "imu": imu, "star_tracker": star, "filter": filt}
    for f in dataclasses.fields(n):
        target = f.metadata["spec"].cpp
        if target is not None:
            part, _, member = target.partition(".")
            setattr(parts[part], member, getattr(n, f.name))
    cam.width_px = cam.height_px = n.camera_pixels
    cam.focal_length_px = nav.CameraSettings.focal_length_from_fov(n.camera_fov, n.camera_pixels)
    cam.C_BC = _camera_axes(np.asarray(n.camera_boresight_B, dtype=float))
    filt.altimeter, filt.camera, filt.imu, filt.star_tracker = alt, cam, imu, star
    s = nav.NavigationSettings()
    s.altimeter, s.camera, s.imu, s.star_tracker, s.filter = alt, cam, imu, star, filt
    s.initial_sigma = np.repeat([n.initial_sigma_position, n.initial_sigma_velocity, n.initial_sigma_attitude], 3)
    sigma = np.zeros(9)
    if n.period_noise == "disturbance":
        d = cfg.disturbance
        var_p = _uniform_ellipsoid_variance(np.diag(d.S_p), max(1.0, d.growth_p), 6)
        var_r = _uniform_ellipsoid_variance(np.diag(d.S_r), max(1.0, d.growth_r), 6)
        sigma = n.period_noise_scale * np.sqrt(np.concatenate([var_p, var_r[:3]]))
        if delivery == "half_period_forces" and d.model == "drawn":
            sigma[6:9] = 0.0  # the torques turn the body at a rate the gyro measures: the filter follows it
    s.period_noise_sigma = sigma
    s.max_samples = max(1, round(cfg.mpc.dt / n.imu_period))
    s.validate()
    return s


def _camera_axes(boresight_B: Array) -> Array:
    """C_BC of a camera whose z_C is its boresight (x_C the B axis least aligned with it, made orthogonal)."""
    z = boresight_B / np.linalg.norm(boresight_B)
    seed = np.eye(3)[int(np.argmin(np.abs(z)))]
    x = seed - z * float(seed @ z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


@dataclass
class Navigation:
    """One run's navigation: the C++ system, the error set's chi-square scale, the sub-step h and the
    truth samples of the period being flown (filled by the plant)."""

    system: Any  # _core.nav.NavigationSystem
    scale: float  # c of E = {e : e^T (c P_x)^-1 e <= 1}
    h: float  # sub-step = the IMU's period (s)
    n_sub: int  # sub-steps per control period
    srp_L: Array  # the truth's SRP acceleration in L (m/s^2)
    t: Array = field(init=False)
    truth: Array = field(init=False)
    accel: Array = field(init=False)

    def __post_init__(self) -> None:
        self.t = np.zeros(self.n_sub)
        self.truth = np.zeros((self.n_sub, 13))
        self.accel = np.zeros((self.n_sub, 3))

    def initialize(self, state: Array, phi_ref: Array) -> Any:
        """Starts the filter at t = 0 from the true 13-state (with its initial error draw)."""
        return self.system.initialize(0.0, state, self.srp_L, phi_ref)

    def step(self, phi_ref: Array) -> Any:
        """The period's estimate from the truth samples the plant filled in."""
        return self.system.step(self.t, self.truth, self.accel, phi_ref)

    def error_set(self, P_x: Array) -> Array:
        """E's matrix c P_x (12 x 12)."""
        return self.scale * np.asarray(P_x, dtype=float)


def new_navigation(scn: Any, seed: int, delivery: str = "jump", fault: dict[str, Any] | None = None) -> Navigation | None:
    """The navigation of a run with seed ``seed`` (None when ``navigation.enabled`` is false) in a plant
    that delivers the drawn disturbance as ``delivery`` (:data:`DISTURBANCE_DELIVERIES`). The sensors
    ray-cast the truth's shape; the filter and the landmark catalogue use the controller's. Its fault
    detection is [faults]' (a run's injected fault: :func:`tubempc.scenario.faults.inject`)."""
    from .faults import detection_settings

    cfg: Config = scn.config
    n = cfg.navigation
    if not n.enabled:
        return None
    settings = navigation_settings(cfg, delivery)
    filter_caster = _core.nav.RayCaster(scn.shape)
    system = _core.nav.NavigationSystem(
        scn.model.core,
        sensor_caster(scn, filter_caster),
        filter_caster,
        landmark_catalogue(scn, filter_caster),
        settings,
        int(seed) + NAV_SEED_OFFSET,
    )
    system.set_faults([], detection_settings(cfg))
    n_sub = round(cfg.mpc.dt / n.imu_period)
    return Navigation(
        system, error_set_scale(n.error_set_probability), n.imu_period, n_sub, np.asarray(scn.truth.srp_acceleration_L)
    )


def sensor_caster(scn: Any, filter_caster: Any | None = None) -> Any:
    """The ray caster the sensors of a run cast on (frame A): the truth's shape, which is the
    controller's (``filter_caster`` when given) unless ``simulation.truth_shape_subdivisions`` > 0."""
    subdivisions = scn.config.simulation.truth_shape_subdivisions
    if subdivisions == 0:
        return filter_caster if filter_caster is not None else _core.nav.RayCaster(scn.shape)
    from .build import scenario_shape

    return _core.nav.RayCaster(scenario_shape(scn.config, subdivisions)[0])


def landmark_catalogue(scn: Any, filter_caster: Any | None = None) -> list[Any]:
    """The navigation camera's landmark catalogue of a scenario (frame A, on the controller's shape):
    ``navigation.landmarks`` spread over the body, then ``navigation.site_landmarks`` about the site.
    Deterministic; the index of a landmark is its index in the C++ camera's catalogue."""
    n = scn.config.navigation
    caster = filter_caster if filter_caster is not None else _core.nav.RayCaster(scn.shape)
    landmarks = _core.nav.generate_landmarks(caster, n.landmarks)
    if n.site_landmarks > 0 and scn.site is not None:
        landmarks += site_landmarks(caster, scn.site, n.site_landmarks, n.site_landmark_radius)
    return landmarks


def site_landmarks(caster: Any, site: Any, count: int, radius: float) -> list[Any]:
    """``count`` landmarks about a landing site: the surface points met by rays cast along the inward
    normal from 2 radius above the points of a sunflower (Vogel) spiral on the disc of radius
    ``radius`` about the site's surface point, normal to its surface normal (frame A). Deterministic."""
    n_A = np.asarray(site.normal_A, dtype=float)
    seed = np.eye(3)[int(np.argmin(np.abs(n_A)))]
    e1 = seed - n_A * float(seed @ n_A)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n_A, e1)
    golden = math.pi * (3.0 - math.sqrt(5.0))
    out = []
    for i in range(count):
        rho, theta = radius * math.sqrt((i + 0.5) / count), i * golden
        origin = np.asarray(site.surface_A) + 2.0 * radius * n_A + rho * (math.cos(theta) * e1 + math.sin(theta) * e2)
        hit = caster.cast(origin, -n_A, 4.0 * radius)
        if hit.hit:
            lm = _core.nav.Landmark()
            lm.p_A, lm.normal_A, lm.face = hit.point_A, hit.normal_A, hit.face
            out.append(lm)
    return out


def tube_gauge(e: Array, Pe: Array, P_est: Array, rounds: int = 8) -> float:
    """The gauge of e in the Minkowski sum of the ellipsoids {x : x^T Pe^-1 x <= 1} and
    {x : x^T P_est^-1 x <= 1}: the smallest s with e in s (Pe (+) E) (<= 1: inside). The sum is the
    intersection of the outer ellipsoids (1 + 1/p) Pe + (1 + p) P_est over p > 0, so the squared gauge
    is the largest e^T ((1 + 1/p) Pe + (1 + p) P_est)^-1 e over p. With P_est V = Pe V diag(d), V^T Pe V = I
    (one generalised eigendecomposition), that is sum_i (V^T e)_i^2 / ((1 + 1/p) + (1 + p) d_i), a unimodal
    function of log p: its largest value over 33 points of log p in [-30, 30], then ``rounds`` times over 33
    points between the best point's neighbours (each round narrows the bracket 16 times: 8 rounds, 1e-8)."""
    e = np.asarray(e, dtype=float)
    if not np.any(e):
        return 0.0
    d, V = scipy.linalg.eigh(P_est, Pe)
    y2 = (V.T @ e) ** 2
    lo, hi, best = -30.0, 30.0, 0.0
    for _ in range(rounds + 1):
        log_p = np.linspace(lo, hi, 33)
        p = np.exp(log_p)[:, None]
        values = (y2 / ((1.0 + 1.0 / p) + (1.0 + p) * d)).sum(axis=1)
        i = int(np.argmax(values))
        best = max(best, float(values[i]))
        lo, hi = log_p[max(i - 1, 0)], log_p[min(i + 1, 32)]
    return math.sqrt(best)


def propagate_sampled(
    nav: Navigation,
    truth: Any,
    t0: float,
    state: Array,
    u_applied: Array,
    settings: Any,
    environment: Any = None,
    gravity_hold: Any = None,
) -> Array:
    """The truth propagated over one control period in nav.n_sub sub-steps of nav.h (``truth`` the
    plant's ProximityModel, ``settings`` its propagator's, ``environment`` its physical environment or None,
    ``gravity_hold`` the run's held gravity expansion or None),
    each sub-step's end recorded in ``nav`` for the sensors (the accelerometer's non-gravitational
    acceleration: the applied thrust and the SRP, the flat plates' at the sub-step's end in a physical
    environment); returns the 13-state at the period's end, before the additive disturbance."""
    for j in range(nav.n_sub):
        prop = truth.propagate(
            t0 + j * nav.h, state, u_applied, nav.h, settings=settings, environment=environment, gravity_hold=gravity_hold
        )
        if prop.status.name != "Success":
            raise RuntimeError(f"truth propagation failed at t = {t0 + j * nav.h:g} s: {prop.status.name}")
        state = np.asarray(prop.state)
        nav.t[j] = t0 + (j + 1) * nav.h
        nav.truth[j] = state
        srp_L = nav.srp_L if environment is None else np.asarray(environment.srp_acceleration_L(state))
        nav.accel[j] = u_applied[:3] + srp_L
    return state


#: The fault detection's fields of a NavigationRecord and their shapes for T + 1 steps (a file written before them).
_FAULT_FIELDS: dict[str, Any] = {
    "fault_detected": lambda n: (n,),
    "fault_cause": lambda n: (n,),
    "failed": lambda n: (n, 4),
    "excluded": lambda n: (n, 4),
}


@dataclass
class NavigationRecord:
    """Per-step navigation of a run (k = 0..T: the estimate the controller flew at step k)."""

    x_hat: Array  # (T+1, 12) estimate
    sigma: Array  # (T+1, 12) square roots of P_x's diagonal
    error: Array  # (T+1, 12) x - x_hat
    nees: Array  # (T+1,) 15-state NEES against the truth (IMU biases included)
    status: list[str]  # (T+1) NavigationStatus
    sensor_status: list[str]  # (T+1) "altimeter/camera/imu/star_tracker" of the last sample of each
    landmarks: Array  # (T+1,) landmarks measured in the call's last camera frame (0: none taken, or it failed)
    accepted: Array  # (T+1, 4) measurements folded in per sensor (camera: landmarks, over the call's frames)
    gauge: Array  # (T, 2) true x_{k+1} - z*_1|k in Omega_k (+) E_{k+1} per subsystem (<= 1: inside)
    gauge_estimate: Array  # (T, 2) x^_{k+1} - z*_1|k in Omega_k (the certified part)
    time_step: Array  # (T,) wall time of the navigation call that gave the estimate of step k + 1 (s)
    time_filter: Array  # (T,) of that call, the onboard estimator's part (C++ clock; sensors excluded) (s)
    # (T+1, 4) samples taken per sensor in the call (camera: frames); NaN in a file written before they were kept
    samples: Array
    # Fault detection (nav/faults.hpp, M50), per step k = 0..T; in a file written before it: none detected.
    fault_detected: Array  # (T+1,) 1 once a fault was detected (latched), else 0
    fault_cause: list[str]  # (T+1) the first detection's name ("none" while none)
    failed: Array  # (T+1, 4) samples per sensor whose NIS test failed in the call
    excluded: Array  # (T+1, 4) 1 for a sensor declared faulty and no longer folded in

    @classmethod
    def allocate(cls, n_steps: int) -> NavigationRecord:
        """Zeros for T = n_steps steps."""
        T1 = n_steps + 1
        z = np.zeros
        return cls(
            z((T1, 12)),
            z((T1, 12)),
            z((T1, 12)),
            z(T1),
            [],
            [],
            z(T1),
            z((T1, 4)),
            z((n_steps, 2)),
            z((n_steps, 2)),
            z(n_steps),
            z(n_steps),
            z((T1, 4)),
            z(T1),
            [],
            z((T1, 4)),
            z((T1, 4)),
        )

    def add(self, k: int, est: Any, x_true: Array, state_true: Array, imu: Any) -> None:
        """The estimate of step k against the true 12-state and 13-state (IMU: the true biases)."""
        self.x_hat[k] = est.x_hat
        self.sigma[k] = np.sqrt(np.maximum(np.diag(np.asarray(est.P_x)), 0.0))
        self.error[k] = x_true - np.asarray(est.x_hat)
        truth = _core.nav.NavState()
        truth.t, truth.r_L, truth.v_L, truth.q_BL = est.t, state_true[0:3], state_true[3:6], state_true[6:10]
        truth.gyro_bias_B, truth.accel_bias_B = imu.gyro_bias, imu.accel_bias
        self.nees[k] = _core.nav.nees(est.estimate, est.covariance, truth)
        self.status.append(str(est.status))
        self.sensor_status.append("/".join(str(s) for s in est.sensor_status))
        self.landmarks[k] = est.landmarks_visible
        self.accepted[k] = list(est.accepted)
        self.samples[k] = list(est.samples)
        self.fault_detected[k] = float(est.fault_detected)
        self.fault_cause.append(str(est.fault_cause))
        self.failed[k] = list(est.failed)
        self.excluded[k] = [float(e) for e in est.excluded]

    def truncate(self, n_run: int) -> None:
        """Cuts to the first ``n_run`` steps."""
        for name in (
            "x_hat",
            "sigma",
            "error",
            "nees",
            "landmarks",
            "accepted",
            "samples",
            "fault_detected",
            "failed",
            "excluded",
        ):
            setattr(self, name, getattr(self, name)[: n_run + 1])
        self.status, self.sensor_status = self.status[: n_run + 1], self.sensor_status[: n_run + 1]
        self.fault_cause = self.fault_cause[: n_run + 1]
        self.gauge, self.gauge_estimate = self.gauge[:n_run], self.gauge_estimate[:n_run]
        self.time_step, self.time_filter = self.time_step[:n_run], self.time_filter[:n_run]

    def campaign_arrays(self) -> dict[str, Array]:
        """What a Monte Carlo run keeps (its per-step arrays in the campaign's store): the estimation error
        and its sigmas, the NEES, the landmarks in view and the output-feedback tube's gauges."""
        return {
            "nav_error": self.error,
            "nav_sigma": self.sigma,
            "nav_nees": self.nees,
            "nav_landmarks": self.landmarks,
            "nav_gauge": self.gauge,
            "nav_gauge_estimate": self.gauge_estimate,
        }

    def arrays(self) -> dict[str, Any]:
        """The record's arrays, named nav_<field> (as results files keep them)."""
        return {f"nav_{k}": np.asarray(v) for k, v in dataclasses.asdict(self).items()}

    @classmethod
    def from_arrays(cls, raw: dict[str, Any]) -> NavigationRecord | None:
        """The record from a results file's arrays (None: the run flew without navigation)."""
        if "nav_x_hat" not in raw:
            return None
        values: dict[str, Any] = {}
        for f in dataclasses.fields(cls):
            if f.name in ("time_step", "time_filter") and f"nav_{f.name}" not in raw:  # written before it was timed
                values[f.name] = np.zeros(len(raw["nav_gauge"]))
                continue
            if f.name == "samples" and "nav_samples" not in raw:  # written before the samples were kept: unknown
                values[f.name] = np.full((len(raw["nav_nees"]), 4), np.nan)
                continue
            if f.name in _FAULT_FIELDS and f"nav_{f.name}" not in raw:  # written before the detection: none
                n1 = len(raw["nav_nees"])
                values[f.name] = ["none"] * n1 if f.name == "fault_cause" else np.zeros(_FAULT_FIELDS[f.name](n1))
                continue
            v = raw[f"nav_{f.name}"]
            strings = f.name in ("status", "sensor_status", "fault_cause")
            values[f.name] = [str(s) for s in v] if strings else np.asarray(v, dtype=float)
        return cls(**values)
