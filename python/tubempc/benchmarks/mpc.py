"""Tube MPC step time over a whole mission, and the same QPs through cvxpy (Clarabel, PIQP).

Default plant (``--plant bennu``): the default scenario's 6-DOF model (polyhedral gravity of the
generated Bennu-like shape, exact ZOH), TBMPC's prior tube, truth = RK4 propagation plus the
scenario's disturbance. ``--plant stand-in``: 12 states / 6 inputs with the paper's sizes (N = 30,
dt = 2 s, T = 300, Table 1 weights, limits 0.55 m/s^2 and 3 N m): linear Hill (Clohessy-Wiltshire)
translation plus a linearised rigid body, the glide-slope cone replaced by its four tangent planes,
a cubic Hermite reference. ``run_mission`` takes any ``LinearizedModel``, reference, tube and truth.

Baselines on QPs of solved steps: the exported matrices through cvxpy (``cvxpy-*``), the same QP
written node by node as a Python user would (``node-cvxpy-*``, :func:`tubempc.models.mpc.solve_qp_per_node`).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from ..models import mpc
from ..models.mpc import solve_qp, solve_qp_per_node
from ..results.machine import machine_info

DESCRIPTION = "tube MPC per-step time over a mission (C++: active set / PIQP) and the same QPs through cvxpy"

Arr = npt.NDArray[np.float64]

N_ORBIT = np.sqrt(1.32712440018e20 / 1.685e11**3)  # rad/s, docs/model.md "Translational dynamics"
J_DIAG = np.array([2750.0, 2750.0, 2030.0])  # kg m^2, docs/model.md "Scenario"
X0 = np.array([959.2404, 162.4966, 752.7547, 7.7649e-4, 0.0844, -0.0192, 0.3142, 2.925, 0.3142, 1e-3, 0.0, 3e-3])
XF = np.array([0.0, 0.0, 246.5, 0.0, 0.0, 0.0, 0.0, 3.1416, 0.0, 0.0, 0.0, 0.0])


def test_plant(dt: float) -> tuple[mpc.LtiModel, Arr, Arr]:
    """The 12/6 stand-in plant (C++ LtiModel) and its discrete (A, B)."""
    n = N_ORBIT
    A = np.zeros((12, 12))
    A[0:3, 3:6] = np.eye(3)
    A[3:6, 0:3] = np.diag([3 * n * n, 0.0, -n * n])
    A[3, 4], A[4, 3] = 2 * n, -2 * n
    A[6:9, 9:12] = np.eye(3)
    B = np.zeros((12, 6))
    B[3:6, 0:3] = np.eye(3)
    B[9:12, 3:6] = np.diag(1.0 / J_DIAG)
    gs = np.deg2rad(70.0)
    G = np.zeros((4, 12))
    for i, (axis, sign) in enumerate([(0, 1), (0, -1), (1, 1), (1, -1)]):
        G[i, axis] = sign * np.cos(gs)
        G[i, 2] = -np.sin(gs)
    model = mpc.LtiModel(A, B, np.zeros(12), dt, G, np.zeros(4))
    Ad, Bd, _ = model.discretize(0.0, dt, np.zeros(12), np.zeros(6))
    return model, Ad, Bd


def hermite_reference(x0: Arr, xf: Arr, T: int, dt: float) -> mpc.Reference:
    """Cubic Hermite path per (position, velocity) pair; u_ref from its second derivative."""
    tf = T * dt
    t = np.arange(T + 1) * dt
    z = np.zeros((12, T + 1))
    acc = np.zeros((6, T + 1))
    for j, (ip, iv) in enumerate([(0, 3), (1, 4), (2, 5), (6, 9), (7, 10), (8, 11)]):
        p0, v0, p1, v1 = x0[ip], x0[iv], xf[ip], xf[iv]
        c2 = (3 * (p1 - p0) - (2 * v0 + v1) * tf) / tf**2
        c3 = (2 * (p0 - p1) + (v0 + v1) * tf) / tf**3
        z[ip] = p0 + v0 * t + c2 * t**2 + c3 * t**3
        z[iv] = v0 + 2 * c2 * t + 3 * c3 * t**2
        acc[j] = 2 * c2 + 6 * c3 * t
    u = acc[:, :T].copy()
    u[3:6] *= J_DIAG[:, None]
    return mpc.Reference(z, u, 0.0)


def paper_settings(dt: float, horizon: int) -> mpc.Settings:
    s = mpc.Settings()
    s.horizon = horizon
    s.dt = dt
    s.Q = np.eye(12)
    s.R = np.diag([1e3] * 3 + [1e4] * 3)
    s.u_max = np.array([0.55] * 3 + [3.0] * 3)
    return s


def declare_block_structure(settings: mpc.Settings, G: Arr) -> None:
    """Translational and rotational subsystems decoupled (true of the paper's 6-DOF model too:
    u_p is in L, the attitude dynamics do not depend on the position); G's pattern from G."""
    S = np.zeros((12, 12))
    S[:6, :6] = S[6:, 6:] = 1.0
    Sb = np.zeros((12, 6))
    Sb[:6, :3] = Sb[6:, 3:] = 1.0
    settings.A_structure = S
    settings.B_structure = Sb
    settings.G_structure = (G != 0.0).astype(float)


def lqr_tube(Ad: Arr, Bd: Arr, settings: mpc.Settings) -> mpc.Tube:
    """K from the DARE with the stage weights; Pe = 9 S_0 (docs/model.md "Disturbance identification")."""
    X = mpc.solve_dare(Ad, Bd, settings.Q, settings.R)
    K = -np.linalg.solve(settings.R + Bd.T @ X @ Bd, Bd.T @ X @ Ad)
    Pe = 9.0 * np.diag([4e-2] * 3 + [2.5e-3] * 3 + [1e-6] * 3 + [1e-8] * 3)
    return mpc.Tube(K, Pe)


def run_mission(
    model: mpc.LinearizedModel,
    settings: mpc.Settings,
    reference: mpc.Reference,
    tube: mpc.Tube,
    truth: Callable[[int, Arr, Arr], Arr],
    qp_steps: set[int],
) -> tuple[list[dict[str, Any]], dict[int, tuple[mpc.QpData, float, float, Arr]]]:
    """Closed loop over the whole mission; per-step records and, for each k in qp_steps, the QP of the
    first step >= k whose status is "solved" (with the step's C++ solve time per QP, the objective and
    the C++ minimiser): fallback steps' last QPs are not the plan applied and are not compared."""
    ctrl = mpc.TubeMPC(model, settings)
    ctrl.setup(reference)
    T = ctrl.mission_steps
    x = reference.z[:, 0].copy()
    records: list[dict[str, Any]] = []
    qps: dict[int, tuple[mpc.QpData, float, float, Arr]] = {}
    kkt: dict[int, float] = {}
    pending = sorted(qp_steps)
    for k in range(T):
        t0 = time.perf_counter()
        r = ctrl.step(k, x, tube)
        wall = time.perf_counter() - t0
        tm = r.timings
        records.append(
            {
                "k": k,
                "status": str(r.status),
                "scp": r.scp_iterations,
                "qp_iter": r.qp_iterations,
                "as_solves": r.active_set_solves,
                "as_iter": r.active_set_iterations,
                "as_fail": getattr(r, "active_set_failures", 0),
                "model_evaluations": r.model_evaluations,
                "linearize": tm.linearize,
                "build": tm.build,
                "solve": tm.solve,
                "total": tm.total,
                "python_wall": wall,
                "horizon": r.horizon,
            }
        )
        if pending and k >= pending[0] and r.status == mpc.Status.Solved:
            while pending and pending[0] <= k:
                pending.pop(0)
            sol = ctrl.qp_solution()
            qps[k] = (ctrl.qp_data(), tm.solve / max(1, r.scp_iterations), r.objective, sol.w)
            kkt[k] = kkt_residual(qps[k][0], sol)
        x = truth(k, x, r.u)
    records.append(
        {
            "final_error_inf": float(np.max(np.abs(x - reference.z[:, -1]))),
            "max_kkt_residual": max(kkt.values(), default=0.0),
        }
    )
    return records, qps


def violation(qp: mpc.QpData, w: Arr) -> float:
    """Largest constraint violation of w in the exported QP."""
    Gw = qp.G @ w
    return float(
        max(
            np.max(np.abs(qp.A @ w - qp.b)),
            np.max(Gw - qp.h_u, initial=0.0),
            np.max(qp.h_l - Gw, initial=0.0),
            np.max(w - qp.x_u, initial=0.0),
            np.max(qp.x_l - w, initial=0.0),
        )
    )


def kkt_residual(qp: mpc.QpData, sol: mpc.QpSolution) -> float:
    """Relative stationarity residual of the C++ primal-dual pair (sign convention of QpSolution)."""
    terms = [qp.P @ sol.w, qp.q, qp.A.T @ sol.y, qp.G.T @ (sol.z_u - sol.z_l), sol.z_bu - sol.z_bl]
    scale = max(1.0, *(float(np.max(np.abs(t), initial=0.0)) for t in terms))
    return float(np.max(np.abs(sum(terms)))) / scale


def _stats(values: list[float]) -> dict[str, float]:
    a = np.asarray(values)
    return {"median": float(np.median(a)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--steps", type=int, default=300, help="mission length T (default 300 = 600 s)")
    parser.add_argument("--horizon", type=int, default=30, help="N (default 30)")
    parser.add_argument("--qp-samples", type=int, default=12, help="QPs re-solved through cvxpy (default 12)")
    parser.add_argument(
        "--solvers",
        default="node-cvxpy-clarabel,node-cvxpy-piqp,cvxpy-clarabel,cvxpy-piqp",
        help="Python backends for the baseline (comma separated): node-cvxpy-* the QP written "
        "node by node in cvxpy, cvxpy-* the exported matrices through cvxpy (Clarabel, PIQP)",
    )
    parser.add_argument("--eps", type=float, default=1e-8, help="interior-point baseline tolerance")
    parser.add_argument(
        "--disturbance",
        type=float,
        default=1e-3,
        help="uniform position/velocity disturbance per step (m, m/s; default 1e-3)",
    )
    parser.add_argument(
        "--structure",
        choices=("block", "dense"),
        default="block",
        help="declared model structure: block-diagonal subsystems (default) or dense",
    )
    parser.add_argument(
        "--plant",
        choices=("bennu", "stand-in"),
        default="bennu",
        help="bennu: the default scenario's 6-DOF model (generated shape, TBMPC's prior tube, "
        "truth propagation with the scenario's disturbance); stand-in: a 12/6 LTI plant",
    )
    parser.add_argument(
        "--linearization",
        choices=mpc.Linearization.names(),
        default="reuse",
        help="every_iteration: call the model at every node in every SCP iteration (mpc::Linearization; "
        "default reuse: a step re-uses the previous converged step's model data)",
    )
    parser.add_argument(
        "--qp-solver",
        choices=mpc.QpSolver.names(),
        default="active_set",
        help="QP solver of the step: the warm-started active set with PIQP when it does not verify "
        "(default, mpc::QpSolver::ActiveSet) or PIQP alone",
    )
    parser.add_argument(
        "--repeats",
        type=int,
        default=1,
        help="fly the mission this many times and report the spread of the per-run medians and "
        "p99s (the machine's speed drifts between runs; default 1)",
    )
    parser.add_argument(
        "--position-tolerance",
        type=float,
        help="bennu plant: LinearizedProximityModel's position_tolerance (m; default: the model's)",
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")


def bennu_plant(
    seed: int = 0, *, steps: int | None = None, dense: bool = False, position_tolerance: float | None = None
) -> tuple[Any, Any, Any, Any, Callable[[int, Arr, Arr], Arr]]:
    """The default scenario's controller model, MPC settings, reference (its first ``steps`` steps),
    TBMPC tube and truth (tubempc.scenario; the configured propagator and disturbance with ``seed``):
    the arguments of :func:`run_mission`. ``dense`` drops the block structure of the QP matrices."""
    from ..config import load_config
    from ..design.library import initial_tube
    from ..scenario.build import build_scenario, mpc_settings
    from ..sim.setup import loop_setup

    cfg = load_config()
    scn = build_scenario(cfg)
    settings = mpc_settings(scn)
    if dense:
        empty = np.zeros((0, 0))
        settings.A_structure, settings.B_structure, settings.G_structure = empty, empty, empty
    steps = scn.n_steps if steps is None else min(steps, scn.n_steps)
    ref = scn.reference
    reference = mpc.Reference(ref.x[: steps + 1].T.copy(), ref.u[:steps].T.copy(), 0.0)
    K, Pe = initial_tube(scn)
    loop = loop_setup(scn)
    dist = loop.plant_disturbance(seed)
    propagator = loop.propagator

    def truth(k: int, x: Arr, u: Arr) -> Arr:
        prop = scn.truth.propagate(k * cfg.mpc.dt, scn.truth.state_to_truth(x), u, cfg.mpc.dt, settings=propagator)
        w_p, w_r = dist.sample(k)
        return np.asarray(
            scn.truth.truth_to_state(np.asarray(prop.state), ref.x[k + 1, 6:9]) + np.concatenate([w_p, w_r]),
            dtype=np.float64,
        )

    if position_tolerance is None:
        model = mpc.LinearizedProximityModel(scn.model.core)
    else:
        model = mpc.LinearizedProximityModel(scn.model.core, position_tolerance)
    return model, settings, reference, mpc.Tube(K, Pe), truth


def run(args: argparse.Namespace) -> int:
    if args.qp_samples < 1:
        raise SystemExit("--qp-samples must be >= 1 (the QP sizes and the C++ solution checks use them)")
    if args.repeats < 1:
        raise SystemExit("--repeats must be >= 1")
    dt = 2.0
    info = machine_info()
    print(f"machine: {info['cpu']} ({info['cores']} cores), Python {info['python']}")
    if args.plant == "bennu":
        plant = {"steps": args.steps, "dense": args.structure == "dense", "position_tolerance": args.position_tolerance}
        model, settings, reference, tube, truth = bennu_plant(args.seed, **plant)

        def fresh_truth() -> Callable[[int, Arr, Arr], Arr]:
            return bennu_plant(args.seed, **plant)[4]

        plant_text = (
            "plant: the default scenario's 6-DOF model (generated Bennu-like shape, polyhedral gravity, "
            "exact ZOH), TBMPC's prior tube, truth = RK4 propagation + the scenario's disturbance"
        )
    else:
        model, Ad, Bd = test_plant(dt)
        settings = paper_settings(dt, args.horizon)
        if args.structure == "block":
            declare_block_structure(settings, model.constraints(0.0, np.zeros(12))[0])
        reference = hermite_reference(X0, XF, args.steps, dt)
        tube = lqr_tube(Ad, Bd, settings)
        scale = np.r_[np.full(6, args.disturbance), np.full(6, 1e-2 * args.disturbance)]

        def fresh_truth() -> Callable[[int, Arr, Arr], Arr]:
            rng = np.random.default_rng(args.seed)

            def truth(k: int, x: Arr, u: Arr) -> Arr:
                return np.asarray(Ad @ x + Bd @ u + rng.uniform(-1.0, 1.0, size=12) * scale, dtype=np.float64)

            return truth

        truth = fresh_truth()

        plant_text = "plant: 12-state/6-input stand-in (Hill/CW translation + linearised rigid body, 4 glide-slope planes)"

    samples = set(np.linspace(0, args.steps - 1, args.qp_samples).round().astype(int).tolist())
    settings.linearization = mpc.Linearization.from_string(args.linearization)
    settings.qp_solver = mpc.QpSolver.from_string(args.qp_solver)
    records, qps = run_mission(model, settings, reference, tube, truth, samples)
    final = records.pop()
    # Further flights of the same (deterministic) mission, for the timings' spread between runs.
    repeat_records = []
    for _ in range(args.repeats - 1):
        again, _qps = run_mission(model, settings, reference, tube, fresh_truth(), set())
        again_final = again.pop()
        if again_final["final_error_inf"] != final["final_error_inf"]:
            raise RuntimeError("a repeated mission ended in a different state: the benchmark is not deterministic")
        repeat_records.append(again)
    statuses: dict[str, int] = {}
    for r in records:
        statuses[r["status"]] = statuses.get(r["status"], 0) + 1
    some_qp = next(iter(qps.values()))[0]
    own_viol = max(violation(qp, w) for qp, w in ((q[0], q[3]) for q in qps.values()))
    n_var, n_eq, n_in = some_qp.P.shape[0], some_qp.A.shape[0], some_qp.G.shape[0]
    print(plant_text)
    print(
        f"mission: T = {args.steps}, N = {args.horizon}, dt = {dt} s; QP: {n_var} variables, "
        f"{n_eq} equalities, {n_in} inequalities; structure {args.structure}, "
        f"nnz(P, A, G) = {some_qp.P.nnz}, {some_qp.A.nnz}, {some_qp.G.nnz}"
    )
    evals = [r["model_evaluations"] for r in records]
    scp_mean = float(np.mean([r["scp"] for r in records]))
    print(
        f"statuses: {statuses}; SCP iterations per step: mean {scp_mean:.2f}; "
        f"model evaluations (nodes discretised) per step: median {np.median(evals):.0f}, mean {np.mean(evals):.1f}; "
        f"final |x - x_f|_inf = {final['final_error_inf']:.3g}"
    )
    n_qp = sum(r["scp"] for r in records)
    as_qp = sum(r["as_solves"] for r in records)
    as_steps = [r for r in records if r["scp"] > 0 and r["as_solves"] == r["scp"]]
    piqp_qp = n_qp - as_qp
    print(
        f"QP solver ({settings.qp_solver.name}): {as_qp} of {n_qp} QPs by the active set "
        f"({np.mean([r['as_iter'] / r['scp'] for r in as_steps]) if as_steps else 0.0:.2f} factorisations per QP on "
        f"steps it solved alone), {piqp_qp} by PIQP "
        f"({sum(r['qp_iter'] for r in records) / max(1, piqp_qp):.1f} interior-point iterations per PIQP QP); "
        f"steps with a PIQP QP: {sum(1 for r in records if r['as_solves'] < r['scp'])}"
    )
    out: dict[str, Any] = {
        "machine": info,
        "plant": args.plant,
        "structure": args.structure,
        "T": args.steps,
        "N": args.horizon,
        "qp_size": [n_var, n_eq, n_in],
        "statuses": statuses,
        "final_error_inf": final["final_error_inf"],
        "linearization": settings.linearization.name,
        "model_evaluations_mean": float(np.mean(evals)),
        "scp_iterations_mean": scp_mean,
        "qp_solver": settings.qp_solver.name,
        "active_set_qps": as_qp,
        "qps": n_qp,
        "step": {},
    }
    print(f"{'per step (C++)':24s} {'median':>10s} {'p99':>10s} {'max':>10s}   [ms]")
    for key in ("total", "linearize", "build", "solve", "python_wall"):
        st = _stats([r[key] for r in records])
        out["step"][key] = st
        print(f"  {key:22s} {1e3 * st['median']:10.3f} {1e3 * st['p99']:10.3f} {1e3 * st['max']:10.3f}")
    per_qp = _stats([r["solve"] / max(1, r["scp"]) for r in records])
    out["step"]["solve_per_qp"] = per_qp
    print(f"  {'solve per QP':22s} {1e3 * per_qp['median']:10.3f} {1e3 * per_qp['p99']:10.3f} {1e3 * per_qp['max']:10.3f}")
    # The tail: the slowest 1 % of the steps (at least 3) with where their time went, and the QPs that
    # left the active set (failed tries, PIQP solves).
    slow = sorted(records, key=lambda r: -float(r["total"]))[: max(3, len(records) // 100)]
    tail_keys = ("k", "total", "linearize", "solve", "scp", "as_iter", "as_fail", "qp_iter", "model_evaluations", "horizon")
    out["tail"] = {
        "steps_over_1ms": sum(1 for r in records if r["total"] > 1e-3),
        "active_set_failed_tries": sum(r["as_fail"] for r in records),
        "piqp_steps": [r["k"] for r in records if r["as_solves"] < r["scp"]],
        "slowest": [{key: r[key] for key in tail_keys} for r in slow],
    }
    print(
        f"tail: {out['tail']['steps_over_1ms']} steps over 1 ms; {out['tail']['active_set_failed_tries']} active-set "
        f"tries failed; steps with a PIQP QP: {out['tail']['piqp_steps']}; slowest steps:"
    )
    for r in slow:
        print(
            f"  k {r['k']:4d} (n {r['horizon']:2d}): {1e3 * r['total']:7.3f} ms (linearize {1e3 * r['linearize']:.3f}, "
            f"solve {1e3 * r['solve']:.3f}); {r['scp']} QPs, {r['as_iter']} factorisations, {r['as_fail']} failed "
            f"tries, {r['qp_iter']} PIQP iterations, {r['model_evaluations']} model evaluations"
        )
    if repeat_records:
        runs = []
        for recs in [records, *repeat_records]:
            run_stats = {key: _stats([r[key] for r in recs]) for key in ("total", "linearize", "solve")}
            run_stats["solve_per_qp"] = _stats([r["solve"] / max(1, r["scp"]) for r in recs])
            runs.append(run_stats)
        out["runs"] = runs
        print(
            f"over {len(runs)} flights of the mission (same steps; the spread is the machine's), per-run "
            f"[ms]:     median min-max      p99 min-max"
        )
        for key in ("total", "linearize", "solve_per_qp"):
            med = [1e3 * r[key]["median"] for r in runs]
            p99 = [1e3 * r[key]["p99"] for r in runs]
            print(f"  {key:22s} {min(med):10.3f} - {max(med):6.3f} {min(p99):10.3f} - {max(p99):6.3f}")

    print(
        f"baseline on {len(qps)} of the mission's QPs (the last QP of each sampled step); C++: max "
        f"violation {own_viol:.1e}, max relative KKT stationarity residual {final['max_kkt_residual']:.1e}"
    )
    out["cpp_max_violation"] = own_viol
    out["cpp_max_kkt_residual"] = final["max_kkt_residual"]
    print(
        f"  {'solver':16s} {'solver ms':>10s} {'wall ms':>10s} {'ratio solver':>13s} {'ratio wall':>11s} "
        f"{'|rel obj diff|':>15s} {'max excess':>11s} {'max viol':>9s}"
    )
    out["baseline"] = {}
    for solver in [s for s in args.solvers.split(",") if s]:
        solver_t, wall_t, ratio_s, ratio_w, diffs, viols = [], [], [], [], [], []
        for qp, cpp_solve, objective, _ in qps.values():
            eps = args.eps
            if solver.startswith("node-"):
                horizon = qp.A.shape[0] // 12 - 1  # the step's: T - k in the shrinking phase
                res = solve_qp_per_node(qp, 12, 6, model.n_constraints(), horizon, solver.removeprefix("node-"), eps)
            else:
                res = solve_qp(qp, solver, eps)
            solver_t.append(res.solve_time)
            wall_t.append(res.wall_time)
            ratio_s.append(res.solve_time / cpp_solve)
            ratio_w.append(res.wall_time / cpp_solve)
            diffs.append((objective - res.objective) / max(1.0, abs(res.objective)))
            viols.append(violation(qp, res.w) if np.all(np.isfinite(res.w)) else np.inf)
        entry = {
            "solver_time_median": float(np.median(solver_t)),
            "wall_time_median": float(np.median(wall_t)),
            "ratio_solver_median": float(np.median(ratio_s)),
            "ratio_wall_median": float(np.median(ratio_w)),
            "median_abs_rel_objective_diff": float(np.median(np.abs(diffs))),
            "max_rel_objective_excess": float(np.max(diffs)),
            "max_violation": float(np.max(viols)),
        }
        out["baseline"][solver] = entry
        print(
            f"  {solver:16s} {1e3 * entry['solver_time_median']:10.3f} "
            f"{1e3 * entry['wall_time_median']:10.3f} {entry['ratio_solver_median']:13.1f} "
            f"{entry['ratio_wall_median']:11.1f} {entry['median_abs_rel_objective_diff']:15.1e} "
            f"{entry['max_rel_objective_excess']:11.1e} {entry['max_violation']:9.1e}"
        )
    print(
        "ratio = Python backend time / C++ solve time per QP (the step's QPs), median over the sampled QPs "
        "('solver': the backend's own solve time; 'wall': including cvxpy's problem construction)"
    )
    print(
        "objective: |rel obj diff| = median |ours - theirs| / |theirs|; max excess = max (ours - theirs) / "
        "|theirs| (> 0: the C++ optimum is worse than the baseline's)"
    )
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(out, f, indent=2)
        print(f"wrote {args.json}")
    return 0
