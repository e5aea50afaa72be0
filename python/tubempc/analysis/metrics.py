"""Closed-loop performance metrics (paper Eq. 54-55, Tables 3-4; docs/model.md "Metrics").

Arrays follow the state layout x = [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)] and the input
layout u = [u_p (m/s^2, frame L), T (N m, frame B)]. ``x`` has T + 1 rows (k = 0..T), ``u`` has T rows.

Definitions used throughout (the paper gives no index range; this is the project's reading):

- J_p = sum_{k=0}^{T-1} ||x_p(k) - zbar_p(k)||^2_Q + ||u_p(k)||^2_R with Q = I, R = I (Eq. 54), and J_r
  likewise for [phi, omega] and T (Eq. 55).
- total control effort per group = sum_k ||u_g(k)||_2 (the paper's units m/s^2 and N m);
  the translational delta-v = sum_k ||u_p(k)|| dt is reported beside it.
- terminal error per state group = ||x_g(T) - x_f,g||_2; RMS error per state group =
  sqrt(mean_k ||x_g(k) - zbar_g(k)||^2) over k = 0..T.
- tube excursion = e^T Pe_k^-1 e with e = x_{k+1} - z*_{1|k} per subsystem, the error one step after the
  plan, which robust invariance bounds by 1 (> 1: outside the tube).
- a run flown on navigation (:func:`navigation_summary`): the estimation error x - x^ at the last step, the
  average NEES against its chi-square bounds (:func:`nees_test`; the steps taken as independent, which
  is optimistic), the camera's landmarks folded in, and the truth's gauge in the output-feedback tube.
"""

from __future__ import annotations

import collections
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from scipy.optimize import minimize_scalar
from scipy.stats import chi2

from .. import _core
from ..design.tube import tube_excursion
from ..results.summaries import (
    ActuationSummary,
    ConstraintViolations,
    ControlEffort,
    EnvelopeFit,
    FaultSummary,
    GroupErrors,
    NavigationSummary,
    NeesTest,
    RunMetrics,
    StepTime,
    SubsystemValues,
    fallback_steps,
)

if TYPE_CHECKING:
    from ..results.records import RunRecord
    from ..scenario.navigation import NavigationRecord

__all__ = [
    "CERTIFIED_TUBE_STATUSES",
    "GROUPS",
    "NOT_DELIVERED",
    "ConvergenceFit",
    "actuation_summary",
    "below_or_above",
    "control_effort",
    "fault_summary",
    "fit_exponential_convergence",
    "navigation_summary",
    "nees_bounds",
    "nees_test",
    "net_delta_v",
    "nominal_input_fraction",
    "performance_index",
    "prior_bound_exceedances",
    "rms_error",
    "run_metrics",
    "step_time_stats",
    "steps_outside_tube",
    "terminal_error",
    "tube_excursion",
    "tube_status_certified",
    "velocity_convergence",
]

#: Tube excursions above 1 + this count as outside the tube (round-off of the e^T Pe^-1 e evaluation).
EXCURSION_TOLERANCE: float = _core.control.EXCURSION_TOLERANCE  # one value, the C++ step's (control::kExcursionTolerance)
#: Step phases whose wall times a run records (``RunRecord.time_<phase>``).
STEP_PHASES = ("step", "tube", "mpc", "linearize", "build", "solve", "propagate", "identify", "predict")

Array = npt.NDArray[np.float64]

#: State groups (slices of the 12-state x) with their units.
GROUPS: dict[str, tuple[slice, str]] = {
    "position": (slice(0, 3), "m"),
    "velocity": (slice(3, 6), "m/s"),
    "attitude": (slice(6, 9), "rad"),
    "angular_velocity": (slice(9, 12), "rad/s"),
}
_SUBSYSTEM_STATES = {"translation": slice(0, 6), "rotation": slice(6, 12)}
_SUBSYSTEM_INPUTS = {"translation": slice(0, 3), "rotation": slice(3, 6)}


def _check(x: Array, zbar: Array, u: Array | None = None) -> None:
    if x.ndim != 2 or x.shape[1] != 12 or x.shape != zbar.shape:
        raise ValueError(f"x and zbar must both be (T+1, 12), got {x.shape} and {zbar.shape}")
    if u is not None and (u.ndim != 2 or u.shape != (x.shape[0] - 1, 6)):
        raise ValueError(f"u must be (T, 6) for x of shape {x.shape}, got {u.shape}")
    for name, a in (("x", x), ("zbar", zbar), ("u", u)):
        if a is not None and not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains non-finite values")


def performance_index(
    x: Array, zbar: Array, u: Array, subsystem: str, Q: Array | None = None, R: Array | None = None
) -> float:
    """J_p (``subsystem="translation"``) or J_r (``"rotation"``) of paper Eq. (54)-(55)."""
    _check(x, zbar, u)
    sx, su = _SUBSYSTEM_STATES[subsystem], _SUBSYSTEM_INPUTS[subsystem]
    e = x[:-1, sx] - zbar[:-1, sx]
    uu = u[:, su]
    Qm = np.eye(6) if Q is None else np.asarray(Q, dtype=float)
    Rm = np.eye(3) if R is None else np.asarray(R, dtype=float)
    return float(np.einsum("ki,ij,kj->", e, Qm, e) + np.einsum("ki,ij,kj->", uu, Rm, uu))


def control_effort(u: Array, dt: float) -> dict[str, float]:
    """Sum of input norms per group (m/s^2 and N m) and the translational delta-v (m/s)."""
    up, tq = np.linalg.norm(u[:, 0:3], axis=1), np.linalg.norm(u[:, 3:6], axis=1)
    return {"translation": float(up.sum()), "rotation": float(tq.sum()), "delta_v": float(up.sum() * dt)}


def terminal_error(x: Array, x_f: Array) -> dict[str, float]:
    """||x_g(T) - x_f,g|| per state group."""
    return {g: float(np.linalg.norm(x[-1, s] - x_f[s])) for g, (s, _) in GROUPS.items()}


def rms_error(x: Array, zbar: Array) -> dict[str, float]:
    """sqrt(mean_k ||x_g(k) - zbar_g(k)||^2) per state group."""
    _check(x, zbar)
    return {g: float(np.sqrt(np.mean(np.sum((x[:, s] - zbar[:, s]) ** 2, axis=1)))) for g, (s, _) in GROUPS.items()}


#: A fitted rho this close to 1 sits at the search's upper bound: no exponential decay was found.
RHO_AT_BOUND = 1.0 - 1e-6


@dataclass(frozen=True)
class ConvergenceFit:
    """Envelope ||e_k|| <= C rho^k ||e_0|| + ebar (paper Theorem 2, Eq. 46) fitted to error data.

    ``no_fit``: empty when an envelope was fitted; else why none exists (the error never exceeds ebar
    after its transient, or the best rho is the search bound 1, no decay), and C, rho are not results."""

    C: float
    rho: float
    ebar: float
    e0: float
    no_fit: str = ""

    @property
    def exists(self) -> bool:
        return not self.no_fit

    def bound(self, k: npt.ArrayLike) -> Array:
        return self.C * self.rho ** np.asarray(k, dtype=float) * self.e0 + self.ebar


def fit_exponential_convergence(errors: npt.ArrayLike, ebar: float | None = None) -> ConvergenceFit:
    """Tightest exponential envelope of an error-norm sequence.

    ``ebar`` defaults to the largest error over the last quarter of the run (the bounded residual the
    disturbance leaves). For each rho in (0, 1) the smallest C with e_k <= C rho^k e_0 + ebar for all k
    is taken; rho minimises the envelope's area sum_k C rho^k e_0 (bounded scalar search on log rho).
    """
    e = np.asarray(errors, dtype=float)
    if e.ndim != 1 or e.size < 3 or not np.all(np.isfinite(e)) or np.any(e < 0):
        raise ValueError("errors must be a 1-D sequence of >= 3 finite non-negative norms")
    eb = float(np.max(e[-max(1, e.size // 4) :])) if ebar is None else float(ebar)
    e0 = float(e[0])
    if e0 <= 0.0:
        raise ValueError("the initial error ||e_0|| must be positive")
    k = np.arange(e.size, dtype=float)
    excess = e - eb
    active = excess > 0.0
    if not np.any(active):
        why = (
            f"the error never exceeds ebar = {eb:.3g} (its largest value over the run's last quarter) after the "
            "transient: there is no decay to fit"
        )
        return ConvergenceFit(C=0.0, rho=0.0, ebar=eb, e0=e0, no_fit=why)
    log_excess, k_active = np.log(excess[active] / e0), k[active]

    def log_c(log_rho: float) -> float:  # log of the smallest C for this rho (log space: rho^k underflows)
        return float(np.max(log_excess - k_active * log_rho))

    def log_area(log_rho: float) -> float:
        rho = np.exp(log_rho)
        return log_c(log_rho) + float(np.log((1.0 - rho**e.size) / (1.0 - rho)))

    res = minimize_scalar(log_area, bounds=(np.log(1e-6), np.log(1.0 - 1e-9)), method="bounded", options={"xatol": 1e-12})
    rho = float(np.exp(res.x))
    why = (
        f"the best rho is the search bound 1 ({rho:.10f}): the error does not decay exponentially towards ebar = {eb:.3g}"
        if rho >= RHO_AT_BOUND
        else ""
    )
    return ConvergenceFit(C=float(np.exp(log_c(res.x))), rho=rho, ebar=eb, e0=e0, no_fit=why)


def steps_outside_tube(excursion: Array) -> int:
    """Steps whose excursion (T, 2) exceeds 1 in either subsystem (1 + EXCURSION_TOLERANCE)."""
    return int(np.sum(np.any(np.asarray(excursion) > 1.0 + EXCURSION_TOLERANCE, axis=1)))


def step_time_stats(seconds: Array) -> dict[str, float]:
    """Median, 99th percentile, mean and maximum of per-step wall times, in milliseconds."""
    ms = 1e3 * np.asarray(seconds, dtype=float)
    return {
        "median_ms": float(np.median(ms)),
        "p99_ms": float(np.percentile(ms, 99)),
        "mean_ms": float(np.mean(ms)),
        "max_ms": float(np.max(ms)),
    }


def velocity_convergence(t: Array, x: Array, zbar: Array) -> tuple[Array, Array, ConvergenceFit]:
    """Theorem 2 envelope of ||v - vbar|| (m/s) (paper Figure 14): the times, the error norms and the
    fit, from the largest error of the transient (the first quarter of the run) on, so that the fit
    spans at least three quarters of the run."""
    err = np.linalg.norm(x[:, 3:6] - zbar[:, 3:6], axis=1)
    k0 = int(np.argmax(err[: max(1, len(err) // 4)]))
    return t[k0:], err[k0:], fit_exponential_convergence(err[k0:])


def _fit(rec: RunRecord) -> EnvelopeFit:
    """The Theorem 2 envelope of the run, or the reason none exists (never a search bound reported as
    a fit)."""
    try:
        _, _, fit = velocity_convergence(rec.t, rec.x, rec.zbar)
    except ValueError as exc:  # too short, or no error at all
        return EnvelopeFit(exists=False, reason=str(exc))
    if not fit.exists:
        return EnvelopeFit(exists=False, reason=fit.no_fit)
    return EnvelopeFit(exists=True, C_e0_m_per_s=fit.C * fit.e0, rho=fit.rho, ebar_m_per_s=fit.ebar)


#: Tube statuses of the C++ controller (``_core.control.TubeStatus``) whose tube is certified for the
#: step's linearisation and identified P_W (TBMPC's "fixed" tube is not: it was designed for the prior).
CERTIFIED_TUBE_STATUSES = frozenset(
    str(s) for s in _core.control.TubeStatus.__members__.values() if _core.control.certified(s)
)


def tube_status_certified(status: str) -> bool:
    """A step's tube status "<translation>/<rotation>" names a certified tube for both subsystems."""
    return all(part in CERTIFIED_TUBE_STATUSES for part in status.split("/"))


#: Actuation statuses of a period the actuators did not deliver (actuators::AllocationStatus).
NOT_DELIVERED = frozenset({"saturated", "infeasible", "invalid_command"})


def net_delta_v(rec: RunRecord, dt: float) -> float:
    """The net delta-v delivered (m/s): the sum of ``|u_p delivered| dt`` (ideal actuators: the command's)."""
    return float(np.linalg.norm(rec.u_delivered[:, :3], axis=1).sum() * dt)


def actuation_summary(rec: RunRecord, dt: float) -> ActuationSummary | None:
    """A run's actuation totals (docs/model.md M37); None for ideal actuators (or a record without them)."""
    if not rec.actuation_statuses or all(s == "ideal" for s in rec.actuation_statuses):
        return None
    return ActuationSummary(
        thruster_delta_v=float(np.sum(rec.delta_v)),
        net_delta_v=net_delta_v(rec, dt),
        propellant=float(np.sum(rec.propellant)),
        pulses=int(np.sum(rec.pulses)),
        max_wheel_momentum=float(np.linalg.norm(rec.wheel_momentum, axis=1).max()),
        statuses=dict(collections.Counter(rec.actuation_statuses)),
        not_delivered_steps=sum(s in NOT_DELIVERED for s in rec.actuation_statuses),
    )


#: Navigation statuses (``_core.nav.NavigationStatus``) of a step whose NEES is taken: the filter ran
#: (a numerical failure or an invalid input leaves an estimate that is not the filter's answer to the step).
NEES_STATUSES = frozenset({"ok", "prediction_only"})
#: Camera column of the navigation record's per-sensor arrays (``_core.nav.Sensor``).
CAMERA = 1


def nees_bounds(steps: int, dof: int, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided bounds of the average of ``steps`` = N independent NEES samples of dimension ``dof`` = n
    (each chi-square with n degrees of freedom for a consistent filter, their sum chi-square with N n):
    (chi2.ppf(a/2, N n) / N, chi2.ppf(1 - a/2, N n) / N) with a = 1 - ``probability``. Independence is
    an assumption: successive steps' errors are correlated, so these bounds are narrower than the
    average's true spread (optimistic)."""
    if steps < 1 or dof < 1 or not 0.0 < probability < 1.0:
        raise ValueError(
            f"nees_bounds needs steps >= 1, dof >= 1 and 0 < probability < 1, got {steps}, {dof}, {probability}"
        )
    a = 1.0 - probability
    return float(chi2.ppf(a / 2.0, steps * dof) / steps), float(chi2.ppf(1.0 - a / 2.0, steps * dof) / steps)


def nees_test(nees: Array, dof: int, probability: float = 0.95) -> NeesTest | None:
    """The average of the NEES samples ``nees`` (the valid steps' only) against :func:`nees_bounds`;
    None for no sample."""
    x = np.asarray(nees, dtype=float)
    if x.size == 0:
        return None
    mean = float(np.mean(x))
    lower, upper = nees_bounds(x.size, dof, probability)
    return NeesTest(
        mean=mean,
        steps=int(x.size),
        dof=dof,
        probability=probability,
        lower=lower,
        upper=upper,
        inside=lower <= mean <= upper,
    )


def fault_summary(applied: Mapping[str, Any]) -> FaultSummary | None:
    """A run's injected fault and its detection (:class:`tubempc.results.summaries.FaultSummary`) from its
    ``applied`` (``fault``, ``fault_detection``); None when no fault was injected and none detected (or a run
    recorded before them)."""
    fault, det = applied.get("fault"), applied.get("fault_detection") or {}
    detected = bool(det.get("detected", False))
    if fault is None and not detected:
        return None
    cause = str(det.get("cause", "none"))
    t_detect = (det.get("detected_at") or {}).get(cause) if detected else None
    onset = None if fault is None else float(fault["start"])
    return FaultSummary(
        injected="none" if fault is None else str(fault["kind"]),
        onset=onset,
        detected=detected,
        cause=cause,
        detection_time=None if t_detect is None else float(t_detect),
        latency=None if t_detect is None or onset is None else float(t_detect) - onset,
    )


def navigation_summary(nav: NavigationRecord, applied: Mapping[str, Any] | None = None) -> NavigationSummary:
    """How a run's navigation went (:class:`tubempc.results.summaries.NavigationSummary`), from its record:

    - the estimation error x - x^ at the last step (touchdown for a whole run), norm per state group;
    - the average NEES over the steps k = 0..T whose NEES is finite (``_core.nav.nees`` is NaN for a
      covariance that is not positive definite) and whose navigation status is "ok" or
      "prediction_only", against its 95 % bounds (:func:`nees_test`; dimension ``_core.nav.N_STATES``
      = 15: the NEES is taken on the filter's whole error state against the truth, IMU biases included);
    - the camera's landmarks folded into the filter (``accepted``'s camera column: over every frame of a
      control period, after the filter's gate; ``landmarks`` counts the last frame's only, before the
      gate, and is not used) over the run, per frame taken (``samples``' camera column, frames lost or
      without landmarks included), and the fewest per frame in one period that took a frame;
    - the truth's largest gauge per subsystem in the output-feedback tube and the steps with a gauge
      above 1 (+ :data:`EXCURSION_TOLERANCE`) in either."""
    dof = int(_core.nav.N_STATES)
    valid = np.isfinite(nav.nees) & np.array([s in NEES_STATUSES for s in nav.status], dtype=bool)
    used = np.asarray(nav.accepted, dtype=float)[:, CAMERA]
    frames = np.asarray(nav.samples, dtype=float)[:, CAMERA]
    counted = bool(np.all(np.isfinite(frames)))  # False: a record written before the frames were kept
    taken = frames > 0 if counted else np.zeros(frames.shape, dtype=bool)
    gauge = np.asarray(nav.gauge, dtype=float).reshape(-1, 2)
    e = np.asarray(nav.error, dtype=float)[-1]
    return NavigationSummary(
        touchdown_error=GroupErrors(**{g: float(np.linalg.norm(e[s])) for g, (s, _) in GROUPS.items()}),
        nees=nees_test(np.asarray(nav.nees, dtype=float)[valid], dof),
        landmarks_used=int(used.sum()),
        camera_frames=int(frames.sum()) if counted else None,
        landmarks_per_frame_mean=float(used.sum() / frames.sum()) if taken.any() else None,
        landmarks_per_frame_min=float(np.min(used[taken] / frames[taken])) if taken.any() else None,
        max_gauge=SubsystemValues(
            translation=float(gauge[:, 0].max(initial=0.0)), rotation=float(gauge[:, 1].max(initial=0.0))
        ),
        steps_outside_output_tube=int(np.sum(np.any(gauge > 1.0 + EXCURSION_TOLERANCE, axis=1))),
        faults=None if applied is None else fault_summary(applied),
    )


def run_metrics(rec: RunRecord, dt: float, x_f: Array) -> RunMetrics:
    """Every scalar result of one closed-loop run: J_p and J_r (Eq. 54-55), control effort, terminal and
    RMS errors, the tube excursions, the constraint violations of the actual trajectory, step-time
    statistics, solver figures, statuses, the velocity-convergence fit and, flown on navigation, how the
    navigation went (:func:`navigation_summary`)."""
    g = rec.g
    return RunMetrics(
        J_p=performance_index(rec.x, rec.zbar, rec.u, "translation"),
        J_r=performance_index(rec.x, rec.zbar, rec.u, "rotation"),
        control_effort=ControlEffort(**control_effort(rec.u, dt)),
        terminal_error=GroupErrors(**terminal_error(rec.x, x_f)),
        rms_error=GroupErrors(**rms_error(rec.x, rec.zbar)),
        max_tube_excursion=SubsystemValues(
            translation=float(rec.excursion[:, 0].max()), rotation=float(rec.excursion[:, 1].max())
        ),
        steps_outside_tube=steps_outside_tube(rec.excursion),
        fallback_steps=fallback_steps(collections.Counter(rec.statuses)),
        constraint_violations=ConstraintViolations(
            glide_slope_steps=int(np.sum(g[:, 0] > 0)),
            los_steps=int(np.sum(g[:, 1] > 0)),
            max_glide_slope_g_m=float(g[:, 0].max()),
            max_los_g_m=float(g[:, 1].max()),
        ),
        step_time={name: StepTime(**step_time_stats(getattr(rec, f"time_{name}"))) for name in STEP_PHASES},
        scp_iterations_mean=float(np.mean(rec.scp_iterations)),
        model_evaluations_mean=float(np.mean(rec.model_evaluations)),
        active_set_qp_fraction=float(np.sum(rec.active_set_solves) / max(1.0, float(np.sum(rec.scp_iterations)))),
        velocity_convergence_fit=_fit(rec),
        statuses=dict(collections.Counter(rec.statuses)),
        tube_statuses=dict(collections.Counter(rec.tube_statuses)),
        # Every step flew a designed or certified tube: no failed LMI design, no step on a last
        # certified tube because the step's could not be certified.
        tube_design_failures=len(rec.design_failures),
        tube_uncertified_steps=sum(not tube_status_certified(s) for s in rec.tube_statuses),
        tube_feasible_every_step=not rec.design_failures and all(map(tube_status_certified, rec.tube_statuses)),
        run_time_s=rec.wall_time_s,
        seed=rec.seed,
        actuation=actuation_summary(rec, dt),
        navigation=None if rec.navigation is None else navigation_summary(rec.navigation, rec.applied),
    )


def below_or_above(reduction_percent: float) -> str:
    """A reduction in percent as words: "12.3 % below", "0.5 % above" (never "-0.5 % below")."""
    word = "below" if reduction_percent >= 0.0 else "above"
    return f"{abs(reduction_percent):.1f} % {word}"


def prior_bound_exceedances(w: Array, prior_variances: Array, pw_scale: float) -> npt.NDArray[np.bool_]:
    """Where the measured exogenous inputs ``w`` (T, 12) leave TBMPC's fixed per-component bound
    sqrt(pw_scale * prior variance) (paper Fig. 11): a boolean (T, 12) array."""
    return np.asarray(np.abs(w) > np.sqrt(pw_scale * np.asarray(prior_variances, dtype=np.float64)))


def nominal_input_fraction(rec: RunRecord, u_max: float) -> Array:
    """Per step, the fraction of the translational input bound the tube leaves to the nominal input: min_i
    1 - sqrt(K_i Pe K_i^T) / u_max over the three force rows of K (the MPC's input tightening, docs/model.md
    "Tube MPC"; K is block-diagonal, so its force rows see the translational Pe_p only)."""
    K = np.asarray(rec.K)[:, :3, :6]
    feedback = np.sqrt(np.maximum(np.einsum("kij,kjl,kil->ki", K, np.asarray(rec.Pe_p), K), 0.0))
    return np.asarray(1.0 - feedback.max(axis=1) / u_max)
