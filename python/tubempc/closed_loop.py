"""Closed-loop TBMPC and TBMPC-FFA on the 6-DOF model (paper Algorithm 1; PAPER_NOTES.md).

Each control step k (dt = 2 s, T = t_f / dt steps):

1. tube update (both subsystems, in two threads): TBMPC keeps the tube designed at k = 0 from the
   prior covariances (paper Table 1); TBMPC-FFA re-designs it from the identified covariance,
   P_W = pw_scale * S^_k (paper Eq. 25, warm-started alpha), for (1 + tube.redesign_margin) P_W,
   and between alpha searches keeps the previous tube while `tube_still_valid` certifies it;
2. the C++ tube MPC step (Problems 2 and 3, SCP about the shifted plan, PIQP) from the measured
   state x_k, with the ancillary law u = v0* + K (x_k - z0*) saturated at the true limits;
3. truth propagation of the 13-state (quaternion attitude) with the truth model (which may differ
   from the controller's: density, SRP, shape resolution), the actuator mismatch, and the additive
   disturbance of paper Eq. (16) and (18) (uniform in an ellipsoid) applied to the state increment;
4. identification (paper Eq. 26-29) of the measured exogenous input per subsystem.

The controller's state x = [r_L, v_L, phi, omega_BL_B] takes phi = log(q_B/L) on the branch nearest
to the reference (so that phi follows the reference through |phi| = pi).
"""

from __future__ import annotations

import concurrent.futures as cf
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from . import _core
from .config import Config
from .disturbances import ActuatorMismatch, AdditiveDisturbance
from .dynamics import ProximityModel
from .identification import ForgettingFactorIdentifier, measured_reference_deviation
from .reference import ReferenceSettings, ReferenceTrajectory, load_or_generate_reference
from .shapes import Shape, bennu_like_shape, load_shape
from .tube import TubeDesigner, TubeResult, tube_still_valid

__all__ = ["METHODS", "Scenario", "SimulationResult", "build_scenario", "simulate"]

Array = npt.NDArray[np.float64]
METHODS = ("tbmpc", "ffa")
_P, _R = slice(0, 6), slice(6, 12)


@dataclass
class Scenario:
    """Everything a closed-loop run needs that does not depend on the method or the seed."""

    config: Config
    shape: Shape
    shape_source: str
    model: ProximityModel
    truth: ProximityModel
    x0: Array
    xf: Array
    reference: ReferenceTrajectory

    @property
    def n_steps(self) -> int:
        return int(self.reference.u.shape[0])


def _model_params(cfg: Config, density_scale: float = 1.0, srp_scale: float = 1.0) -> dict[str, Any]:
    e, a, s, c = cfg.environment, cfg.asteroid, cfg.spacecraft, cfg.constraints
    return {
        "mu_sun": e.mu_sun,
        "orbit_radius": e.R,
        "beta_srp": e.beta_srp * srp_scale,
        "inertia_B": np.asarray(s.J).tolist(),
        "spin_rate": a.spin_sign * 2.0 * np.pi / a.spin_period,
        "kinematics": "paper" if cfg.mpc.kinematics == "first_order" else "exact",
        "glide_slope_angle": c.glide_slope_angle,
        "los_angle": c.los_angle,
        "boresight_B": np.asarray(s.boresight_B, dtype=float).tolist(),
    }


def _shape_of(cfg: Config, subdivisions: int | None = None) -> tuple[Shape, str]:
    src = cfg.asteroid.shape
    if src == "generated" or subdivisions:
        n = subdivisions or 12
        return bennu_like_shape(n_subdivisions=n), f"generated bennu_like_shape(n_subdivisions={n})"
    path = Path(src)
    if not path.is_absolute() and cfg.source not in ("<memory>", ""):
        path = Path(cfg.source).parent / path
    return load_shape(path, unit="km"), str(path)


def _boundary(cfg: Config, shape: Shape) -> tuple[Array, Array]:
    b = cfg.boundary
    x0 = np.concatenate([b.r0, b.v0, b.phi0, b.w0])
    rf = np.asarray(b.rf, dtype=float)
    if b.terminal == "altitude":  # rf moved along its direction to the given altitude above the surface
        d = rf / np.linalg.norm(rf)
        surface = float(np.max(np.asarray(shape.vertices) @ d))
        rf = d * (surface + b.terminal_altitude)
    return x0, np.concatenate([rf, b.vf, b.phi_f, b.wf])


def build_scenario(cfg: Config, shape_path: str | Path | None = None, cache_dir: str | Path | None = None) -> Scenario:
    """The controller's and the truth's models and the reference trajectory for a configuration."""
    if shape_path is not None:
        cfg = cfg.with_overrides({"asteroid.shape": str(shape_path)})
    shape, shape_src = _shape_of(cfg)
    gravity = _core.gravity.PolyhedronGravity(shape.vertices, shape.faces, cfg.asteroid.density)
    model = ProximityModel(gravity, _model_params(cfg))
    sim = cfg.simulation
    truth_shape = shape if sim.truth_shape_subdivisions == 0 else _shape_of(cfg, sim.truth_shape_subdivisions)[0]
    truth_gravity = _core.gravity.PolyhedronGravity(truth_shape.vertices, truth_shape.faces,
                                                    cfg.asteroid.density * sim.density_scale)
    truth = ProximityModel(truth_gravity, _model_params(cfg, sim.density_scale, sim.srp_scale))
    x0, xf = _boundary(cfg, shape)
    frac = sim.reference_input_fraction
    key = {"model": _model_params(cfg), "shape": shape_src, "n_faces": len(shape.faces),
           "volume": float(shape.volume), "density": cfg.asteroid.density}
    ref = load_or_generate_reference(
        model, x0, xf, cache_dir=cache_dir, key_extra=key, dt=cfg.mpc.dt, n_steps=cfg.mpc.n_steps,
        u_max=frac * cfg.spacecraft.u_max, T_max=frac * cfg.spacecraft.T_max,
        glide_slope_angle=cfg.constraints.glide_slope_angle, settings=ReferenceSettings())
    return Scenario(cfg, shape, shape_src, model, truth, x0, xf, ref)


@dataclass
class SimulationResult:
    """Arrays of one closed-loop run (SI units; shapes in the comments) and its scalar facts."""

    method: str
    seed: int
    arrays: dict[str, Array] = field(default_factory=dict)
    statuses: list[str] = field(default_factory=list)
    failures: list[str] = field(default_factory=list)  # cause of each fallback ("solved": none)
    tube_statuses: list[str] = field(default_factory=list)
    wall_time_s: float = 0.0

    def __getitem__(self, name: str) -> Array:
        return self.arrays[name]


def _tube_designers(cfg: Config) -> tuple[TubeDesigner, TubeDesigner]:
    m, s, t = cfg.mpc, cfg.spacecraft, cfg.tube
    if t.weighting == "mpc":
        Qp, Rp, Qr, Rr = np.diag(m.Q_p), np.diag(m.R_p), np.diag(m.Q_r), np.diag(m.R_r)
    else:
        ident = cfg.identification
        Qp = np.diag(1.0 / np.diag(ident.S0_p))
        Qr = np.diag(1.0 / np.diag(ident.S0_r))
        Rp = t.input_weight * np.eye(3) / s.u_max**2
        Rr = t.input_weight * np.eye(3) / s.T_max**2
    return (TubeDesigner(Q=Qp, R=Rp, u_max=s.u_max, max_solves=t.max_solves),
            TubeDesigner(Q=Qr, R=Rr, u_max=s.T_max, max_solves=t.max_solves))


def _block_tube(tp: TubeResult, tr: TubeResult) -> tuple[Array, Array]:
    K = np.zeros((6, 12))
    Pe = np.zeros((12, 12))
    K[0:3, _P], K[3:6, _R] = tp.K, tr.K
    Pe[_P, _P], Pe[_R, _R] = tp.Pe, tr.Pe
    return K, Pe


def _structure(scn: Scenario) -> tuple[Array, Array, Array]:
    """Nonzero patterns of the model's A, B and G over the reference (block-diagonal subsystems)."""
    ref, dt = scn.reference, scn.config.mpc.dt
    Ad, Bd, _ = scn.model.discretize(0.0, ref.x[:-1], ref.u, dt)
    G = np.array([scn.model.constraints(k * dt, ref.x[k])[0] for k in range(0, len(ref.x), 10)])
    return ((np.abs(Ad) > 0).any(axis=0).astype(float), (np.abs(Bd) > 0).any(axis=0).astype(float),
            (np.abs(G) > 0).any(axis=0).astype(float))


def _mpc_settings(cfg: Config, scn: Scenario) -> Any:
    st = _core.mpc.Settings()
    st.A_structure, st.B_structure, st.G_structure = _structure(scn)
    st.horizon = cfg.mpc.N
    st.dt = cfg.mpc.dt
    st.Q = np.diag(np.concatenate([cfg.mpc.Q_p, cfg.mpc.Q_r]))
    st.R = np.diag(np.concatenate([cfg.mpc.R_p, cfg.mpc.R_r]))
    st.u_max = np.r_[[cfg.spacecraft.u_max] * 3, [cfg.spacecraft.T_max] * 3]
    st.scp_eps = cfg.mpc.eps
    st.input_cost = _core.mpc.InputCost.Paper if cfg.mpc.input_cost == "paper" else _core.mpc.InputCost.FromReference
    st.reuse_linearization = cfg.mpc.linearization == "reuse"
    st.backend = _core.mpc.Backend.ActiveSetPiqp if cfg.mpc.qp_solver == "active_set" else _core.mpc.Backend.PiqpSparse
    return st


def simulate(scn: Scenario, method: str, seed: int, *, progress: bool = False,
             lambda_p: float | None = None, lambda_r: float | None = None,
             max_steps: int | None = None, tube_threads: int = 2) -> SimulationResult:
    """One closed-loop run of ``method`` ("tbmpc" or "ffa") with disturbance seed ``seed``.

    ``lambda_p``/``lambda_r`` override the configuration's forgetting factors; ``max_steps`` stops
    the run early (arrays are then cut to the steps run); ``tube_threads`` = 2 designs the two
    subsystems' tubes in parallel threads, 1 one after the other (for campaigns whose worker
    processes already occupy every core).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    cfg = scn.config
    ident_cfg, dist_cfg = cfg.identification, cfg.disturbance
    T, dt, N = scn.n_steps, cfg.mpc.dt, cfg.mpc.N
    ref = scn.reference
    zbar, ubar = ref.x, ref.u

    plant = _core.mpc.LinearizedProximityModel(scn.model.core)
    ctrl = _core.mpc.TubeMPC(plant, _mpc_settings(cfg, scn))
    ctrl.setup(_core.mpc.Reference(zbar.T.copy(), ubar.T.copy(), 0.0))
    des_p, des_r = _tube_designers(cfg)
    idents = (
        ForgettingFactorIdentifier(lambda_p or ident_cfg.lambda_p, ident_cfg.w0_p, ident_cfg.S0_p,
                                   prior_weight=ident_cfg.prior_weight, eig_floor=ident_cfg.eig_floor,
                                   pw_scale=ident_cfg.pw_scale),
        ForgettingFactorIdentifier(lambda_r or ident_cfg.lambda_r, ident_cfg.w0_r, ident_cfg.S0_r,
                                   prior_weight=ident_cfg.prior_weight, eig_floor=ident_cfg.eig_floor,
                                   pw_scale=ident_cfg.pw_scale),
    )
    disturbance = AdditiveDisturbance(dist_cfg.S_p, dist_cfg.S_r, seed=seed)
    actuators = ActuatorMismatch(seed + 1, dist_cfg.scale_error_p, dist_cfg.misalignment_p,
                                 dist_cfg.scale_error_r, dist_cfg.misalignment_r)
    sim = cfg.simulation
    prop_kw: dict[str, Any] = ({"method": "rk4", "substeps": sim.substeps} if sim.integrator == "rk4"
                               else {"method": "dopri", "rtol": sim.rtol})

    rec: dict[str, Array] = {
        "t": np.arange(T + 1, dtype=np.float64) * dt, "x": np.zeros((T + 1, 12)), "zbar": zbar, "ubar": ubar,
        "z": np.zeros((T, 12)), "z_plan": np.zeros((T, N + 1, 12)), "u": np.zeros((T, 6)), "v": np.zeros((T, 6)),
        "K": np.zeros((T, 6, 12)), "Pe_p": np.zeros((T, 6, 6)), "Pe_r": np.zeros((T, 6, 6)),
        "alpha": np.zeros((T, 2)), "w": np.zeros((T, 12)), "w_true": np.zeros((T, 12)),
        "w_hat": np.zeros((T, 12)), "S_p": np.zeros((T, 6, 6)), "S_r": np.zeros((T, 6, 6)),
        "g": np.zeros((T + 1, 2)), "excursion": np.zeros((T, 2)), "scp_iterations": np.zeros(T),
        "qp_iterations": np.zeros(T), "active_set_solves": np.zeros(T), "model_evaluations": np.zeros(T),
        "time_tube": np.zeros(T),
        "time_linearize": np.zeros(T),
        "time_build": np.zeros(T), "time_solve": np.zeros(T), "time_mpc": np.zeros(T),
        "time_propagate": np.zeros(T), "time_identify": np.zeros(T), "time_step": np.zeros(T),
    }
    result = SimulationResult(method=method, seed=seed, arrays=rec)

    state = scn.model.state_to_truth(scn.x0)
    x = scn.x0.copy()
    rec["x"][0] = x
    rec["g"][0] = [scn.truth.glide_slope(x)[0], scn.truth.line_of_sight(x)[0]]
    tubes: tuple[TubeResult, TubeResult] | None = None
    margin = cfg.tube.redesign_margin if method == "ffa" else 0.0
    designed_for: list[Array] = [ident.P_W for ident in idents]  # the P_W each tube was designed for
    pool = cf.ThreadPoolExecutor(max_workers=max(1, min(2, int(tube_threads))))
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=T, desc=method, unit="step", leave=False)
    wall0 = time.perf_counter()
    try:
        n_run = T if max_steps is None else max(1, min(int(max_steps), T))
        for k in range(n_run):
            t_k = k * dt
            t0 = time.perf_counter()
            # 1. tube update (TBMPC: once from the prior; FFA: from the identified P_W, every step
            #    unless the current tube is still certified for it; README, readings)
            if tubes is None or method == "ffa":
                Ad, Bd, _ = scn.model.discretize(t_k, zbar[k], ubar[k], dt)
                search = k % cfg.tube.alpha_search_period == 0
                jobs: list[tuple[cf.Future[TubeResult], Array] | None] = []
                for i, (des, ident, sl, su) in enumerate(((des_p, idents[0], _P, slice(0, 3)),
                                                          (des_r, idents[1], _R, slice(3, 6)))):
                    prev = None if tubes is None else tubes[i]
                    A_s, B_s, P_W = Ad[sl, sl], Bd[sl, su], ident.P_W
                    if (prev is not None and not search and margin > 0.0
                            and tube_still_valid(prev, A_s, B_s, P_W, designed_for[i], margin)):
                        jobs.append(None)
                        continue
                    P_design = (1.0 + margin) * P_W
                    alpha_prev = prev.alpha if prev is not None and prev.feasible else None
                    if alpha_prev is not None and not search:
                        future = pool.submit(des.design_fixed_alpha, A_s, B_s, P_design, alpha_prev)
                    else:
                        future = pool.submit(des.design, A_s, B_s, P_design, alpha_prev)
                    jobs.append((future, P_design))
                kept: list[TubeResult] = []
                names = []
                for i, (job, des) in enumerate(zip(jobs, (des_p, des_r), strict=True)):
                    if job is None:
                        assert tubes is not None
                        kept.append(tubes[i])
                        names.append("KEPT")
                        continue
                    res = job[0].result()
                    names.append(res.status.name)
                    if res.feasible:
                        kept.append(res)
                        designed_for[i] = job[1]
                    elif des.last_feasible is not None:
                        kept.append(des.last_feasible)
                    elif tubes is not None:
                        kept.append(tubes[i])
                    else:
                        raise RuntimeError(f"initial tube design infeasible ({res.status.name}); "
                                           "check identification priors and input limits")
                tubes = (kept[0], kept[1])
                result.tube_statuses.append("/".join(names))
            assert tubes is not None
            K, Pe = _block_tube(*tubes)
            t1 = time.perf_counter()
            # 2. MPC step
            step = ctrl.step(k, x, _core.mpc.Tube(K, Pe))
            u = np.asarray(step.u, dtype=float).copy()
            z0 = np.asarray(step.z)[:, 0].copy()
            t2 = time.perf_counter()
            # 3. truth propagation with actuator mismatch and the additive disturbance
            u_applied = np.concatenate([actuators.apply_acceleration(u[:3]), actuators.apply_torque(u[3:])])
            prop = scn.truth.propagate(t_k, state, u_applied, dt, **prop_kw)
            if prop.status.name != "Success":
                raise RuntimeError(f"truth propagation failed at step {k}: {prop.status.name}")
            w_p, w_r = disturbance.sample()
            x_next = scn.truth.truth_to_state(np.asarray(prop.state), zbar[k + 1, 6:9])
            x_next[_P] += w_p
            x_next[_R] += w_r
            state = scn.truth.state_to_truth(x_next)
            t3 = time.perf_counter()
            # 4. identification of the exogenous input
            if ident_cfg.measured_input == "residual":
                Ak, Bk, ck = scn.model.discretize(t_k, x, u, dt)
                w_meas = x_next - (Ak @ x + Bk @ u + ck)
            else:
                w_meas = measured_reference_deviation(x_next, zbar[k + 1])
            idents[0].update(w_meas[_P])
            idents[1].update(w_meas[_R])
            t4 = time.perf_counter()

            # Tube check (paper Proposition 1): the error after the step, x_{k+1} - z*_{1|k}, in the tube of step k.
            e = x_next - np.asarray(step.z)[:, 1]
            Pe_p, Pe_r = np.asarray(tubes[0].Pe, dtype=float), np.asarray(tubes[1].Pe, dtype=float)
            rec["excursion"][k] = [float(e[_P] @ np.linalg.solve(Pe_p, e[_P])), float(e[_R] @ np.linalg.solve(Pe_r, e[_R]))]
            rec["z"][k], rec["z_plan"][k] = z0, np.asarray(step.z).T
            rec["u"][k], rec["v"][k] = u, np.asarray(step.v)[:, 0]
            rec["K"][k], rec["Pe_p"][k], rec["Pe_r"][k] = K, tubes[0].Pe, tubes[1].Pe
            rec["alpha"][k] = [tubes[0].alpha, tubes[1].alpha]
            rec["w"][k], rec["w_true"][k] = w_meas, np.concatenate([w_p, w_r])
            rec["w_hat"][k] = np.concatenate([idents[0].w_hat, idents[1].w_hat])
            rec["S_p"][k], rec["S_r"][k] = idents[0].S_hat, idents[1].S_hat
            rec["scp_iterations"][k], rec["qp_iterations"][k] = step.scp_iterations, step.qp_iterations
            rec["model_evaluations"][k] = step.model_evaluations
            rec["active_set_solves"][k] = step.active_set_solves
            tm = step.timings
            rec["time_linearize"][k], rec["time_build"][k], rec["time_solve"][k] = tm.linearize, tm.build, tm.solve
            rec["time_tube"][k], rec["time_mpc"][k] = t1 - t0, t2 - t1
            rec["time_propagate"][k], rec["time_identify"][k], rec["time_step"][k] = t3 - t2, t4 - t3, t4 - t0
            result.statuses.append(str(step.status))
            result.failures.append(str(step.failure))
            x = x_next
            rec["x"][k + 1] = x
            rec["g"][k + 1] = [scn.truth.glide_slope(x)[0], scn.truth.line_of_sight(x)[0]]
            if bar is not None:
                bar.update()
    finally:
        pool.shutdown()
        if bar is not None:
            bar.close()
    result.wall_time_s = time.perf_counter() - wall0
    if n_run < T:
        for name, arr in rec.items():
            if arr.ndim and arr.shape[0] in (T, T + 1):
                rec[name] = arr[: n_run + (arr.shape[0] - T)]
    return result
