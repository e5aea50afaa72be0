"""Closed-loop TBMPC and TBMPC-FFA on the 6-DOF model (paper Algorithm 1; docs/model.md).

Each control step k (dt = 2 s, T = t_f / dt steps):

1. tube update (:class:`tubempc.tube_policy.TubeUpdatePolicy`): TBMPC keeps the tube designed at
   k = 0 from the prior covariances (paper Table 1); TBMPC-FFA re-designs it from the identified
   covariance (P_W = pw_scale S^_k, paper Eq. 25), keeping a tube while it is certified;
2. the C++ tube MPC step (Problems 2 and 3, SCP about the shifted plan; QPs by the warm-started
   active set, PIQP where it does not verify) from the measured state x_k, with the ancillary law
   u = v0* + K (x_k - z0*) saturated at the true limits;
3. truth propagation of the 13-state (quaternion attitude) with the truth model (which may differ
   from the controller's: density, SRP, shape resolution), the actuator mismatch, and the additive
   disturbance of paper Eq. (16) and (18) applied to the state increment;
4. identification (paper Eq. 26-29) of the measured exogenous input per subsystem;
5. recording into a :class:`tubempc.results.RunRecord`.

The controller's state x = [r_L, v_L, phi, omega_BL_B] takes phi = log(q_B/L) on the branch nearest
to the reference (so that phi follows the reference through ``|phi| = pi``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
from .disturbances import ActuatorMismatch, AdditiveDisturbance
from .identification import ForgettingFactorIdentifier, measured_reference_deviation, measured_residual
from .metrics import tube_excursion
from .results import RunRecord
from .scenario import (
    METHODS,
    P_INPUTS,
    P_STATES,
    R_INPUTS,
    R_STATES,
    Scenario,
    block_tube,
    identifiers,
    mpc_settings,
    plant_disturbance,
    propagator_options,
    tube_designers,
)
from .tube import TubeResult
from .tube_policy import TubeUpdatePolicy

__all__ = ["METHODS", "simulate"]

Array = npt.NDArray[np.float64]


@dataclass
class _Plant:
    """The simulated plant of one run: truth model, actuators, disturbance and truth state."""

    scn: Scenario
    disturbance: AdditiveDisturbance
    actuators: ActuatorMismatch
    propagate_kw: dict[str, Any]
    state: Array  # 13-state [r_L, v_L, q_B/L, omega_BL_B] of the truth

    def step(self, k: int, u: Array) -> tuple[Array, Array]:
        """Propagates one control period with input ``u``; returns x_{k+1} and the disturbance drawn."""
        scn, dt = self.scn, self.scn.config.mpc.dt
        u_applied = np.concatenate([self.actuators.apply_acceleration(u[:3]), self.actuators.apply_torque(u[3:])])
        prop = scn.truth.propagate(k * dt, self.state, u_applied, dt, **self.propagate_kw)
        if prop.status.name != "Success":
            raise RuntimeError(f"truth propagation failed at step {k}: {prop.status.name}")
        w_p, w_r = self.disturbance.sample(k)
        x_next = scn.truth.truth_to_state(np.asarray(prop.state), scn.reference.x[k + 1, 6:9])
        x_next[P_STATES] += w_p
        x_next[R_STATES] += w_r
        self.state = scn.truth.state_to_truth(x_next)
        return x_next, np.concatenate([w_p, w_r])


def _measured_input(scn: Scenario, k: int, x: Array, u: Array, x_next: Array) -> Array:
    """The measured exogenous input w_k (``identification.measured_input``; docs/model.md)."""
    if scn.config.identification.measured_input == "residual":
        Ak, Bk, ck = scn.model.discretize(k * scn.config.mpc.dt, x, u, scn.config.mpc.dt)
        return measured_residual(x_next, Ak, Bk, ck, x, u)
    return measured_reference_deviation(x_next, scn.reference.x[k + 1])


Identifiers = tuple[ForgettingFactorIdentifier, ForgettingFactorIdentifier]


def _tube_update(
    scn: Scenario, policy: TubeUpdatePolicy, k: int, idents: Identifiers
) -> tuple[list[TubeResult], str | None]:
    """Step 1: the subsystems' tubes for step k, about the reference's node k."""
    dt = scn.config.mpc.dt
    if policy.tubes is not None and not policy.adaptive:
        return policy.tubes, None
    Ad, Bd, _ = scn.model.discretize(k * dt, scn.reference.x[k], scn.reference.u[k], dt)
    return policy.update(
        k,
        (Ad[P_STATES, P_STATES], Ad[R_STATES, R_STATES]),
        (Bd[P_STATES, P_INPUTS], Bd[R_STATES, R_INPUTS]),
        (idents[0].P_W, idents[1].P_W),
    )


def _record_step(
    rec: RunRecord,
    k: int,
    step: Any,
    tubes: list[TubeResult],
    K: Array,
    w_meas: Array,
    w_true: Array,
    idents: tuple[ForgettingFactorIdentifier, ForgettingFactorIdentifier],
    times: tuple[float, float, float, float, float],
    wait: float,
) -> None:
    """Step 5: everything the step produced (``times`` = the perf_counter stamps t0..t4; ``wait`` =
    the tube update's wait for a due background design, counted apart from the controller's time)."""
    z_plan = np.asarray(step.z)
    rec.z[k], rec.z_plan[k] = z_plan[:, 0], z_plan.T
    rec.u[k], rec.v[k] = np.asarray(step.u, dtype=float), np.asarray(step.v)[:, 0]
    rec.K[k], rec.Pe_p[k], rec.Pe_r[k] = K, tubes[0].Pe, tubes[1].Pe
    rec.alpha[k] = [tubes[0].alpha, tubes[1].alpha]
    rec.w[k], rec.w_true[k] = w_meas, w_true
    rec.w_hat[k] = np.concatenate([idents[0].w_hat, idents[1].w_hat])
    rec.S_p[k], rec.S_r[k] = idents[0].S_hat, idents[1].S_hat
    rec.scp_iterations[k], rec.qp_iterations[k] = step.scp_iterations, step.qp_iterations
    rec.model_evaluations[k], rec.active_set_solves[k] = step.model_evaluations, step.active_set_solves
    tm = step.timings
    rec.time_linearize[k], rec.time_build[k], rec.time_solve[k] = tm.linearize, tm.build, tm.solve
    t0, t1, t2, t3, t4 = times
    rec.time_tube[k], rec.time_mpc[k], rec.time_propagate[k] = t1 - t0 - wait, t2 - t1, t3 - t2
    rec.time_identify[k], rec.time_step[k], rec.time_design_wait[k] = t4 - t3, t4 - t0 - wait, wait
    rec.statuses.append(str(step.status))
    rec.failures.append(str(step.failure))


def _new_record(scn: Scenario, method: str, seed: int) -> RunRecord:
    """A record for the whole mission with its time base, reference and initial state filled in."""
    T, dt = scn.n_steps, scn.config.mpc.dt
    rec = RunRecord.allocate(method, seed, T, scn.config.mpc.horizon)
    rec.t[:] = np.arange(T + 1, dtype=np.float64) * dt
    rec.zbar[:], rec.ubar[:] = scn.reference.x, scn.reference.u
    rec.x[0] = scn.x0
    rec.g[0] = [scn.truth.glide_slope(scn.x0)[0], scn.truth.line_of_sight(scn.x0)[0]]
    return rec


def _new_policy(scn: Scenario, method: str, tube_threads: int, design_worker: str | None) -> TubeUpdatePolicy:
    t = scn.config.tube
    return TubeUpdatePolicy(
        tube_designers(scn.config),
        adaptive=method == "ffa",
        margin=t.redesign_margin,
        alpha_search_period=t.alpha_search_period,
        threads=tube_threads,
        update=t.update,
        design_delay=t.design_delay,
        adopt_when_ready=t.design_adoption == "when_ready",
        worker=design_worker or t.design_worker,
    )


def _new_plant(scn: Scenario, seed: int) -> _Plant:
    dist = scn.config.disturbance
    return _Plant(
        scn,
        plant_disturbance(scn, seed),
        ActuatorMismatch(seed + 1, dist.scale_error_p, dist.misalignment_p, dist.scale_error_r, dist.misalignment_r),
        propagator_options(scn.config),
        scn.model.state_to_truth(scn.x0),
    )


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
) -> RunRecord:
    """One closed-loop run of ``method`` ("tbmpc" or "ffa") with disturbance seed ``seed``.

    ``lambda_p``/``lambda_r`` override the configuration's forgetting factors; ``max_steps`` stops
    the run early (arrays are then cut to the steps run); ``tube_threads`` = 2 designs the two
    subsystems' tubes in parallel threads, 1 one after the other (for campaigns whose worker
    processes already occupy every core); ``design_worker`` overrides ``tube.design_worker`` (the
    numbers do not depend on it when adoption is deterministic).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    T, dt = scn.n_steps, scn.config.mpc.dt
    ref = scn.reference
    ctrl = _core.mpc.TubeMPC(_core.mpc.LinearizedProximityModel(scn.model.core), mpc_settings(scn))
    ctrl.setup(_core.mpc.Reference(ref.x.T.copy(), ref.u.T.copy(), 0.0))
    idents = identifiers(scn.config, lambda_p, lambda_r)
    plant = _new_plant(scn, seed)
    rec = _new_record(scn, method, seed)
    x = scn.x0.copy()
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=T, desc=method, unit="step", leave=False)
    wall0 = time.perf_counter()
    n_run = T if max_steps is None else max(1, min(int(max_steps), T))
    with _new_policy(scn, method, tube_threads, design_worker) as policy:
        # The first tube design is part of the set-up (before step 0's clock): every later tube update
        # is the per-step cost.
        first_tubes, first_status = _tube_update(scn, policy, 0, idents)
        rec.tube_statuses.append(str(first_status))
        for k in range(n_run):
            t0 = time.perf_counter()
            tubes, tube_status = (first_tubes, None) if k == 0 else _tube_update(scn, policy, k, idents)
            if tube_status is not None:
                rec.tube_statuses.append(tube_status)
            K, Pe = block_tube(tubes[0], tubes[1])
            t1 = time.perf_counter()
            step = ctrl.step(k, x, _core.mpc.Tube(K, Pe))
            u = np.asarray(step.u, dtype=float).copy()
            t2 = time.perf_counter()
            x_next, w_true = plant.step(k, u)
            t3 = time.perf_counter()
            w_meas = _measured_input(scn, k, x, u, x_next)
            idents[0].update(w_meas[P_STATES])
            idents[1].update(w_meas[R_STATES])
            t4 = time.perf_counter()
            # Tube check (paper Proposition 1): the error after the step, x_{k+1} - z*_{1|k}, in the tube of step k.
            z1 = np.asarray(step.z)[:, 1]
            rec.excursion[k] = [
                tube_excursion(x_next[None, sx], z1[None, sx], np.asarray(tube.Pe))[0]
                for sx, tube in zip((P_STATES, R_STATES), tubes, strict=True)
            ]
            wait = policy.last_wait_s if k > 0 else 0.0
            _record_step(rec, k, step, tubes, K, w_meas, w_true, idents, (t0, t1, t2, t3, t4), wait)
            x = x_next
            rec.x[k + 1] = x
            rec.g[k + 1] = [scn.truth.glide_slope(x, (k + 1) * dt)[0], scn.truth.line_of_sight(x)[0]]
            if bar is not None:
                bar.update()
    if bar is not None:
        bar.close()
    rec.design_failures = list(policy.design_failures)
    rec.wall_time_s = time.perf_counter() - wall0
    if n_run < T:
        rec.truncate(n_run)
    rec.applied = _applied(scn, plant, rec, max_steps)
    return rec


def _applied(scn: Scenario, plant: _Plant, rec: RunRecord, max_steps: int | None) -> dict[str, Any]:
    """The dispersions the run actually applied, with the realised disturbance's statistics (SI units,
    per state component: mean, standard deviation and largest |w|) for checking that they were."""
    sim = scn.config.simulation
    w = rec.w_true
    return {
        "seed": rec.seed,
        "max_steps": max_steps,
        "disturbance": plant.disturbance.describe(),
        "actuators": plant.actuators.describe(),
        "truth": {
            "density_scale": sim.density_scale,
            "srp_scale": sim.srp_scale,
            "truth_shape_subdivisions": sim.truth_shape_subdivisions,
        },
        "realised_disturbance": {
            "mean": w.mean(axis=0).tolist(),
            "std": w.std(axis=0).tolist(),
            "max_abs": np.abs(w).max(axis=0).tolist(),
        },
    }
