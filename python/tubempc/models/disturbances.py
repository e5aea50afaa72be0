"""Seeded disturbance models for the closed-loop simulation (docs/model.md "Simulated
disturbance and truth"; paper Eq. 18 for the ellipsoidal set, Section 3 for the lumped disturbance).

Every model owns a numpy Generator built from an integer seed, so a run is reproducible from
its `describe()` dictionary, which is JSON-serialisable and meant to be saved with results.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def psd_factor(S: ArrayLike) -> FloatArray:
    """A factor F with F F^T = S for a symmetric PSD S (Cholesky, eigen-factor if singular)."""
    S_ = np.asarray(S, dtype=np.float64)
    if S_.ndim != 2 or S_.shape[0] != S_.shape[1]:
        raise ValueError(f"expected a square matrix, got shape {S_.shape}")
    if not np.all(np.isfinite(S_)):
        raise ValueError("matrix contains non-finite values")
    S_ = 0.5 * (S_ + S_.T)
    try:
        return np.asarray(np.linalg.cholesky(S_), dtype=np.float64)
    except np.linalg.LinAlgError:
        lam, V = np.linalg.eigh(S_)
        if lam.min() < -1e-12 * max(lam.max(), 0.0):
            raise ValueError("matrix is not positive semidefinite") from None
        return np.asarray(V * np.sqrt(np.maximum(lam, 0.0))[None, :], dtype=np.float64)


def _unit_directions(dim: int, n: int, rng: np.random.Generator) -> FloatArray:
    g = rng.standard_normal((n, dim))
    return np.asarray(g / np.linalg.norm(g, axis=1, keepdims=True), dtype=np.float64)


def sample_ellipsoid(S: ArrayLike, n: int, rng: np.random.Generator) -> FloatArray:
    """n points (rows) uniform in {w : w^T S^-1 w <= 1} (paper Eq. 18).

    Uniform in the unit ball (direction uniform on the sphere, radius u^(1/dim)), mapped by
    a factor F of S (F F^T = S); a linear map keeps the distribution uniform.
    """
    F = psd_factor(S)
    dim = F.shape[0]
    r = rng.random(n) ** (1.0 / dim)
    return np.asarray((_unit_directions(dim, n, rng) * r[:, None]) @ F.T, dtype=np.float64)


def sample_ellipsoid_surface(S: ArrayLike, n: int, rng: np.random.Generator) -> FloatArray:
    """n points (rows) on the boundary {w : w^T S^-1 w = 1} (images of uniform directions)."""
    F = psd_factor(S)
    return _unit_directions(F.shape[0], n, rng) @ F.T


def _as_cov(name: str, S: ArrayLike, dim: int) -> FloatArray:
    S_ = np.asarray(S, dtype=np.float64)
    if S_.shape == (dim,):
        S_ = np.diag(S_)
    if S_.shape != (dim, dim):
        raise ValueError(f"{name}: expected shape ({dim}, {dim}) or ({dim},), got {S_.shape}")
    psd_factor(S_)
    return 0.5 * (S_ + S_.T)


def _as_center(name: str, c: ArrayLike | None, dim: int) -> FloatArray:
    out = np.zeros(dim) if c is None else np.asarray(c, dtype=np.float64)
    if out.shape != (dim,) or not np.all(np.isfinite(out)):
        raise ValueError(f"{name}: expected {dim} finite values, got {out}")
    return out


class EllipsoidDisturbance:
    """i.i.d. w = center + uniform sample of {d : d^T S^-1 d <= 1} (paper Eq. 18), seeded."""

    def __init__(self, S: ArrayLike, seed: int, center: ArrayLike | None = None) -> None:
        S_ = np.asarray(S, dtype=np.float64)
        self.S = _as_cov("S", S_, S_.shape[0])
        self.dim = self.S.shape[0]
        self.center = _as_center("center", center, self.dim)
        self.seed = int(seed)
        self._rng = np.random.default_rng(self.seed)

    def sample(self, n: int | None = None) -> FloatArray:
        """One sample (shape (dim,)) or n samples (shape (n, dim))."""
        w = self.center + sample_ellipsoid(self.S, 1 if n is None else n, self._rng)
        return w[0] if n is None else w

    def describe(self) -> dict[str, Any]:
        return {
            "model": "ellipsoid_uniform",
            "seed": self.seed,
            "S": self.S.tolist(),
            "center": self.center.tolist(),
        }


class AdditiveDisturbance:
    """Per-subsystem additive disturbance on the one-step state increment (paper Eq. 16).

    Translational w_p = [dr (m), dv (m/s)] in frame L, added to position and velocity after
    each step of dt; rotational w_r = [dphi (rad, rotation vector in B), domega (rad/s, in
    B)], composed with the attitude and added to omega by the simulator. Each part is uniform
    in its ellipsoid (S_p, S_r: 6x6 or 6 diagonal entries, SI units squared) around its
    center; the two parts draw from independent streams spawned from `seed`.

    growth_p, growth_r (>= 0): the ellipsoid's semi-axes at step k are scaled by
    1 + (growth - 1) k / (n_steps - 1), from 1 at the first step to `growth` at the last
    (docs/decisions.md, "The paper's claims"); 1 keeps the disturbance stationary.
    """

    def __init__(
        self,
        S_p: ArrayLike,
        S_r: ArrayLike,
        seed: int,
        center_p: ArrayLike | None = None,
        center_r: ArrayLike | None = None,
        *,
        growth_p: float = 1.0,
        growth_r: float = 1.0,
        n_steps: int = 1,
    ) -> None:
        for name, v in (("growth_p", growth_p), ("growth_r", growth_r)):
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {v}")
        if n_steps < 1:
            raise ValueError(f"n_steps must be >= 1, got {n_steps}")
        self.growth_p, self.growth_r, self.n_steps = float(growth_p), float(growth_r), int(n_steps)
        self.seed = int(seed)
        self.S_p = _as_cov("S_p", S_p, 6)
        self.S_r = _as_cov("S_r", S_r, 6)
        self.center_p = _as_center("center_p", center_p, 6)
        self.center_r = _as_center("center_r", center_r, 6)
        seq_p, seq_r = np.random.SeedSequence(self.seed).spawn(2)
        self._rng_p = np.random.default_rng(seq_p)
        self._rng_r = np.random.default_rng(seq_r)

    def scale(self, k: int) -> tuple[float, float]:
        """The semi-axis scales (translation, rotation) of step k (see the class doc)."""
        f = min(max(k, 0), self.n_steps - 1) / max(self.n_steps - 1, 1)
        return 1.0 + (self.growth_p - 1.0) * f, 1.0 + (self.growth_r - 1.0) * f

    def sample(self, k: int = 0) -> tuple[FloatArray, FloatArray]:
        """Step k's (w_p, w_r), each of shape (6,)."""
        s_p, s_r = self.scale(k)
        w_p = self.center_p + s_p * sample_ellipsoid(self.S_p, 1, self._rng_p)[0]
        w_r = self.center_r + s_r * sample_ellipsoid(self.S_r, 1, self._rng_r)[0]
        return w_p, w_r

    def describe(self) -> dict[str, Any]:
        return {
            "model": "additive_ellipsoid_uniform",
            "seed": self.seed,
            "S_p": self.S_p.tolist(),
            "center_p": self.center_p.tolist(),
            "S_r": self.S_r.tolist(),
            "center_r": self.center_r.tolist(),
            "growth_p": self.growth_p,
            "growth_r": self.growth_r,
            "n_steps": self.n_steps,
        }


def rotation_matrix(axis: ArrayLike, angle: float) -> FloatArray:
    """Rotation matrix of `angle` (rad) about the unit vector `axis` (Rodrigues)."""
    k = np.asarray(axis, dtype=np.float64)
    k = k / np.linalg.norm(k)
    Kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    R = np.eye(3) + math.sin(angle) * Kx + (1.0 - math.cos(angle)) * (Kx @ Kx)
    return np.asarray(R, dtype=np.float64)


class ActuatorMismatch:
    """Seeded actuator execution error: applied = R_mis diag(1 + s) commanded.

    Drawn once at construction, separately for the commanded acceleration u_p (m/s^2, frame
    L) and torque T (N m, frame B): per-axis scale errors s_i uniform in [-scale_error,
    scale_error] and a misalignment rotation about a uniformly random axis by an angle
    uniform in [0, misalignment] (rad). Zero errors give the identity.
    """

    def __init__(
        self,
        seed: int,
        scale_error_p: float = 0.0,
        misalignment_p: float = 0.0,
        scale_error_r: float = 0.0,
        misalignment_r: float = 0.0,
    ) -> None:
        for name, v in (
            ("scale_error_p", scale_error_p),
            ("misalignment_p", misalignment_p),
            ("scale_error_r", scale_error_r),
            ("misalignment_r", misalignment_r),
        ):
            if not (math.isfinite(v) and 0.0 <= v < 1.0):
                raise ValueError(f"{name} must be finite and in [0, 1), got {v}")
        self.seed = int(seed)
        self.params = {
            "scale_error_p": scale_error_p,
            "misalignment_p": misalignment_p,
            "scale_error_r": scale_error_r,
            "misalignment_r": misalignment_r,
        }
        rng = np.random.default_rng(self.seed)
        self._drawn: dict[str, Any] = {}
        self.M_p = self._draw(rng, "p", scale_error_p, misalignment_p)
        self.M_r = self._draw(rng, "r", scale_error_r, misalignment_r)

    def _draw(
        self,
        rng: np.random.Generator,
        tag: str,
        scale_error: float,
        misalignment: float,
    ) -> FloatArray:
        scale = 1.0 + rng.uniform(-scale_error, scale_error, 3)
        axis = _unit_directions(3, 1, rng)[0]
        angle = float(rng.uniform(0.0, misalignment))
        self._drawn[f"scale_{tag}"] = scale.tolist()
        self._drawn[f"axis_{tag}"] = axis.tolist()
        self._drawn[f"angle_{tag}"] = angle
        return rotation_matrix(axis, angle) @ np.diag(scale)

    def apply_acceleration(self, u_p: ArrayLike) -> FloatArray:
        """Applied acceleration (m/s^2, L) for the commanded one."""
        return self.M_p @ np.asarray(u_p, dtype=np.float64)

    def apply_torque(self, T: ArrayLike) -> FloatArray:
        """Applied torque (N m, B) for the commanded one."""
        return self.M_r @ np.asarray(T, dtype=np.float64)

    def describe(self) -> dict[str, Any]:
        return {
            "model": "actuator_mismatch",
            "seed": self.seed,
            **self.params,
            **self._drawn,
        }
