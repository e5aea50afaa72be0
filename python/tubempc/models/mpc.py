"""Tube MPC (C++ core) and Python solvers of its exported QP.

The controller (:class:`TubeMPC`: its QPs by a warm-started active set, PIQP where that does not
verify; see ``cpp/include/tubempc/mpc/tube_mpc.hpp`` and docs/model.md "Tube MPC") runs in
C++. :func:`solve_qp` solves the QP returned by
``TubeMPC.qp_data()`` with an independent backend through cvxpy: Clarabel or PIQP (OSQP was removed:
docs/decisions.md, "Dependencies"). It serves cross-checks and the ``tubempc bench mpc`` baseline;
it is not used inside ``step``.

QP form (PIQP's): ``min 1/2 w'Pw + q'w  s.t.  A w = b,  h_l <= G w <= h_u,  x_l <= w <= x_u``;
the nominal cost is the QP objective plus ``qp.constant``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._core.mpc import (
    InitialCondition,
    InputCost,
    KktSolver,
    Linearization,
    LinearizedModel,
    LinearizedProximityModel,
    LtiModel,
    QpData,
    QpSolution,
    QpSolver,
    Reference,
    ScpMode,
    Settings,
    Status,
    StepResult,
    Timings,
    Tube,
    TubeMPC,
    solve_dare,
)

__all__ = [
    "InitialCondition",
    "InputCost",
    "KktSolver",
    "Linearization",
    "LinearizedModel",
    "LinearizedProximityModel",
    "LtiModel",
    "QpData",
    "QpResult",
    "QpSolution",
    "QpSolver",
    "Reference",
    "ScpMode",
    "Settings",
    "Status",
    "StepResult",
    "Timings",
    "Tube",
    "TubeMPC",
    "solve_dare",
    "solve_qp",
    "solve_qp_per_node",
]

SOLVERS = ("cvxpy-clarabel", "cvxpy-piqp")


@dataclass
class QpResult:
    """Solution of an exported QP by a Python backend."""

    w: npt.NDArray[np.float64]
    objective: float  # 1/2 w'Pw + q'w + constant (the nominal cost)
    status: str
    solve_time: float  # the solver's own time (s); nan when the backend does not report it
    wall_time: float  # including problem construction (s)


def _cvxpy(qp: QpData, solver: str, eps: float) -> QpResult:
    import cvxpy as cp

    t0 = time.perf_counter()
    n = qp.P.shape[0]
    w = cp.Variable(n)
    cons = [qp.A @ w == qp.b]
    up, lo = np.isfinite(qp.h_u), np.isfinite(qp.h_l)
    if up.any():
        cons.append(qp.G[np.flatnonzero(up)] @ w <= qp.h_u[up])
    if lo.any():
        cons.append(qp.G[np.flatnonzero(lo)] @ w >= qp.h_l[lo])
    fixed = qp.x_l == qp.x_u  # equal bounds as equalities (interior-point solvers need an interior)
    if fixed.any():
        cons.append(w[np.flatnonzero(fixed)] == qp.x_l[fixed])
    bu, bl = np.isfinite(qp.x_u) & ~fixed, np.isfinite(qp.x_l) & ~fixed
    if bu.any():
        cons.append(w[np.flatnonzero(bu)] <= qp.x_u[bu])
    if bl.any():
        cons.append(w[np.flatnonzero(bl)] >= qp.x_l[bl])
    objective = 0.5 * cp.quad_form(w, qp.P, assume_PSD=True) + qp.q @ w
    prob = cp.Problem(cp.Minimize(objective), cons)
    name = solver.upper()
    prob.solve(solver=name, **_cvxpy_opts(name, eps))
    wall = time.perf_counter() - t0
    x = np.asarray(w.value, dtype=float) if w.value is not None else np.full(n, np.nan)
    obj = float(0.5 * x @ (qp.P @ x) + qp.q @ x + qp.constant)
    stats = prob.solver_stats
    solve_time = float(stats.solve_time) if stats is not None and stats.solve_time else float("nan")
    return QpResult(x, obj, str(prob.status), solve_time, wall)


def _cvxpy_opts(solver: str, eps: float) -> dict[str, float]:
    if solver == "CLARABEL":
        return {"tol_gap_abs": eps, "tol_gap_rel": eps, "tol_feas": eps}
    if solver == "PIQP":
        return {"eps_abs": eps, "eps_rel": eps}
    return {}


def solve_qp_per_node(
    qp: QpData, nx: int, nu: int, nc: int, horizon: int, solver: str = "cvxpy-clarabel", eps: float = 1e-9
) -> QpResult:
    """The same QP written node by node, as a Python user writes an MPC problem in cvxpy.

    One ``cp.Variable`` per nominal state and input, the initial-condition variable ``s``, a Python
    loop adding ``z[i+1] == A_i z[i] + B_i v[i] + c_i``, the state-constraint rows, the boxes and the
    stage costs. The node data (A_i, B_i, c_i, G_i, h_i, weights, bounds) are read from the blocks of
    the exported QP, so the problem and its optimum are the exported QP's; cvxpy parses and
    canonicalises it from scratch, as it would each control step without parameters. The layout is
    the one of ``tube_mpc.hpp`` (w = [dz_0, v_0, ..., dz_N, s, t], t only with a soft terminal
    constraint); a QP with soft state constraints (slacks sigma) raises ValueError.
    """
    import cvxpy as cp

    if solver not in SOLVERS:
        raise ValueError(f"solve_qp_per_node: unknown solver {solver!r}; choose one of {SOLVERS}")
    name = solver.removeprefix("cvxpy-").upper()
    n_w = qp.P.shape[0]
    n_t = nx if qp.G.shape[0] == (horizon + 1) * nc + 2 * nx else 0
    n_s = n_w - (horizon + 1) * nx - horizon * nu - n_t
    if n_s not in (0, nx) or qp.A.shape[0] != (horizon + 1) * nx or qp.G.shape[0] != (horizon + 1) * nc + 2 * n_t:
        raise ValueError("solve_qp_per_node: the QP has state-constraint slacks or an unexpected layout")
    t0 = time.perf_counter()
    P, A, G = qp.P.tocsr(), qp.A.tocsr(), qp.G.tocsr()

    def iz(i: int) -> slice:
        return slice(i * (nx + nu), i * (nx + nu) + nx)

    def iv(i: int) -> slice:
        return slice(i * (nx + nu) + nx, (i + 1) * (nx + nu))

    s_idx = slice(n_w - n_t - n_s, n_w - n_t)
    t_idx = slice(n_w - n_t, n_w)
    z = [cp.Variable(nx, name=f"z{i}") for i in range(horizon + 1)]
    v = [cp.Variable(nu, name=f"v{i}") for i in range(horizon)]
    s = cp.Variable(n_s, name="s") if n_s else None
    t = cp.Variable(n_t, name="t") if n_t else None
    blocks: list[tuple[cp.Variable, slice]] = [(z[i], iz(i)) for i in range(horizon + 1)]
    blocks += [(v[i], iv(i)) for i in range(horizon)]
    if s is not None:
        blocks.append((s, s_idx))
    if t is not None:
        blocks.append((t, t_idx))
    cost = 0
    cons = []
    for var, sl in blocks:  # block-diagonal cost and per-variable boxes
        Pi = P[sl, sl].toarray()
        if np.any(Pi):
            cost = cost + 0.5 * cp.quad_form(var, 0.5 * (Pi + Pi.T), assume_PSD=True)
        cost = cost + qp.q[sl] @ var
        lo, hi = qp.x_l[sl], qp.x_u[sl]
        fixed = lo == hi
        if fixed.all():
            cons.append(var == lo)
            continue
        if np.isfinite(hi).any():
            cons.append(var[np.flatnonzero(np.isfinite(hi))] <= hi[np.isfinite(hi)])
        if np.isfinite(lo).any():
            cons.append(var[np.flatnonzero(np.isfinite(lo))] >= lo[np.isfinite(lo)])
    # initial condition: dz_0 - L s = x_k - zbar_k (or dz_0 = ... without s)
    init = A[:nx, iz(0)].toarray() @ z[0]
    if s is not None:
        init = init + A[:nx, s_idx].toarray() @ s
    cons.append(init == qp.b[:nx])
    for i in range(horizon):  # dynamics: dz_{i+1} = A_i dz_i + B_i v_i + c_i
        rows = slice((i + 1) * nx, (i + 2) * nx)
        Ai, Bi = -A[rows, iz(i)].toarray(), -A[rows, iv(i)].toarray()
        cons.append(z[i + 1] == Ai @ z[i] + Bi @ v[i] + qp.b[rows])
    if t is not None:  # soft terminal constraint |dz_N - (x_f - zbar_T)| <= t, two rows per state
        term = np.arange((horizon + 1) * nc, G.shape[0])
        up, lo = term[np.isfinite(qp.h_u[term])], term[np.isfinite(qp.h_l[term])]
        if up.size:
            cons.append(G[up][:, iz(horizon)].toarray() @ z[horizon] + G[up][:, t_idx].toarray() @ t <= qp.h_u[up])
        if lo.size:
            cons.append(G[lo][:, iz(horizon)].toarray() @ z[horizon] + G[lo][:, t_idx].toarray() @ t >= qp.h_l[lo])
    for i in range(horizon + 1):  # linearised, tightened state constraints
        rows = slice(i * nc, (i + 1) * nc)
        Gi, hu, hl = G[rows, iz(i)].toarray(), qp.h_u[rows], qp.h_l[rows]
        if np.any(Gi) and np.isfinite(hu).any():
            cons.append(Gi[np.isfinite(hu)] @ z[i] <= hu[np.isfinite(hu)])
        if np.any(Gi) and np.isfinite(hl).any():
            cons.append(Gi[np.isfinite(hl)] @ z[i] >= hl[np.isfinite(hl)])
    prob = cp.Problem(cp.Minimize(cost), cons)
    prob.solve(solver=name, **_cvxpy_opts(name, eps))
    wall = time.perf_counter() - t0
    w = np.full(n_w, np.nan)
    if all(var.value is not None for var, _ in blocks):
        for var, sl in blocks:
            w[sl] = var.value
    obj = float(0.5 * w @ (qp.P @ w) + qp.q @ w + qp.constant)
    stats = prob.solver_stats
    solve_time = float(stats.solve_time) if stats is not None and stats.solve_time else float("nan")
    return QpResult(w, obj, str(prob.status), solve_time, wall)


def solve_qp(qp: QpData, solver: str = "cvxpy-clarabel", eps: float = 1e-9) -> QpResult:
    """Solves an exported QP with ``solver`` in :data:`SOLVERS` to tolerance ``eps``."""
    if solver in SOLVERS:
        return _cvxpy(qp, solver.removeprefix("cvxpy-"), eps)
    raise ValueError(f"solve_qp: unknown solver {solver!r}; choose one of {SOLVERS}")
