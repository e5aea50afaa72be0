"""The C++ controller's parts against their Python oracles (tubempc.testing.identification, tubempc.design.tube), and the
exact certification of LMI designs checked by an independent worst-direction search."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import minimize

from tubempc import _core
from tubempc.design.tube import DesignStatus, TubeDesigner, lmi_residual, lyapunov_tube
from tubempc.testing.identification import ForgettingFactorIdentifier

ctl = _core.control


def _spd(rng: np.random.Generator, n: int, scales: np.ndarray) -> np.ndarray:
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    M = Q @ np.diag(rng.uniform(0.2, 1.0, n)) @ Q.T
    return np.asarray(M * np.outer(scales, scales))


@pytest.mark.parametrize("lam, prior_weight", [(0.96, 24.5), (0.5, 0.0), (0.98, 1.0)])
def test_identification_equals_the_python_oracle(lam: float, prior_weight: float) -> None:
    rng = np.random.default_rng(1)
    S0 = np.diag([4e-2, 4e-2, 4e-2, 2.5e-3, 2.5e-3, 2.5e-3])
    w0 = rng.standard_normal(6) * 1e-2
    s = ctl.IdentifierSettings()
    s.lambda_, s.w0, s.S0, s.prior_weight = lam, w0, S0, prior_weight
    cpp = ctl.ForgettingFactorIdentifier(s)
    py = ForgettingFactorIdentifier(lam, w0, S0, prior_weight=prior_weight)
    for k in range(200):
        w = rng.standard_normal(6) * np.sqrt(np.diag(S0)) * (0.1 if k < 100 else 2.0)
        cpp.update(w)
        py.update(w)
        np.testing.assert_allclose(cpp.w_hat, py.w_hat, rtol=1e-12, atol=1e-14 * np.sqrt(S0.max()))
        scale = np.abs(py.S_hat).max()
        np.testing.assert_allclose(cpp.S_hat, py.S_hat, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(cpp.P_W, py.P_W, rtol=0, atol=1e-12 * 9 * scale)
    assert cpp.zeta == pytest.approx(py.zeta, rel=1e-14)


def _subsystems() -> list[tuple[np.ndarray, np.ndarray, float, np.ndarray]]:
    """Translational (with a gravity-gradient-like coupling) and rotational subsystems of the paper's size
    over dt = 2 s: (A, B, u_max, prior P_W)."""
    dt = 2.0
    out = []
    for gain, u_max, sig in ((1.0, 0.55, np.r_[[0.6] * 3, [0.15] * 3]), (1.0 / 2750, 3.0, np.r_[[3e-3] * 3, [3e-4] * 3])):
        Ac = np.zeros((6, 6))
        Ac[:3, 3:] = np.eye(3)
        if gain == 1.0:
            Ac[3:, :3] = np.diag([2e-7, -1e-7, -1e-7])
            Ac[3:, 3:] = np.array([[0, 2.8e-4, 0], [-2.8e-4, 0, 0], [0, 0, 0]])
        Bc = np.zeros((6, 3))
        Bc[3:] = gain * np.eye(3)
        M = scipy.linalg.expm(np.block([[Ac, Bc], [np.zeros((3, 9))]]) * dt)
        out.append((M[:6, :6], M[:6, 6:], u_max, np.diag(sig**2)))
    return out


def test_lyapunov_update_equals_the_python_oracle() -> None:
    rng = np.random.default_rng(2)
    for A, B, u_max, P0 in _subsystems():
        des = TubeDesigner(Q=np.linalg.inv(P0), R=np.eye(3) / u_max**2, u_max=u_max, max_solves=3)
        design = des.design(A, B, P0)
        assert design.feasible and design.K is not None
        for _ in range(10):
            P_W = _spd(rng, 6, np.sqrt(np.diag(P0)) * rng.uniform(0.3, 2.0))
            py, reason = lyapunov_tube(A, B, design, P_W, u_max)
            status, cpp = ctl.lyapunov_tube(A, B, design.K, design.alpha, P_W, u_max)
            assert (py is None) == (status != ctl.Certification.Certified), (reason, status)
            if py is not None and py.Pe is not None:
                np.testing.assert_allclose(cpp.Pe, py.Pe, rtol=0, atol=1e-12 * np.abs(py.Pe).max())
                assert cpp.residual <= 0.0
            assert ctl.lmi_residual(A, B, design.K, design.Pe, P0, design.alpha) == pytest.approx(
                lmi_residual(A, B, design.K, design.Pe, P0, design.alpha), abs=1e-12
            )


def _worst_invariance(Acl: np.ndarray, Pe: np.ndarray, P_W: np.ndarray, rng: np.random.Generator) -> float:
    """max over e in the tube, w in W of (Acl e + w)^T Pe^-1 (Acl e + w) = max over unit v of
    (|F^T v| + |G^T v|)^2 with F = Pe^-1/2 Acl Pe^1/2, G = Pe^-1/2 P_W^1/2: sampled, then refined."""
    Li = np.linalg.inv(np.linalg.cholesky(Pe))
    F = Li @ Acl @ np.linalg.cholesky(Pe)
    G = Li @ np.linalg.cholesky(P_W)

    def h(v: np.ndarray) -> float:
        u = v / np.linalg.norm(v)
        return float((np.linalg.norm(F.T @ u) + np.linalg.norm(G.T @ u)) ** 2)

    V = rng.standard_normal((4000, 6))
    best = V[np.argmax([h(v) for v in V])]
    res = minimize(lambda v: -h(v), best, method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 4000})
    return max(h(best), -float(res.fun))


def test_every_certified_design_is_invariant_in_its_worst_direction() -> None:
    """48 LMI designs (both subsystems, disturbance sets of many shapes and sizes, with and without a
    margin): each one accepted is certified exactly (recomputed residual <= 0, non-empty tightening),
    and the worst successor found by an independent search stays inside its tube."""
    rng = np.random.default_rng(3)
    checked = 0
    for A, B, u_max, P0 in _subsystems():
        des = TubeDesigner(Q=np.linalg.inv(P0), R=np.eye(3) / u_max**2, u_max=u_max, max_solves=3)
        for i in range(24):
            P_W = _spd(rng, 6, np.sqrt(np.diag(P0)) * 10 ** rng.uniform(-1.5, 0.3)) * (1.2 if i % 2 else 1.0)
            res = des.design(A, B, P_W, None if i % 3 else 0.9)
            if not res.feasible:
                assert res.status in (DesignStatus.INFEASIBLE, DesignStatus.INVALID, DesignStatus.SOLVER_ERROR)
                continue
            assert res.K is not None and res.Pe is not None
            assert res.lmi_residual <= 0.0 and lmi_residual(A, B, res.K, res.Pe, P_W, res.alpha) <= 0.0
            assert np.all(np.sqrt(np.einsum("ij,jk,ik->i", res.K, res.Pe, res.K)) < u_max)
            assert _worst_invariance(A + B @ res.K, res.Pe, P_W, rng) <= 1.0 + 1e-12
            checked += 1
    assert checked >= 40


def test_statuses_name_their_certification() -> None:
    certified = {str(s) for s in ctl.TubeStatus.__members__.values() if ctl.certified(s)}
    assert certified == {"initial", "lyapunov", "lyapunov_no_margin", "library", "library_no_margin"}
    assert str(ctl.TubeStatus.Uncertified) == "uncertified" and str(ctl.Method.Ffa) == "ffa"


@pytest.mark.parametrize(
    "cls",
    [
        _core.mpc.Settings,
        _core.control.IdentifierSettings,
        _core.dynamics.PropagatorSettings,
        _core.control.TubePolicySettings,
    ],
)
def test_field_tables_bind_every_attribute_once(cls: type) -> None:
    names = cls.field_names()
    assert len(names) == len(set(names))
    assert set(names) == {n for n in dir(cls) if isinstance(getattr(cls, n), property)}
    if cls is _core.control.IdentifierSettings:
        assert "lambda_" in names  # the C++ field `lambda`, a Python keyword
