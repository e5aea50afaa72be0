"""Forgetting-factor identification of the exogenous input (paper Eq. 26-29; docs/model.md
"Disturbance identification").

With q = e^(lam - 1), lam in (0, 1) the forgetting factor:

    zeta(k+1) = q (zeta(k) + 1)                      (= sum_{i=0..k} q^(k+1-i) if zeta(0) = 0)
    w^_{k+1}  = q / zeta(k+1) (zeta(k) w^_k + w_k)
    S^_{k+1}  = q / zeta(k+1) (zeta(k) S^_k + (w_k - w^_{k+1}) (w_k - w^_{k+1})^T)
    W^(k+1)   = {w : (w - w^_{k+1})^T S^_{k+1}^-1 (w - w^_{k+1}) <= 1}

and the tube uses P_W = pw_scale * S^ (docs/model.md: default 9, the 3-sigma reading).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..config import Config
from ..design.library import memory_weight

__all__ = [
    "ForgettingFactorIdentifier",
    "identifiers",
    "measured_reference_deviation",
    "measured_residual",
    "zeta_closed_form",
]

FloatArray = NDArray[np.float64]


def _vector(name: str, x: ArrayLike) -> FloatArray:
    out = np.asarray(x, dtype=np.float64)
    if out.ndim != 1:
        raise ValueError(f"{name}: expected a vector, got shape {out.shape}")
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name}: contains non-finite values {out}")
    return out


def measured_residual(
    x_next: ArrayLike,
    A_k: ArrayLike,
    B_k: ArrayLike,
    c_k: ArrayLike,
    x_k: ArrayLike,
    u_k: ArrayLike,
) -> FloatArray:
    """w_k = x_{k+1} - (A_k x_k + B_k u_k + c_k), the default ``identification.measured_input = "residual"`` (SI units
    of the subsystem state; A_k, B_k, c_k the discretised model of docs/model.md Eq. M12)."""
    pred = (
        np.asarray(A_k, dtype=np.float64) @ _vector("x_k", x_k)
        + np.asarray(B_k, dtype=np.float64) @ _vector("u_k", u_k)
        + _vector("c_k", c_k)
    )
    return _vector("x_next", x_next) - pred


def measured_reference_deviation(x_next: ArrayLike, zbar_next: ArrayLike) -> FloatArray:
    """w_k = x_{k+1} - zbar_{k+1}, the paper's literal Eq. (26) (``measured_input = "reference_deviation"``)."""
    return _vector("x_next", x_next) - _vector("zbar_next", zbar_next)


def zeta_closed_form(lam: float, k: int, zeta0: float = 0.0) -> float:
    """zeta(k) = q^k zeta0 + q (1 - q^k) / (1 - q), q = e^(lam - 1) (paper Eq. 27 for zeta0 = 0)."""
    q = math.exp(lam - 1.0)
    return q**k * zeta0 + q * (1.0 - q**k) / (1.0 - q)


class ForgettingFactorIdentifier:
    """Recursive estimate of the exogenous input's mean w^ and covariance S^ (paper Eq. 27-29).

    lam: forgetting factor in (0, 1); w0 (n,), S0 (n x n, symmetric PD): the prior w^_0,
    S^_0 (paper Table 1), in the subsystem's SI units.

    Prior at k = 0: the literal recursion has zeta(0) = 0 (empty sum), so the first update
    gives w^_1 = w_0 and S^_1 = 0 whatever the prior: S^_0 is forgotten at once. The paper
    lists S^_0 (Table 1) as the identification's initial condition and the paper describes a
    conservative initial tube that "gradually shrinks", which the literal form cannot
    produce. prior_weight = zeta(0) > 0 keeps the prior as a pseudo-measurement of that weight
    (this class's default 1: like one past sample); prior_weight = 0 is the paper's literal
    recursion. The scenarios use zeta(0) = prior_memory * q / (1 - q) (:func:`identifiers`):
    with prior_memory = 1 zeta stays constant and the prior decays by q per step.

    eig_floor: the returned S^ has its eigenvalues floored so that, in the coordinates scaled
    by the prior's standard deviations sqrt(diag(S0)), every eigenvalue is >= eig_floor
    (default 1e-6: every direction keeps at least 1e-3 of the prior's standard deviation).
    The floor is applied to the returned matrix only; the recursion itself stays exact.
    pw_scale: P_W = pw_scale * S^ (default 9, the 3-sigma reading of docs/model.md).
    """

    def __init__(
        self,
        lam: float,
        w0: ArrayLike,
        S0: ArrayLike,
        *,
        prior_weight: float = 1.0,
        eig_floor: float = 1e-6,
        pw_scale: float = 9.0,
    ) -> None:
        if not (math.isfinite(lam) and 0.0 < lam < 1.0):
            raise ValueError(f"forgetting factor lam must lie in (0, 1), got {lam}")
        if not (math.isfinite(prior_weight) and prior_weight >= 0.0):
            raise ValueError(f"prior_weight must be finite and >= 0, got {prior_weight}")
        if not (math.isfinite(eig_floor) and eig_floor > 0.0):
            raise ValueError(f"eig_floor must be finite and > 0, got {eig_floor}")
        if not (math.isfinite(pw_scale) and pw_scale > 0.0):
            raise ValueError(f"pw_scale must be finite and > 0, got {pw_scale}")
        self.lam = float(lam)
        self.q = math.exp(self.lam - 1.0)
        self.w_hat = _vector("w0", w0).copy()
        n = self.w_hat.shape[0]
        S = np.asarray(S0, dtype=np.float64)
        if S.shape != (n, n) or not np.all(np.isfinite(S)):
            raise ValueError(f"S0: expected a finite ({n}, {n}) matrix, got shape {S.shape}")
        S = 0.5 * (S + S.T)
        if np.linalg.eigvalsh(S).min() <= 0.0:
            raise ValueError("S0 must be positive definite")
        self._S = S
        self._d = np.sqrt(np.diag(S))
        self.zeta = float(prior_weight)
        self.eig_floor = float(eig_floor)
        self.pw_scale = float(pw_scale)
        self.k = 0

    @property
    def S_hat(self) -> FloatArray:
        """Current covariance estimate S^_k, symmetric, eigenvalue-floored (see class doc)."""
        d = self._d
        Ss = self._S / np.outer(d, d)
        lam, V = np.linalg.eigh(0.5 * (Ss + Ss.T))
        Ss = (V * np.maximum(lam, self.eig_floor)[None, :]) @ V.T
        return np.asarray(0.5 * (Ss + Ss.T) * np.outer(d, d), dtype=np.float64)

    @property
    def P_W(self) -> FloatArray:
        """Disturbance ellipsoid shape for the tube design, pw_scale * S^_k."""
        return self.pw_scale * self.S_hat

    def update(self, w_k: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Fold the measured input w_k in; return (w^_{k+1}, S^_{k+1}) (S^ floored)."""
        w = _vector("w_k", w_k)
        if w.shape != self.w_hat.shape:
            raise ValueError(f"w_k: expected shape {self.w_hat.shape}, got {w.shape}")
        zeta_next = self.q * (self.zeta + 1.0)
        g = self.q / zeta_next
        w_next = g * (self.zeta * self.w_hat + w)
        dw = w - w_next
        self._S = g * (self.zeta * self._S + np.outer(dw, dw))
        self._S = 0.5 * (self._S + self._S.T)
        self.w_hat = w_next
        self.zeta = zeta_next
        self.k += 1
        return self.w_hat.copy(), self.S_hat


def identifiers(
    cfg: Config, lambda_p: float | None = None, lambda_r: float | None = None
) -> tuple[ForgettingFactorIdentifier, ForgettingFactorIdentifier]:
    """Forgetting-factor identifiers of both subsystems at their prior (paper Eq. 26-29);
    ``lambda_p``/``lambda_r`` override the configuration's forgetting factors."""
    ident = cfg.identification
    common = {"eig_floor": ident.eig_floor, "pw_scale": ident.pw_scale}
    lam_p, lam_r = lambda_p or ident.lambda_p, lambda_r or ident.lambda_r
    return (
        ForgettingFactorIdentifier(
            lam_p, ident.w0_p, ident.S0_p, prior_weight=ident.prior_memory * memory_weight(lam_p), **common
        ),
        ForgettingFactorIdentifier(
            lam_r, ident.w0_r, ident.S0_r, prior_weight=ident.prior_memory * memory_weight(lam_r), **common
        ),
    )
