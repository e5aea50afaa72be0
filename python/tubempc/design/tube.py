"""Ellipsoidal tube design per subsystem (paper Eq. 25; docs/model.md "Tube design").

The tube of the ancillary law u = v + K (x - z) is the ellipsoid Z = {e : e^T Pe^-1 e <= 1}.
It is robust positively invariant for e+ = (A + B K) e + w, w in W = {w : w^T P_W^-1 w <= 1}
(paper Proposition 1), when, for some alpha in (0, 1),

    (A + B K) Pe (A + B K)^T / alpha + P_W / (1 - alpha) <= Pe.                      (*)

With Y = K Pe, (*) is, by a Schur complement on alpha Pe > 0, exactly the linear matrix
inequality used here:

    [[Pe - P_W / (1 - alpha), A Pe + B Y], [(A Pe + B Y)^T, alpha Pe]] >= 0.

The paper's Eq. (25) writes (*) with the auxiliary Z >= Y Pe^-1 Y^T in place of the term
B Y Pe^-1 Y^T B^T (i.e. (A Pe A^T + B Y A^T + A Y^T B^T + B Z B^T) / alpha - Pe +
P_W / (1 - alpha) <= 0). Since B Z B^T >= B Y Pe^-1 Y^T B^T, every point feasible for the
paper's form satisfies (*): the exact form used here is never more restrictive than the
paper's, and the tube it certifies is invariant by the same argument. The other constraints
and the objective are the paper's: [[Z, Y], [Y^T, Pe]] >= 0, [[Pe, Y^T], [Y, u_max^2 I]] >= 0
(which gives K_i Pe K_i^T <= u_max^2 for every input row i, so ``|K e|_i <= u_max`` on Z), and
min Tr(Q Pe) + Tr(R Z), i.e. Tr(C Pe C^T + B2 Z B2^T) with C = [Q^1/2; 0], B2 = [0; R^1/2].

The scalar alpha is found by a one-dimensional search on the optimal value f(alpha), done in
the logit coordinate s = ln(alpha / (1 - alpha)) so that optima close to 1 (slow closed-loop
contraction, e.g. the rotational subsystem) are resolved as finely as those near 1/2. Every
solve also returns df/dalpha from the dual matrix of the invariance LMI (envelope theorem),
which the search uses as a slope: a safeguarded secant on the slope inside a bracket.

Numerics: the state components span many orders of magnitude (rotational P_W ~ 1e-8), so
the SDP is posed in scaled coordinates x_s = D^-1 x (D diagonal, from sqrt(diag(P_W)) or a
user-given scale) and inputs u_s = u / u_max; the objective is normalised to order one. The
cvxpy problem is built once with Parameters and is DPP, so cvxpy compiles it once.
"""

from __future__ import annotations

import math
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any

import cvxpy as cp
import numpy as np
import scipy.linalg
from cvxpy.atoms.affine.bmat import bmat as _cp_bmat
from cvxpy.atoms.affine.trace import trace as _cp_trace
from cvxpy.expressions.expression import Expression
from numpy.typing import ArrayLike, NDArray

from ..models.disturbances import sample_ellipsoid, sample_ellipsoid_surface

FloatArray = NDArray[np.float64]

# cvxpy is untyped: typed aliases of the calls used here.
bmat: Callable[[list[list[Any]]], Expression] = _cp_bmat
trace: Callable[[Any], Expression] = _cp_trace


class DesignStatus(Enum):
    """Outcome of a tube design."""

    OPTIMAL = "optimal"
    OPTIMAL_INACCURATE = "optimal_inaccurate"
    INFEASIBLE = "infeasible"
    SOLVER_ERROR = "solver_error"
    INVALID = "invalid"  # solved, but not certified exactly (certify_design: residual > 0 or empty tightening)
    LYAPUNOV = "lyapunov"  # the certified per-step update (lyapunov_tube) of a design's K and alpha


@dataclass(frozen=True)
class DesignResult:
    """Result of one tube design in the subsystem's SI units.

    K: feedback gain (n_u x n_x); Pe: tube shape matrix (n_x x n_x); both None when no
    solve succeeded (INFEASIBLE, SOLVER_ERROR); use them only when `feasible`. objective: Tr(Q Pe) + Tr(R Z) at the optimum
    (inf if none). lmi_residual: `lmi_residual(A, B, K, Pe, P_W, alpha)`, <= 0 when (*)
    holds. solve_time_s: wall time of the whole design; n_solves: SDP solves it used.
    """

    K: FloatArray | None
    Pe: FloatArray | None
    alpha: float
    objective: float
    status: DesignStatus
    lmi_residual: float
    solve_time_s: float
    n_solves: int

    @property
    def feasible(self) -> bool:
        """True when the result holds a usable tube."""
        return self.status in (DesignStatus.OPTIMAL, DesignStatus.OPTIMAL_INACCURATE)


@dataclass
class _Eval:
    """One SDP solve at fixed alpha, in scaled coordinates and normalised objective."""

    s: float  # logit(alpha)
    status: DesignStatus
    value: float = math.inf
    slope: float = math.nan  # df/ds
    Pe_s: FloatArray | None = None
    Y_s: FloatArray | None = None

    @property
    def ok(self) -> bool:
        return self.status in (DesignStatus.OPTIMAL, DesignStatus.OPTIMAL_INACCURATE)


_STATUS = {
    cp.OPTIMAL: DesignStatus.OPTIMAL,
    cp.OPTIMAL_INACCURATE: DesignStatus.OPTIMAL_INACCURATE,
    cp.INFEASIBLE: DesignStatus.INFEASIBLE,
    cp.INFEASIBLE_INACCURATE: DesignStatus.INFEASIBLE,
}


def _sym(M: FloatArray) -> FloatArray:
    return 0.5 * (M + M.T)


def _as_matrix(name: str, M: ArrayLike, shape: tuple[int, int]) -> FloatArray:
    out = np.asarray(M, dtype=np.float64)
    if out.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {out.shape}")
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name}: contains non-finite values")
    return out


# Cold-start alpha grid, denser towards 1 where slowly contracting subsystems have their optimum.
_ALPHA_GRID = (0.1, 0.3, 0.5, 0.7, 0.85, 0.93, 0.97, 0.99, 0.997)


@dataclass
class _Sdp:
    """The SDP of paper Eq. (25) for one (n_x, n_u, margin), compiled by cvxpy once: its variables, parameters,
    the invariance constraint (whose dual gives the objective's slope in alpha) and the problem."""

    Pe: cp.Variable
    Y: cp.Variable
    Z: cp.Variable
    A: cp.Parameter
    B: cp.Parameter
    PWa: cp.Parameter  # P_W,s / (1 - alpha)
    alpha: cp.Parameter
    Qs: cp.Parameter
    Rs: cp.Parameter
    inv_con: Any
    problem: cp.Problem


# One compiled SDP per size and margin in each thread (thread-local storage, freed with its thread): cvxpy's
# canonicalisation (tens of ms) is made once per thread instead of once per designer (a campaign's run makes two
# designers), and a thread's designs never share the parameters another thread is setting. The compiled program
# maps the parameters to the same solver data whoever solved before (tests/py/design/test_tube.py).
_COMPILED = threading.local()


def _compiled_sdp(n_x: int, n_u: int, margin: float) -> _Sdp:
    cache: dict[tuple[int, int, float], _Sdp] | None = getattr(_COMPILED, "sdps", None)
    if cache is None:
        cache = _COMPILED.sdps = {}
    key = (n_x, n_u, margin)
    if key not in cache:
        cache[key] = _build_sdp(n_x, n_u, margin)
    return cache[key]


def _build_sdp(n_x: int, n_u: int, margin: float) -> _Sdp:
    Pe = cp.Variable((n_x, n_x), symmetric=True)
    Y = cp.Variable((n_u, n_x))
    Z = cp.Variable((n_u, n_u), symmetric=True)
    A = cp.Parameter((n_x, n_x))
    B = cp.Parameter((n_x, n_u))
    PWa = cp.Parameter((n_x, n_x), symmetric=True)
    alpha = cp.Parameter(nonneg=True)
    Qs = cp.Parameter((n_x, n_x), PSD=True)
    Rs = cp.Parameter((n_u, n_u), PSD=True)
    M = A @ Pe + B @ Y
    inv = bmat([[Pe - PWa, M], [M.T, alpha * Pe]])
    cost = bmat([[Z, Y], [Y.T, Pe]])
    inp = bmat([[Pe, Y.T], [Y, np.eye(n_u)]])
    inv_con = _sym_expr(inv) >> margin * np.eye(2 * n_x)
    cons = [inv_con, _sym_expr(cost) >> 0, _sym_expr(inp) >> 0]
    problem = cp.Problem(cp.Minimize(trace(Qs @ Pe) + trace(Rs @ Z)), cons)
    assert problem.is_dpp()
    return _Sdp(Pe, Y, Z, A, B, PWa, alpha, Qs, Rs, inv_con, problem)


class TubeDesigner:
    """Tube design (K, Pe, alpha) for one subsystem (paper Eq. 25; docs/model.md "Tube design").

    Q (n_x x n_x, PSD) and R (n_u x n_u, PD) weight Tr(Q Pe) + Tr(R Z); u_max is the input
    bound (subsystem input units, e.g. m/s^2 or N m) of [[Pe, Y^T], [Y, u_max^2 I]] >= 0.
    state_scale: diagonal scaling D of the state for the SDP (subsystem state units); None
    takes sqrt(diag(P_W)) at every design. lmi_margin: the invariance LMI is imposed
    >= lmi_margin * I in scaled coordinates so that the returned tube satisfies (*) strictly
    despite solver tolerances. alpha_grid: cold-start evaluation points; warm_halfwidth:
    initial half-width of the warm-start bracket around alpha_prev, in logit units
    s = ln(alpha / (1 - alpha)); s_xtol, obj_rtol: stop when the bracket is narrower than
    s_xtol or the first-order bound on the remaining improvement is below obj_rtol times the
    objective; max_solves: cap on the solves of one design (the cold-start grid is always
    evaluated in full; max_solves = 1 or 2 gives a fixed-cost warm update: alpha_prev
    only, or alpha_prev and one probe). A solution is accepted only when :func:`certify_design`
    certifies it exactly (recomputed lmi_residual <= 0, non-empty input tightening), else it gets
    status INVALID. solver_options are passed to cvxpy's solve.
    """

    def __init__(
        self,
        n_x: int = 6,
        n_u: int = 3,
        *,
        Q: ArrayLike,
        R: ArrayLike,
        u_max: float,
        solver: str = "CLARABEL",
        state_scale: ArrayLike | None = None,
        lmi_margin: float = 1e-7,
        alpha_grid: tuple[float, ...] = _ALPHA_GRID,
        warm_halfwidth: float = 0.05,
        s_xtol: float = 2e-3,
        obj_rtol: float = 2e-3,
        max_solves: int = 25,
        solver_options: dict[str, object] | None = None,
    ) -> None:
        self.n_x, self.n_u = n_x, n_u
        # The constructor's arguments: a designer rebuilt from them (another process) designs alike.
        self.spec: dict[str, Any] = {
            "n_x": n_x,
            "n_u": n_u,
            "Q": np.array(Q, dtype=np.float64),
            "R": np.array(R, dtype=np.float64),
            "u_max": u_max,
            "solver": solver,
            "state_scale": None if state_scale is None else np.array(state_scale, dtype=np.float64),
            "lmi_margin": lmi_margin,
            "alpha_grid": tuple(alpha_grid),
            "warm_halfwidth": warm_halfwidth,
            "s_xtol": s_xtol,
            "obj_rtol": obj_rtol,
            "max_solves": max_solves,
            "solver_options": dict(solver_options or {}),
        }
        self.Q = _sym(_as_matrix("Q", Q, (n_x, n_x)))
        self.R = _sym(_as_matrix("R", R, (n_u, n_u)))
        if np.linalg.eigvalsh(self.Q).min() < 0.0 or np.linalg.eigvalsh(self.R).min() <= 0.0:
            raise ValueError("Q must be PSD and R positive definite")
        if not (math.isfinite(u_max) and u_max > 0.0):
            raise ValueError(f"u_max must be finite and > 0, got {u_max}")
        self.u_max = float(u_max)
        self.solver = solver
        self.state_scale = None if state_scale is None else self._check_scale(state_scale)
        if not all(0.0 < a < 1.0 for a in alpha_grid):
            raise ValueError("alpha_grid must lie in (0, 1)")
        self.alpha_grid = tuple(sorted(alpha_grid))
        self.s_bounds = (
            _logit(min(1e-3, self.alpha_grid[0])),
            _logit(max(1.0 - 1e-4, self.alpha_grid[-1])),
        )
        self.warm_halfwidth = warm_halfwidth
        self.s_xtol = s_xtol
        self.obj_rtol = obj_rtol
        self.max_solves = max_solves
        self.solver_options = dict(solver_options or {})
        self._PW_s = np.eye(n_x)  # scaled P_W of the current design
        self._lmi_margin = float(lmi_margin)

    def _check_scale(self, scale: ArrayLike) -> FloatArray:
        d = np.asarray(scale, dtype=np.float64).reshape(-1)
        if d.shape != (self.n_x,) or not np.all(np.isfinite(d)) or np.any(d <= 0.0):
            raise ValueError(f"state scale must be {self.n_x} finite positive values, got {d}")
        return d

    @property
    def problem(self) -> cp.Problem:
        """The SDP this designer solves in the calling thread (:func:`_compiled_sdp`)."""
        return self._sdp().problem

    def _sdp(self) -> _Sdp:
        return _compiled_sdp(self.n_x, self.n_u, self._lmi_margin)

    def _set_data(self, sdp: _Sdp, A: FloatArray, B: FloatArray, P_W: FloatArray) -> tuple[FloatArray, float]:
        """Scale the data into the SDP's parameters; return D and the objective factor."""
        if self.state_scale is not None:
            d = self.state_scale
        else:
            diag = np.diag(P_W)
            if np.any(diag <= 0.0):
                raise ValueError("P_W has a non-positive diagonal; give state_scale")
            d = np.sqrt(diag)
        su = self.u_max
        sdp.A.value = A * (1.0 / d)[:, None] * d[None, :]
        sdp.B.value = B * (su / d)[:, None]
        self._PW_s = _sym(P_W / np.outer(d, d))
        Qs = _sym(self.Q * np.outer(d, d))
        Rs = self.R * su * su
        c = float(np.trace(Qs) + np.trace(Rs))
        sdp.Qs.value = Qs / c
        sdp.Rs.value = Rs / c
        return d, c

    def _evaluate(self, sdp: _Sdp, s: float) -> _Eval:
        alpha = _expit(s)
        sdp.alpha.value = alpha
        sdp.PWa.value = self._PW_s / (1.0 - alpha)
        try:
            with warnings.catch_warnings():
                # An inaccurate solution is reported through DesignStatus.OPTIMAL_INACCURATE.
                warnings.filterwarnings("ignore", "Solution may be inaccurate", UserWarning)
                solve: Callable[..., object] = sdp.problem.solve
                # No warm start: Clarabel would reuse the previous solve's data and a design would
                # depend on the designs before it (1e-5 in Pe), so that a design in another process
                # (tube_policy.py) would differ from the same design here.
                solve(solver=self.solver, **{"warm_start": False, **self.solver_options})
        except cp.error.SolverError:
            return _Eval(s, DesignStatus.SOLVER_ERROR)
        status = _STATUS.get(sdp.problem.status, DesignStatus.SOLVER_ERROR)
        if status not in (DesignStatus.OPTIMAL, DesignStatus.OPTIMAL_INACCURATE):
            return _Eval(s, status)
        Pe_s = _sym(np.asarray(sdp.Pe.value))
        lam = np.asarray(sdp.inv_con.dual_value)
        n = self.n_x
        dfda = np.sum(lam[:n, :n] * self._PW_s) / (1.0 - alpha) ** 2 - np.sum(lam[n:, n:] * Pe_s)
        slope = float(dfda) * alpha * (1.0 - alpha)
        return _Eval(s, status, float(sdp.problem.value), slope, Pe_s, np.asarray(sdp.Y.value))

    def design(
        self,
        A: ArrayLike,
        B: ArrayLike,
        P_W: ArrayLike,
        alpha_prev: float | None = None,
    ) -> DesignResult:
        """Design the tube for x+ = A x + B u + w, w^T P_W^-1 w <= 1 (subsystem SI units).

        With alpha_prev, the search starts at alpha_prev, probes a bracket of half-width
        `warm_halfwidth` in the descent direction and widens it only while the optimum lies
        beyond its edge; without it (or if alpha_prev is infeasible), it evaluates
        `alpha_grid` and refines around the best point. Infeasibility is reported in the
        status, never raised.
        """
        t0 = time.perf_counter()
        A_, B_, PW = self._check_data(A, B, P_W)
        sdp = self._sdp()
        d, c = self._set_data(sdp, A_, B_, PW)
        search = _Search(lambda s: self._evaluate(sdp, s), self.s_bounds)
        best = None if alpha_prev is None else self._warm_search(alpha_prev, search)
        if best is None:
            best = self._cold_search(search)
        return self._result(A_, B_, PW, d, c, best, search.n, t0)

    def design_fixed_alpha(self, A: ArrayLike, B: ArrayLike, P_W: ArrayLike, alpha: float) -> DesignResult:
        """Design the tube with alpha fixed (one solve); same units and status as `design`."""
        if not 0.0 < alpha < 1.0:
            raise ValueError(f"alpha must lie in (0, 1), got {alpha}")
        t0 = time.perf_counter()
        A_, B_, PW = self._check_data(A, B, P_W)
        sdp = self._sdp()
        d, c = self._set_data(sdp, A_, B_, PW)
        return self._result(A_, B_, PW, d, c, self._evaluate(sdp, _logit(alpha)), 1, t0)

    def _check_data(self, A: ArrayLike, B: ArrayLike, P_W: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        A_ = _as_matrix("A", A, (self.n_x, self.n_x))
        B_ = _as_matrix("B", B, (self.n_x, self.n_u))
        PW = _sym(_as_matrix("P_W", P_W, (self.n_x, self.n_x)))
        return A_, B_, PW

    def _warm_search(self, alpha_prev: float, search: _Search) -> _Eval | None:
        """Bracket search around alpha_prev; None if alpha_prev is infeasible."""
        if not 0.0 < alpha_prev < 1.0:
            raise ValueError(f"alpha_prev must lie in (0, 1), got {alpha_prev}")
        b = search(_logit(alpha_prev))
        if not b.ok:
            return None
        h = self.warm_halfwidth
        if abs(b.slope) * h <= self.obj_rtol * abs(b.value) or search.n >= self.max_solves:
            return b
        direction = -math.copysign(1.0, b.slope)
        while True:
            t = search(b.s + direction * h)
            beyond = t.ok and t.value <= b.value and t.slope * direction < 0.0
            if not beyond or t.s in self.s_bounds or search.n >= self.max_solves:
                break
            b, h = t, 4.0 * h
        if beyond:
            return t
        return self._refine(b, t, search)

    def _cold_search(self, search: _Search) -> _Eval:
        grid = [search(_logit(a)) for a in self.alpha_grid]
        if not any(e.ok for e in grid):
            errors = [e for e in grid if e.status is DesignStatus.SOLVER_ERROR]
            return errors[0] if len(errors) == len(grid) else grid[0]
        i = min(range(len(grid)), key=lambda j: grid[j].value)
        b = grid[i]
        lo, hi = self.s_bounds
        if b.slope > 0.0:
            other = grid[i - 1] if i > 0 else _Eval(lo, DesignStatus.INFEASIBLE)
        else:
            other = grid[i + 1] if i + 1 < len(grid) else _Eval(hi, DesignStatus.INFEASIBLE)
        return self._refine(b, other, search)

    def _refine(self, b: _Eval, e: _Eval, search: _Search) -> _Eval:
        """Minimise f between the best point b and the far end e (the minimum lies between).

        Secant on the slope when e is feasible with a slope of the other sign, bisection
        otherwise; stops on s_xtol, on max_solves, or when the remaining improvement bound
        is below obj_rtol |f(b)|: |f'(b)| |e - b|, or, with slopes of both signs, the gap
        to the intersection of the tangents at b and e (a lower bound where f is convex,
        valid also at a kink of f, which appears when the input constraint becomes active).
        """
        while search.n < self.max_solves:
            width = abs(e.s - b.s)
            if width <= self.s_xtol:
                break
            gap = abs(b.slope) * width
            bracketed = e.ok and b.slope * e.slope < 0.0
            if bracketed:
                s_x = (e.value - b.value + b.slope * b.s - e.slope * e.s) / (b.slope - e.slope)
                gap = min(gap, b.value - (b.value + b.slope * (s_x - b.s)))
            if e.ok and gap <= self.obj_rtol * abs(b.value):
                break
            if bracketed:
                t_s = b.s - b.slope * (e.s - b.s) / (e.slope - b.slope)
                lo_s, hi_s = sorted((b.s, e.s))
                t_s = min(max(t_s, lo_s + 0.05 * width), hi_s - 0.05 * width)
            else:
                t_s = 0.5 * (b.s + e.s)
            t = search(t_s)
            if not t.ok:
                e = t
            elif t.slope * b.slope > 0.0:
                b, e = (t, e) if t.value <= b.value else (b, t)
            else:
                b, e = (t, b) if t.value < b.value else (b, t)
        return b

    def _result(
        self,
        A: FloatArray,
        B: FloatArray,
        P_W: FloatArray,
        d: FloatArray,
        c: float,
        best: _Eval,
        n_solves: int,
        t0: float,
    ) -> DesignResult:
        alpha = _expit(best.s)
        if best.Pe_s is None or best.Y_s is None:
            elapsed = time.perf_counter() - t0
            return DesignResult(None, None, alpha, math.inf, best.status, math.nan, elapsed, n_solves)
        K_s = np.linalg.solve(best.Pe_s, best.Y_s.T).T
        K = self.u_max * K_s / d[None, :]
        Pe, resid, certified = certify_design(A, B, K, _sym(best.Pe_s * np.outer(d, d)), P_W, alpha, self.u_max)
        status = best.status if certified else DesignStatus.INVALID
        elapsed = time.perf_counter() - t0
        return DesignResult(K, Pe, alpha, best.value * c, status, resid, elapsed, n_solves)


class _Search:
    """Counts the evaluations of one design and clips s = logit(alpha) to the bounds."""

    def __init__(self, evaluate: Callable[[float], _Eval], bounds: tuple[float, float]):
        self._evaluate = evaluate
        self._bounds = bounds
        self.n = 0

    def __call__(self, s: float) -> _Eval:
        self.n += 1
        return self._evaluate(min(max(float(s), self._bounds[0]), self._bounds[1]))


def _logit(alpha: float) -> float:
    return math.log(alpha / (1.0 - alpha))


def _expit(s: float) -> float:
    return 1.0 / (1.0 + math.exp(-s))


def _sym_expr(M: Expression) -> Expression:
    out: Expression = 0.5 * (M + M.T)
    return out


def lmi_residual(
    A: ArrayLike,
    B: ArrayLike,
    K: ArrayLike,
    Pe: ArrayLike,
    P_W: ArrayLike,
    alpha: float,
) -> float:
    """Violation of the invariance condition (*) recomputed in numpy, relative to Pe.

    Returns the largest eigenvalue of S^-1 M S^-1 with M = (A + B K) Pe (A + B K)^T / alpha
    + P_W / (1 - alpha) - Pe and S = diag(sqrt(diag(Pe))): dimensionless, <= 0 iff (*) holds.
    """
    A_, B_, K_ = (np.asarray(X, dtype=np.float64) for X in (A, B, K))
    Pe_ = _sym(np.asarray(Pe, dtype=np.float64))
    Acl = A_ + B_ @ K_
    M = Acl @ Pe_ @ Acl.T / alpha + np.asarray(P_W, dtype=np.float64) / (1.0 - alpha) - Pe_
    s = 1.0 / np.sqrt(np.diag(Pe_))
    return float(np.linalg.eigvalsh(_sym(M * np.outer(s, s))).max())


#: Relative enlargements of Pe tried, in order, when a solver's Pe misses (*) by its tolerance.
CERTIFY_SCALES = (0.0, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3)


def certify_design(
    A: FloatArray, B: FloatArray, K: FloatArray, Pe: FloatArray, P_W: FloatArray, alpha: float, u_max: float
) -> tuple[FloatArray, float, bool]:
    """The exact acceptance of an LMI design: (Pe', residual, certified) with Pe' = (1 + s) Pe for the
    first s of :data:`CERTIFY_SCALES` with ``lmi_residual <= 0``, certified when its input tightening is
    non-empty too (sqrt(K_i Pe' K_i^T) < u_max), so that a design the solver met only to its tolerance
    is certified exactly or refused. Enlarging Pe by (1 + s) turns a residual r > 0 into at most
    (1 + s) r - s lambda_min(S^-1 P_W S^-1) / (1 - alpha) (S = diag(Pe)^1/2): a small s suffices when
    r is of the solver's tolerance; a larger Pe only widens the feedback, so the search stops at the
    first s with r <= 0. Not certified: the last candidate and its residual."""
    Pe_s, resid = Pe, math.inf
    for s in CERTIFY_SCALES:
        Pe_s = Pe * (1.0 + s)
        resid = lmi_residual(A, B, K, Pe_s, P_W, alpha)
        if resid <= 0.0:
            feedback = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", K, Pe_s, K), 0.0))
            return Pe_s, resid, bool(np.all(feedback < u_max))
    return Pe_s, resid, False


#: Relative inflation of P_W in the Lyapunov update: keeps the certified tube strictly inside the
#: invariance condition, which the exact solution meets with equality.
LYAPUNOV_MARGIN = 1e-9


def lyapunov_tube(
    A: ArrayLike, B: ArrayLike, tube: DesignResult, P_W: ArrayLike, u_max: float
) -> tuple[DesignResult | None, str]:
    """The certified per-step tube update (a microsecond alternative to an LMI design).

    For the gain K and alpha of ``tube`` (an LMI design), the smallest ellipsoid robustly invariant
    for x+ = (A + B K) x + w, w^T P_W^-1 w <= 1, in the family of the invariance condition (*), solves
    the discrete Lyapunov equation Pe = A_K Pe A_K^T / alpha + P_W / (1 - alpha), A_K = A + B K
    (P_W inflated by LYAPUNOV_MARGIN). The result is certified, not assumed: it must exist
    (rho(A_K)^2 < alpha), satisfy (*) for this (A, B) (``lmi_residual <= 0``) and leave the input
    tightening non-empty (sqrt(K_i Pe K_i^T) < u_max). Returns (tube, "") or (None, reason).
    """
    if tube.K is None or not tube.feasible:
        return None, "no designed gain"
    A_, B_, K_ = (np.asarray(X, dtype=np.float64) for X in (A, B, tube.K))
    PW = _sym(np.asarray(P_W, dtype=np.float64)) * (1.0 + LYAPUNOV_MARGIN)
    a = tube.alpha
    Acl = A_ + B_ @ K_
    rho = float(np.max(np.abs(np.linalg.eigvals(Acl))))
    if not rho * rho < a:
        return None, f"A + B K is not contractive enough for alpha = {a:.4g} (rho^2 = {rho * rho:.4g})"
    t0 = time.perf_counter()
    Pe = _sym(scipy.linalg.solve_discrete_lyapunov(Acl / np.sqrt(a), PW / (1.0 - a)))
    if not np.all(np.isfinite(Pe)) or np.linalg.eigvalsh(Pe).min() <= 0.0:
        return None, "the Lyapunov solution is not positive definite"
    residual = lmi_residual(A_, B_, K_, Pe, P_W, a)
    if residual > 0.0:
        return None, f"invariance condition violated for this step's linearisation (residual {residual:.3g})"
    margin = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", K_, Pe, K_), 0.0))
    if np.any(margin >= u_max):
        return None, f"empty input tightening (feedback {margin.max():.4g} >= u_max {u_max:.4g})"
    return DesignResult(
        K=K_,
        Pe=Pe,
        alpha=a,
        objective=float("nan"),
        status=DesignStatus.LYAPUNOV,
        lmi_residual=residual,
        solve_time_s=time.perf_counter() - t0,
        n_solves=0,
    ), ""


def sample_invariance(
    A: ArrayLike,
    B: ArrayLike,
    K: ArrayLike,
    Pe: ArrayLike,
    P_W: ArrayLike,
    n: int,
    rng: np.random.Generator,
) -> float:
    """Largest e+^T Pe^-1 e+ over n samples, e+ = (A + B K) e + w (<= 1 for an invariant tube).

    e is drawn uniformly on the boundary of {e^T Pe^-1 e <= 1}; w on the boundary of
    {w^T P_W^-1 w <= 1} for half of the samples and uniformly inside it for the other half.
    """
    A_, B_, K_ = (np.asarray(X, dtype=np.float64) for X in (A, B, K))
    Pe_ = _sym(np.asarray(Pe, dtype=np.float64))
    PW = _sym(np.asarray(P_W, dtype=np.float64))
    e = sample_ellipsoid_surface(Pe_, n, rng)
    n_in = n // 2
    w = np.vstack([sample_ellipsoid(PW, n_in, rng), sample_ellipsoid_surface(PW, n - n_in, rng)])
    e_next = e @ (A_ + B_ @ K_).T + w
    L = np.linalg.cholesky(Pe_)
    z = np.linalg.solve(L, e_next.T)
    return float(np.max(np.sum(z * z, axis=0)))


def tube_excursion(x: FloatArray, z: FloatArray, Pe: FloatArray) -> FloatArray:
    """e_k^T Pe_k^-1 e_k for each k, with e = x - z (n_k, n) and Pe (n_k, n, n) or one (n, n)."""
    e = np.asarray(x, dtype=float) - np.asarray(z, dtype=float)
    P = np.broadcast_to(np.asarray(Pe, dtype=float), (e.shape[0], e.shape[1], e.shape[1]))
    return np.asarray(np.einsum("ki,ki->k", e, np.linalg.solve(P, e[..., None])[..., 0]), dtype=float)
