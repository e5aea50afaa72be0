"""Reference trajectory by sequential convex programming (paper Section 3.1; docs/model.md
"Reference trajectory").

Fixed final time, minimum sum_k (||u_p,k|| + ||T_k||) dt subject to the discretised dynamics (exact
zero-order hold about the previous iterate), the glide-slope cone (kept exact: it is a second-order
cone), the line-of-sight cone (linearised about the previous iterate), ||u_p|| <= u_max,
||T|| <= T_max, the boundary states of Table 2, and a trust region (a box on the step, scaled per
state group, shrunk when an iterate's dynamics defect grows). The convex subproblems are solved with
cvxpy + Clarabel. Converged when the largest scaled step ||(X - X_prev) / s||_inf falls below ``tol``
and the nonlinear one-step defect is below ``defect_tol`` (relative to s).

Results are cached on disk keyed by a hash of the model's parameters, the shape's fingerprint, a hash
of the gravity model's mesh (vertices and faces, when it has one), the boundary states and the solver
settings. Cache files are written atomically (a temporary file in the same folder, then a rename); an
unreadable cache file is regenerated with a warning naming it.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
import warnings
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import cvxpy as cp
import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from .. import _core

__all__ = ["ReferenceSettings", "ReferenceTrajectory", "generate_reference", "load_or_generate_reference"]

Array = npt.NDArray[np.float64]

#: Per-state scale used by the trust region and the convergence test (m, m/s, rad, rad/s).
STATE_SCALE = np.array([10.0] * 3 + [0.01] * 3 + [0.05] * 3 + [1e-3] * 3)


@dataclass(frozen=True)
class ReferenceSettings:
    """Settings of the SCP. ``trust_radius`` is in units of STATE_SCALE (from the second iteration
    on; the first subproblem, about the straight-line guess, has none)."""

    max_iterations: int = 40
    tol: float = 1e-3
    defect_tol: float = 1e-3
    trust_radius: float = 50.0
    solver: str = "CLARABEL"

    def validate(self) -> None:
        if self.max_iterations < 1:
            raise ValueError(f"ReferenceSettings.max_iterations must be >= 1, got {self.max_iterations}")
        for name in ("tol", "defect_tol", "trust_radius"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"ReferenceSettings.{name} must be finite and > 0, got {v}")


@dataclass(frozen=True)
class ReferenceTrajectory:
    """t (T+1,) s; x (T+1, 12) [r_L, v_L, phi, omega_BL_B]; u (T, 6) [u_p (L), T (B)]."""

    t: Array
    x: Array
    u: Array
    cost: float
    iterations: int
    converged: bool
    max_step: float
    max_defect: float
    solve_time_s: float
    #: cvxpy's status of the last convex subproblem: "optimal", or "optimal_inaccurate" (reduced accuracy:
    #: then converged only if its solution keeps the input bounds and the defect, checked here).
    last_subproblem: str = "optimal"

    def save(self, path: Path) -> None:
        """Writes an ``.npz`` at exactly ``path``, atomically: a reader sees the old file or the new one."""
        path = Path(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                np.savez(
                    f,
                    t=self.t,
                    x=self.x,
                    u=self.u,
                    meta=json.dumps({k: v for k, v in asdict(self).items() if k not in ("t", "x", "u")}),
                )
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    def core(self) -> Any:
        """The C++ core's ``_core.mpc.Reference`` of this trajectory: the nodes as columns (12 x (T+1), 6 x T) and
        t0 the first node's time."""
        return _core.mpc.Reference(self.x.T.copy(), self.u.T.copy(), float(self.t[0]))

    @staticmethod
    def load(path: Path) -> ReferenceTrajectory:
        with open(path, "rb") as f, np.load(f) as d:
            meta = json.loads(str(d["meta"]))
            return ReferenceTrajectory(t=d["t"], x=d["x"], u=d["u"], **meta)


def _initial_guess(x0: Array, xf: Array, T: int) -> tuple[Array, Array]:
    s = np.linspace(0.0, 1.0, T + 1)[:, None]
    X = (1.0 - s) * x0 + s * xf
    return X, np.zeros((T, 6))


def _defect(model: Any, X: Array, U: Array, dt: float) -> float:
    """Largest scaled one-step defect of the model's exact discretisation about (X, U) itself."""
    T = U.shape[0]
    Ad, Bd, cd = model.discretize(0.0, X[:-1], U, dt)
    pred = np.einsum("kij,kj->ki", Ad, X[:-1]) + np.einsum("kij,kj->ki", Bd, U) + cd
    return float(np.max(np.abs((pred - X[1 : T + 1]) / STATE_SCALE)))


def generate_reference(
    model: Any,
    x0: npt.ArrayLike,
    xf: npt.ArrayLike,
    *,
    dt: float,
    n_steps: int,
    u_max: float,
    T_max: float,
    glide_slope_angle: float,
    settings: ReferenceSettings | None = None,
) -> ReferenceTrajectory:
    """Solves the fixed-time minimum-effort problem by SCP from a straight-line initial guess.

    ``model`` is a :class:`tubempc.ProximityModel` (its discretisation and line-of-sight
    linearisation are used); x0, xf the 12-states of Table 2.
    """
    st = settings or ReferenceSettings()
    st.validate()
    x0a, xfa = np.asarray(x0, dtype=float), np.asarray(xf, dtype=float)
    if x0a.shape != (12,) or xfa.shape != (12,) or not (np.all(np.isfinite(x0a)) and np.all(np.isfinite(xfa))):
        raise ValueError("x0 and xf must be finite 12-vectors")
    T = int(n_steps)
    cones = [model.glide_slope_cone_L(k * dt) for k in range(T + 1)]
    apex = np.array([c[0] for c in cones])
    axis = np.array([c[1] for c in cones])
    papers_cone = bool(np.all(apex == 0.0) and np.all(axis == [0.0, 0.0, 1.0]))
    X, U = _initial_guess(x0a, xfa, T)
    nX, nU = 12 * (T + 1), 6 * T
    scale = np.tile(STATE_SCALE, T + 1)
    cos_gs = np.cos(glide_slope_angle)
    radius = st.trust_radius
    t_start = time.perf_counter()
    converged, it, step, cost, status = False, 0, np.inf, np.inf, "optimal"

    for it in range(1, st.max_iterations + 1):
        Ad, Bd, cd = model.discretize(0.0, X[:-1], U, dt)
        G_los = np.empty((T + 1, 12))
        h_los = np.empty(T + 1)
        for k in range(T + 1):
            G, h = model.constraints(k * dt, X[k])
            G_los[k], h_los[k] = G[1], h[1]

        x = cp.Variable(nX)
        u = cp.Variable(nU)
        # Dynamics: x_{k+1} = Ad_k x_k + Bd_k u_k + cd_k for k = 0..T-1, as one sparse system.
        Ablk = sp.block_diag(list(Ad), format="csr")
        Bblk = sp.block_diag(list(Bd), format="csr")
        sel_next = sp.eye(nX, format="csr")[12:]
        sel_prev = sp.eye(nX, format="csr")[:-12]
        Glos: sp.csr_array | sp.csr_matrix = sp.block_diag([g[None, :] for g in G_los], format="csr")
        Xm = cp.reshape(x, (T + 1, 12), order="C")
        Um = cp.reshape(u, (T, 6), order="C")
        if papers_cone:  # apex at the centre, axis z_L: |r| cos(phi_gs) <= r_z
            glide_slope = cp.SOC(Xm[:, 2] / cos_gs, Xm[:, 0:3], axis=1)
        else:  # the cone fixed in A, at each node's time: |r - p_k| cos(phi_gs) <= (r - p_k) . a_k
            D = Xm[:, 0:3] - apex
            glide_slope = cp.SOC(cp.sum(cp.multiply(D, axis), axis=1) / cos_gs, D, axis=1)
        cons = [
            sel_next @ x == Ablk @ (sel_prev @ x) + Bblk @ u + cd.reshape(-1),
            x[:12] == x0a,
            x[-12:] == xfa,
            glide_slope,
            Glos @ x <= h_los,
            cp.norm(Um[:, 0:3], 2, axis=1) <= u_max,
            cp.norm(Um[:, 3:6], 2, axis=1) <= T_max,
        ]
        if it > 1:  # the straight-line guess is not dynamically consistent: no trust region about it
            cons.append(cp.abs(cp.multiply(1.0 / scale, x - X.reshape(-1))) <= radius)
        effort = cp.sum(cp.norm(Um[:, 0:3], 2, axis=1) + cp.norm(Um[:, 3:6], 2, axis=1)) * dt
        prob = cp.Problem(cp.Minimize(effort), cons)
        with warnings.catch_warnings():  # a reduced accuracy is checked below and named in the result
            warnings.filterwarnings("ignore", message="Solution may be inaccurate", category=UserWarning)
            prob.solve(solver=st.solver)
        status = str(prob.status)
        if prob.status not in ("optimal", "optimal_inaccurate") or x.value is None:
            raise RuntimeError(f"reference SCP iteration {it}: convex subproblem {prob.status}")
        X_new = np.asarray(x.value).reshape(T + 1, 12)
        U_new = np.asarray(u.value).reshape(T, 6)
        step = float(np.max(np.abs((X_new - X) / STATE_SCALE)))
        X, U, cost = X_new, U_new, float(prob.value)
        defect = _defect(model, X, U, dt)
        if step < st.tol and defect < st.defect_tol:
            # a reduced-accuracy subproblem counts only if its solution keeps the bounds it was given
            converged = status == "optimal" or _within_bounds(U, u_max, T_max)
            break
        # Trust region: follow the step size down so that the linearisation stays valid.
        radius = max(min(radius, 2.0 * step), 10.0 * st.tol)
    return ReferenceTrajectory(
        t=np.arange(T + 1, dtype=np.float64) * dt,
        x=X,
        u=U,
        cost=cost,
        iterations=it,
        converged=converged,
        max_step=step,
        max_defect=_defect(model, X, U, dt),
        solve_time_s=time.perf_counter() - t_start,
        last_subproblem=status,
    )


def _within_bounds(U: Array, u_max: float, T_max: float, rtol: float = 1e-6) -> bool:
    """Every input of the plan within its norm bound (relative tolerance ``rtol``)."""
    return bool(
        np.all(np.linalg.norm(U[:, 0:3], axis=1) <= u_max * (1.0 + rtol))
        and np.all(np.linalg.norm(U[:, 3:6], axis=1) <= T_max * (1.0 + rtol))
    )


def _mesh_digest(model: Any) -> str | None:
    """SHA-256 of the gravity model's mesh (float64 vertices, int64 faces), None without a mesh."""
    gravity = getattr(model, "gravity", None)
    vertices, faces = getattr(gravity, "vertices", None), getattr(gravity, "faces", None)
    if vertices is None or faces is None:
        return None
    h = hashlib.sha256(np.ascontiguousarray(vertices, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(faces, dtype="<i8").tobytes())
    return h.hexdigest()


def load_or_generate_reference(
    model: Any,
    x0: npt.ArrayLike,
    xf: npt.ArrayLike,
    *,
    cache_dir: str | Path | None,
    key_extra: dict[str, Any],
    **kwargs: Any,
) -> ReferenceTrajectory:
    """:func:`generate_reference` with an on-disk cache keyed by everything that determines it.

    ``key_extra`` must identify the model (parameters, shape fingerprint, density); the boundary
    states, keyword arguments and a hash of the model's mesh are added to the key. A cache file that
    cannot be read (truncated, corrupt) is regenerated with a warning naming it.
    """
    settings = kwargs.get("settings") or ReferenceSettings()
    key = json.dumps(
        {
            "x0": np.asarray(x0, float).tolist(),
            "xf": np.asarray(xf, float).tolist(),
            "kwargs": {k: v for k, v in kwargs.items() if k != "settings"},
            "settings": asdict(settings),
            "model": key_extra,
            "mesh_sha256": _mesh_digest(model),
        },
        sort_keys=True,
        default=str,
    )
    digest = hashlib.sha256(key.encode()).hexdigest()[:20]
    path = Path(cache_dir) / f"reference_{digest}.npz" if cache_dir is not None else None
    if path is not None and path.exists():
        try:
            return ReferenceTrajectory.load(path)
        except (zipfile.BadZipFile, EOFError, OSError, ValueError, KeyError, TypeError) as exc:
            warnings.warn(
                f"{path}: unreadable reference cache file ({type(exc).__name__}: {exc}); regenerating it",
                RuntimeWarning,
                stacklevel=2,
            )
    ref = generate_reference(model, x0, xf, **kwargs)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        ref.save(path)
    return ref
