"""Tube MPC (C++ core) and Python solvers of its exported QP.

The controller (:class:`TubeMPC`, PIQP inside, see ``cpp/include/tubempc/mpc/tube_mpc.hpp`` and
PAPER_NOTES.md "Tube MPC") runs in C++. :func:`solve_qp` solves the QP returned by
``TubeMPC.qp_data()`` with a second, independent backend: OSQP (the Python package; OSQP's C
library is not linked into the core) or, through cvxpy, Clarabel, OSQP or PIQP. It serves
cross-checks and the ``tubempc bench mpc`` baseline; it is not used inside ``step``.

QP form (PIQP's): ``min 1/2 w'Pw + q'w  s.t.  A w = b,  h_l <= G w <= h_u,  x_l <= w <= x_u``;
the nominal cost is the QP objective plus ``qp.constant``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ._core.mpc import (
    Backend,
    InitialCondition,
    InputCost,
    KktSolver,
    LinearizedModel,
    LinearizedProximityModel,
    LtiModel,
    QpData,
    QpSolution,
    Reference,
    Settings,
    Status,
    StepResult,
    Timings,
    Tube,
    TubeMPC,
    solve_dare,
)

__all__ = [
    "Backend",
    "InitialCondition",
    "InputCost",
    "KktSolver",
    "LinearizedModel",
    "LinearizedProximityModel",
    "LtiModel",
    "QpData",
    "QpResult",
    "QpSolution",
    "Reference",
    "Settings",
    "Status",
    "StepResult",
    "Timings",
    "Tube",
    "TubeMPC",
    "solve_dare",
    "solve_qp",
]

SOLVERS = ("osqp", "cvxpy-clarabel", "cvxpy-osqp", "cvxpy-piqp")


@dataclass
class QpResult:
    """Solution of an exported QP by a Python backend."""

    w: npt.NDArray[np.float64]
    objective: float  # 1/2 w'Pw + q'w + constant (the nominal cost)
    status: str
    solve_time: float  # the solver's own time (s); nan when the backend does not report it
    wall_time: float  # including problem construction (s)


def _osqp(qp: QpData, eps: float) -> QpResult:
    import osqp

    t0 = time.perf_counter()
    n = qp.P.shape[0]
    C = sp.vstack([qp.A, qp.G, sp.identity(n, format="csc")], format="csc")
    lo = np.concatenate([qp.b, qp.h_l, qp.x_l])
    hi = np.concatenate([qp.b, qp.h_u, qp.x_u])
    solver = osqp.OSQP()
    solver.setup(sp.triu(qp.P, format="csc"), qp.q, C, lo, hi, eps_abs=eps, eps_rel=eps, max_iter=200000,
                 polishing=True, verbose=False)
    res = solver.solve(raise_error=False)
    wall = time.perf_counter() - t0
    w = np.asarray(res.x, dtype=float)
    obj = float(0.5 * w @ (qp.P @ w) + qp.q @ w + qp.constant)
    return QpResult(w, obj, str(res.info.status), float(res.info.run_time), wall)


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
    opts: dict[str, float] = {}
    name = solver.upper()
    if name == "OSQP":
        opts = {"eps_abs": eps, "eps_rel": eps, "max_iter": 200000}
    elif name == "CLARABEL":
        opts = {"tol_gap_abs": eps, "tol_gap_rel": eps, "tol_feas": eps}
    elif name == "PIQP":
        opts = {"eps_abs": eps, "eps_rel": eps}
    prob.solve(solver=name, **opts)
    wall = time.perf_counter() - t0
    x = np.asarray(w.value, dtype=float) if w.value is not None else np.full(n, np.nan)
    obj = float(0.5 * x @ (qp.P @ x) + qp.q @ x + qp.constant)
    stats = prob.solver_stats
    solve_time = float(stats.solve_time) if stats is not None and stats.solve_time else float("nan")
    return QpResult(x, obj, str(prob.status), solve_time, wall)


def solve_qp(qp: QpData, solver: str = "osqp", eps: float = 1e-9) -> QpResult:
    """Solves an exported QP with ``solver`` in :data:`SOLVERS` to tolerance ``eps``."""
    if solver == "osqp":
        return _osqp(qp, eps)
    if solver.startswith("cvxpy-"):
        return _cvxpy(qp, solver.removeprefix("cvxpy-"), eps)
    raise ValueError(f"solve_qp: unknown solver {solver!r}; choose one of {SOLVERS}")
