"""Closed-loop TBMPC and TBMPC-FFA on the 6-DOF model (paper Algorithm 1; docs/model.md "Closed loop").

Each control step k (dt = 2 s, T = t_f / dt steps) is one call of the C++ controller
(``_core.control.Controller``, cpp/include/tubempc/control/controller.hpp):

1. identification (paper Eq. 26-29) of the last period's measured exogenous input per subsystem;
2. tube update: TBMPC keeps the tube designed at set-up from the prior (paper Table 1); TBMPC-FFA
   flies the certified Lyapunov update of its current LMI design for the identified set (paper
   Eq. 25), a set-up library design where that fails (:mod:`tubempc.design.library`); due LMI designs
   run in the background (:mod:`tubempc.design.policy`) and are offered to the controller;
3. the tube MPC step (Problems 2 and 3, SCP about the shifted plan; QPs by the warm-started
   active set, PIQP where it does not verify) from the measured state x_k, with the ancillary law
   u = v0* + K (x_k - z0*) saturated at the true limits.

Around it, this module simulates the plant: truth propagation of the 13-state (quaternion attitude)
with the truth model (which may differ from the controller's: density, SRP, shape resolution), the
actuator mismatch, and the additive disturbance of paper Eq. (16) and (18) applied to the state
increment (``disturbance.model = "drawn"``), or, with ``"physical"``, no draw: the truth's physical
environment in the C++ propagation (``Scenario.physical``; docs/model.md "Physical environment"); and
records everything into a :class:`tubempc.results.RunRecord`.

The controller's state x = [r_L, v_L, phi, omega_BL_B] takes phi = log(q_B/L) on the branch nearest
to the reference (so that phi follows the reference through ``|phi| = pi``).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..config.faults import ACTUATOR_FAULT_KINDS
from ..design.abort import AbortLibrary, abort_library, command_step, new_abort
from ..design.library import kept_for_the_mission, mission_controller
from ..design.policy import BackgroundDesigns
from ..results.records import RunRecord
from ..scenario.actuators import describe_actuation
from ..scenario.build import METHODS, P_STATES, R_STATES, Scenario
from ..scenario.faults import actuator_fault, burst_window, inject, run_fault
from ..scenario.navigation import Navigation, NavigationRecord, new_navigation, tube_gauge
from .plant import ProjectPlant
from .setup import loop_setup, run_truth

__all__ = ["METHODS", "simulate"]

Array = npt.NDArray[np.float64]


def _record_step(rec: RunRecord, k: int, step: Any, ctrl: Any, times: tuple[float, float], wait: float) -> None:
    """Everything the controller's step k produced (``times`` = perf_counter stamps around the
    propagation; ``wait`` = the wait for a due background design, counted apart from the controller's
    time). The step folded w_{k-1} in: it is recorded at k - 1, as the estimates after it."""
    mpc = step.mpc
    z_plan = np.asarray(mpc.z)
    rec.z[k], rec.z_plan[k] = z_plan[:, 0], z_plan.T
    rec.u[k], rec.v[k] = np.asarray(step.u, dtype=float), np.asarray(mpc.v)[:, 0]
    K, Pe = np.asarray(step.tube.K), np.asarray(step.tube.Pe)
    rec.K[k], rec.Pe_p[k], rec.Pe_r[k] = K, Pe[P_STATES, P_STATES], Pe[R_STATES, R_STATES]
    rec.alpha[k] = list(step.alpha)
    if k > 0 and step.identified:
        _record_identification(rec, k - 1, np.asarray(step.w_measured), ctrl)
    rec.scp_iterations[k], rec.qp_iterations[k] = mpc.scp_iterations, mpc.qp_iterations
    rec.model_evaluations[k], rec.active_set_solves[k] = mpc.model_evaluations, mpc.active_set_solves
    tm, ct = mpc.timings, step.timings
    rec.time_linearize[k], rec.time_build[k], rec.time_solve[k] = tm.linearize, tm.build, tm.solve
    rec.time_tube[k], rec.time_mpc[k], rec.time_identify[k], rec.time_predict[k] = ct.tube, ct.mpc, ct.identify, ct.predict
    rec.time_step[k], rec.time_propagate[k], rec.time_design_wait[k] = ct.total, times[1] - times[0], wait
    rec.statuses.append(str(mpc.status))
    rec.failures.append(str(mpc.failure))
    rec.tube_statuses.append("/".join(str(s) for s in step.tube_status))


def _record_identification(rec: RunRecord, k: int, w_k: Array, ctrl: Any) -> None:
    """The measured input w_k and the identifiers' estimates after folding it in."""
    idents = (ctrl.identifier(0), ctrl.identifier(1))
    rec.w[k] = w_k
    rec.w_hat[k] = np.concatenate([np.asarray(i.w_hat) for i in idents])
    rec.S_p[k], rec.S_r[k] = np.asarray(idents[0].S_hat), np.asarray(idents[1].S_hat)


def _new_record(scn: Scenario, method: str, seed: int) -> RunRecord:
    """A record for the whole mission with its time base, reference and initial state filled in."""
    T, dt = scn.n_steps, scn.config.mpc.dt
    rec = RunRecord.allocate(method, seed, T, scn.config.mpc.horizon)
    rec.t[:] = np.arange(T + 1, dtype=np.float64) * dt
    rec.zbar[:], rec.ubar[:] = scn.reference.x, scn.reference.u
    rec.x[0] = scn.x0
    rec.g[0] = [scn.truth.glide_slope(scn.x0)[0], scn.truth.line_of_sight(scn.x0)[0]]
    return rec


def _new_plant(scn: Scenario, seed: int, dispersed: bool, fault: dict[str, Any] | None = None) -> ProjectPlant:
    """The run's plant: ``simulation.plant``'s, with the run's disturbance and actuator draws and its truth (in a
    physical environment the nominal one, or with ``dispersed`` the one drawn from the seed: :func:`run_truth`),
    and the run's disturbance burst (``fault``, the project's plant with the drawn disturbance only)."""
    loop = loop_setup(scn)
    system = None
    if loop.actuation is not None:
        suite = loop.actuation.suite
        unit = actuator_fault(fault, len(suite.cluster), len(suite.wheels))
        system = loop.actuation.system(seed + 1, unit)
        if unit is not None and fault is not None:
            fault["actuator"] = unit[1]  # the thruster or wheel that failed, kept with the run
    truth0 = scn.model.state_to_truth(scn.x0)
    kind = ProjectPlant
    if scn.config.simulation.plant == "basilisk":
        from .basilisk import BasiliskPlant

        kind = BasiliskPlant
    truth, physical = run_truth(scn, seed, dispersed)
    burst = burst_window(fault)
    if fault is not None and fault["kind"] in ACTUATOR_FAULT_KINDS and system is None:
        raise ValueError(f'faults.kind: {fault["kind"]!r} needs spacecraft.actuators other than "ideal"')
    if burst is not None and (kind is not ProjectPlant or physical is not None):
        raise ValueError(
            'faults.kind: "disturbance_burst" scales the drawn disturbance of the project\'s plant: it needs '
            'simulation.plant = "project" and disturbance.model = "drawn"'
        )
    plant = kind(
        scn,
        loop.plant_disturbance(seed),
        loop.actuators(seed),
        loop.propagator,
        truth0,
        system,
        environment=None if physical is None else physical.environment(),
        truth=truth,
        physical=physical,
    )
    plant.burst = burst
    return plant


@contextlib.contextmanager
def _mission_abort(scn: Scenario) -> Iterator[tuple[Any, AbortLibrary | None]]:
    """The run's safe abort (``_core.control.SafeAbort``, set up once per scenario and kept between runs like the
    controller, ``SafeAbort.reset`` per run) and the scenario's abort library, with ``[abort]`` enabled (None, None
    otherwise)."""
    if not scn.config.abort.enabled:
        yield None, None
        return
    library = abort_library(scn)
    with kept_for_the_mission(scn, "abort", lambda: new_abort(scn, library)) as abort:
        yield abort, library


def _record_actuation(rec: RunRecord, k: int, plant: ProjectPlant, dt: float) -> str:
    """The period's delivered input and, with an actuator model, its accounting (ideal: ``|u_p| dt``); returns the
    period's actuation status."""
    u_delivered, st = plant.delivered
    rec.u_delivered[k] = u_delivered
    if st is None:
        rec.delta_v[k] = float(np.linalg.norm(u_delivered[:3])) * dt
        rec.actuation_statuses.append("ideal")
        return "ideal"
    rec.delta_v[k], rec.propellant[k], rec.pulses[k] = st.delta_v, st.propellant, st.pulses
    rec.wheel_momentum[k] = np.asarray(plant.actuation.wheels.axes_B) @ np.asarray(st.wheel_momentum)
    rec.time_actuation[k] = st.step_time
    on_time = np.asarray(st.on_time)
    rec.thruster_on_time[k, : on_time.size] = on_time
    rec.actuation_statuses.append(str(st.status))
    return str(st.status)


def simulate(
    scn: Scenario,
    method: str,
    seed: int,
    *,
    progress: bool = False,
    lambda_p: float | None = None,
    lambda_r: float | None = None,
    max_steps: int | None = None,
    tube_threads: int = 2,
    design_worker: str | None = None,
    dispersed: bool = False,
) -> RunRecord:
    """One closed-loop run of ``method`` ("tbmpc" or "ffa") with disturbance seed ``seed``.

    ``dispersed``: in a physical environment (disturbance.model = "physical"), fly the truth drawn from the seed
    within the ``[physical]`` section's dispersions, as a Monte Carlo campaign's run does, instead of the nominal
    truth a single run flies (:func:`tubempc.sim.setup.run_truth`; no effect with the drawn model).

    ``lambda_p``/``lambda_r`` override the configuration's forgetting factors; ``max_steps`` stops
    the run early (arrays are then cut to the steps run); ``tube_threads`` = 2 runs the two
    subsystems' background designs in parallel threads (``design_worker = "thread"``), 1 one after
    the other; ``design_worker`` overrides ``tube.design_worker`` (the numbers do not depend on it when
    adoption is deterministic; "none": no background designs, the library stands in, as in a C++
    program flying the exported scenario).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    loop = loop_setup(scn)  # everything the run takes from the configuration, handed over once
    worker = design_worker or loop.tube.design_worker
    background = method == "ffa" and worker != "none"
    with (
        mission_controller(
            scn, method, loop.mpc_settings, lambda_p=lambda_p, lambda_r=lambda_r, background_designs=background
        ) as ctrl,
        _mission_abort(scn) as (abort, library),
    ):
        return _fly(
            scn, method, ctrl, abort, library, seed, progress, max_steps, tube_threads, worker, background, dispersed
        )


def _fly(
    scn: Scenario,
    method: str,
    ctrl: Any,
    abort: Any,
    library: AbortLibrary | None,
    seed: int,
    progress: bool,
    max_steps: int | None,
    tube_threads: int,
    worker: str,
    background: bool,
    dispersed: bool,
) -> RunRecord:
    """:func:`simulate`'s run on the controller ``ctrl`` and the safe abort ``abort`` with its ``library`` (None,
    None: no [abort]), both set up for the mission, at k = 0."""
    T, dt = scn.n_steps, scn.config.mpc.dt
    loop = loop_setup(scn)
    t = loop.tube
    fault = run_fault(scn.config, seed)  # [faults]: the given one, or one drawn from the seed
    # the step of a commanded abort (-1: none) and the last step's controller-side detections
    commanded_at = command_step(scn)
    tube_uncertified = allocation_infeasible = False
    # the estimate in the descent's last tube and the descent's identified set against its prior (p, r)
    excursion, disturbance_ratio, input_nis = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
    abort_residual, abort_uncertified = -math.inf, 0
    plant = _new_plant(scn, seed, dispersed, fault)
    rec = _new_record(scn, method, seed)
    x = scn.x0.copy()
    nav, est = _start_navigation(scn, plant, rec, seed, fault)
    # The navigation's fault detection, latched (nav/faults.hpp): a fault detected so far and its cause's name.
    fault_detected, fault_cause = (False, "none") if est is None else (bool(est.fault_detected), str(est.fault_cause))
    x_hat = x if est is None else np.asarray(est.x_hat)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=T, desc=method, unit="step", leave=False)
    wall0 = time.perf_counter()
    n_run = T if max_steps is None else max(1, min(int(max_steps), T))
    designs = (
        BackgroundDesigns(
            loop.designers(),
            delay=t.design_delay,
            adopt_when_ready=t.design_adoption == "when_ready",
            worker=worker,
            threads=tube_threads,
        )
        if background
        else None
    )
    try:
        for k in range(n_run):
            if abort is not None:  # the C++ supervision decides from the step's detections (latched)
                abort.monitor(
                    k,
                    _core.control.AbortTriggers(
                        command=k == commanded_at,
                        navigation_fault=fault_detected,
                        tube_uncertified=tube_uncertified,
                        allocation_infeasible=allocation_infeasible,
                        excursion=excursion,
                        disturbance_ratio=disturbance_ratio,
                        input_nis=input_nis,
                    ),
                    ctrl,
                )
            flying = ctrl if abort is None or not abort.aborting else abort
            if designs is not None and flying is ctrl:
                designs.adopt_due(k, ctrl)
            if est is not None:
                flying.set_estimation_error(plant.nav_error_set)
            step = flying.step(k, x_hat)
            if designs is not None and flying is ctrl:
                designs.submit(k, step, ctrl, t.redesign_margin)
            tube_uncertified = _core.control.TubeStatus.Uncertified in step.tube_status
            u = np.asarray(step.u, dtype=float).copy()
            t0 = time.perf_counter()
            x_next, w_true = plant.step(k, u)
            t1 = time.perf_counter()
            # Tube check (paper Proposition 1): the error after the step, x_{k+1} - z*_{1|k}, in the tube of step k.
            z1 = np.asarray(step.mpc.z)[:, 1]
            Pe = np.asarray(step.tube.Pe)
            if nav is not None:
                t_nav = time.perf_counter()
                reference = (
                    scn.reference if flying is ctrl or library is None else library.hover
                )  # the attitude branch flown
                est = nav.step(reference.x[k + 1, 6:9])
                x_hat = _record_navigation(rec, k, est, x_next, plant, z1, Pe, time.perf_counter() - t_nav)
                fault_detected, fault_cause = bool(est.fault_detected), str(est.fault_cause)
            else:
                x_hat = x_next
            # with navigation: the estimate's excursion in the certified tube (the truth's is rec.navigation.gauge)
            flier = flying.controller if flying is abort else ctrl
            excursion = flier.excursion(x_hat)
            rec.excursion[k] = excursion
            if nav is not None:
                rec.navigation.gauge_estimate[k] = np.sqrt(excursion)
            disturbance_ratio, input_nis = step.disturbance_ratio, step.input_nis
            rec.w_true[k] = w_true
            allocation_infeasible = _record_actuation(rec, k, plant, dt) == "infeasible"
            _record_step(rec, k, step, flier, (t0, t1), 0.0 if designs is None else designs.last_wait_s)
            if flying is abort:  # the abort's certification at every step it flies
                abort_residual = max(abort_residual, *step.residual)
                abort_uncertified += not all(_core.control.certified(s) for s in step.tube_status)
            x = x_next
            rec.x[k + 1] = x
            rec.g[k + 1] = [scn.truth.glide_slope(x, (k + 1) * dt)[0], scn.truth.line_of_sight(x)[0]]
            if bar is not None:
                bar.update()
        if (abort is None or not abort.aborting) and ctrl.identify(
            n_run, x_hat
        ):  # the last period's input, which no later step folds in
            _record_identification(rec, n_run - 1, np.asarray(ctrl.last_measured_input), ctrl)
    finally:
        if designs is not None:
            designs.close()
    if bar is not None:
        bar.close()
    rec.design_failures = [] if designs is None else list(designs.design_failures)
    rec.wall_time_s = time.perf_counter() - wall0
    if n_run < T:
        rec.truncate(n_run)
        if rec.navigation is not None:
            rec.navigation.truncate(n_run)
    rec.applied = _applied(scn, plant, rec, max_steps)
    rec.applied["fault"] = fault  # None: fault-free
    if abort is not None and library is not None:
        d = abort.decision
        rec.applied["abort"] = {  # the library is the scenario's (AbortLibrary.describe): its commit step only
            "commit_step": library.commit_step,
            "mode": str(d.mode),
            "cause": str(d.cause),
            "entered_at_step": d.entered_at if d.entered_at >= 0 else None,
            "refused_cause": str(d.refused_cause),
            "refused_at_step": d.refused_at if d.refused_at >= 0 else None,
            "max_residual": abort_residual if math.isfinite(abort_residual) else None,
            "uncertified_steps": abort_uncertified,
        }
    # the detection's outcome: every detection's first time (s; None: not detected), the same keys in every run
    times = [math.nan] * len(_nav_fault_names()) if est is None else list(est.detected_at)
    rec.applied["fault_detection"] = {
        "detected": fault_detected,
        "cause": fault_cause,
        "detected_at": {n: float(t) if math.isfinite(t) else None for n, t in zip(_nav_fault_names(), times, strict=True)},
    }
    return rec


def _nav_fault_names() -> list[str]:
    """The names of ``_core.nav.NavFault`` in the order of ``NavigationStep.detected_at`` (the C++ name table's)."""
    from .. import _core

    return list(_core.nav.NavFault.names())


def _start_navigation(
    scn: Scenario, plant: ProjectPlant, rec: RunRecord, seed: int, fault: dict[str, Any] | None = None
) -> tuple[Navigation | None, Any]:
    """The run's navigation, started at the initial state (None, None: the controller reads the truth)."""
    nav = new_navigation(scn, seed, plant.DISTURBANCE_DELIVERY)
    if nav is None:
        return None, None
    inject(nav.system, scn.config, fault)
    plant.nav = nav
    rec.navigation = NavigationRecord.allocate(scn.n_steps)
    est = nav.initialize(plant.state, scn.reference.x[0, 6:9])
    rec.navigation.add(0, est, scn.x0, plant.state, nav.system.imu)
    plant.nav_error_set = nav.error_set(est.P_x)
    return nav, est


def _record_navigation(
    rec: RunRecord, k: int, est: Any, x_next: Array, plant: ProjectPlant, z1: Array, Pe: Array, seconds: float
) -> Array:
    """Step k + 1's estimate into the record (``seconds``: the navigation call's wall time), and the truth's
    gauge in the output-feedback tube z*_1|k (+) Omega_k (+) E_{k+1} (the estimate's is the step's excursion);
    returns the estimate x^_{k+1}."""
    assert plant.nav is not None and rec.navigation is not None
    rec.navigation.time_step[k], rec.navigation.time_filter[k] = seconds, est.time_filter
    x_hat = np.asarray(est.x_hat)
    rec.navigation.add(k + 1, est, x_next, plant.state, plant.nav.system.imu)
    plant.nav_error_set = E = plant.nav.error_set(est.P_x)
    for i, sx in enumerate((P_STATES, R_STATES)):
        rec.navigation.gauge[k, i] = tube_gauge(x_next[sx] - z1[sx], Pe[sx, sx], E[sx, sx])
    return x_hat


def _applied(scn: Scenario, plant: ProjectPlant, rec: RunRecord, max_steps: int | None) -> dict[str, Any]:
    """The dispersions the run actually applied, with the realised disturbance's statistics (SI units,
    per state component: mean, standard deviation and largest |w|) for checking that they were."""
    sim = scn.config.simulation
    w = rec.w_true
    truth: dict[str, Any] = {
        "density_scale": sim.density_scale,
        "srp_scale": sim.srp_scale,
        "truth_shape_subdivisions": sim.truth_shape_subdivisions,
    }
    if plant.physical is None:
        disturbance, ideal_actuators = plant.disturbance.describe(), plant.actuators.describe()
    else:  # no draw; the actuator errors are the environment's, in B; the truth the run's (nominal or dispersed)
        disturbance = {"model": "physical", "seed": rec.seed, "dispersed": plant.physical.drawn is not None}
        ideal_actuators = dict(plant.physical.actuators)
        truth["physical"] = plant.physical.describe()
    return {
        "seed": rec.seed,
        "max_steps": max_steps,
        "plant": plant.describe(),
        "disturbance": disturbance,
        "actuators": ideal_actuators
        if plant.actuation is None
        else describe_actuation(plant.actuation, loop_setup(scn).actuation),
        "truth": truth,
        "realised_disturbance": {
            "mean": w.mean(axis=0).tolist(),
            "std": w.std(axis=0).tolist(),
            "max_abs": np.abs(w).max(axis=0).tolist(),
        },
    }
