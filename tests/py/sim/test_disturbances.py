"""Seeded disturbance models (paper Eq. 18; docs/model.md "Simulated disturbance and truth")."""

import json
import math

import numpy as np
import pytest

from tubempc.models.disturbances import (
    ActuatorMismatch,
    AdditiveDisturbance,
    EllipsoidDisturbance,
    sample_ellipsoid,
    sample_ellipsoid_surface,
)


def _badly_scaled_cov() -> np.ndarray:
    rng = np.random.default_rng(42)
    Q, _ = np.linalg.qr(rng.standard_normal((6, 6)))
    D = np.diag([1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6])
    return D @ Q @ np.diag([1.0, 2.0, 3.0, 0.5, 0.2, 1.5]) @ Q.T @ D


def _mahalanobis2(S: np.ndarray, w: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", w, np.linalg.solve(S, w.T).T)


def test_samples_lie_in_the_ellipsoid() -> None:
    S = _badly_scaled_cov()
    w = sample_ellipsoid(S, 20000, np.random.default_rng(1))
    m = _mahalanobis2(S, w)
    assert m.max() <= 1.0 + 1e-9
    assert m.max() > 0.99  # and reach its boundary
    on = _mahalanobis2(S, sample_ellipsoid_surface(S, 1000, np.random.default_rng(2)))
    np.testing.assert_allclose(on, 1.0, rtol=1e-8)


@pytest.mark.parametrize("dim", [3, 6])
def test_samples_are_uniform(dim: int) -> None:
    S = _badly_scaled_cov()[:dim, :dim]
    n = 200_000
    m = _mahalanobis2(S, sample_ellipsoid(S, n, np.random.default_rng(3)))
    for rho in (0.5, 0.8, 0.95):
        p = rho**dim  # volume fraction of the ellipsoid scaled by rho
        frac = float(np.mean(m <= rho**2))
        assert abs(frac - p) < 5.0 * math.sqrt(p * (1.0 - p) / n), (rho, frac, p)
    # Uniform directions: the mean of a symmetric set is ~0 in whitened coordinates.
    w = sample_ellipsoid(S, n, np.random.default_rng(4))
    white = np.linalg.solve(np.linalg.cholesky(S), w.T).T
    assert np.abs(white.mean(axis=0)).max() < 5.0 / math.sqrt(n)


def test_reproducible_under_seed() -> None:
    S = np.diag([4e-2, 4e-2, 4e-2, 2.5e-3, 2.5e-3, 2.5e-3])
    a, b, c = (
        EllipsoidDisturbance(S, 7),
        EllipsoidDisturbance(S, 7),
        EllipsoidDisturbance(S, 8),
    )
    xa, xb, xc = a.sample(50), b.sample(50), c.sample(50)
    np.testing.assert_array_equal(xa, xb)
    assert not np.allclose(xa, xc)
    assert a.sample().shape == (6,)
    center = np.full(6, 0.01)
    shifted = EllipsoidDisturbance(S, 7, center=center).sample(50)
    np.testing.assert_allclose(shifted - center, xa, rtol=1e-12, atol=1e-15)


def test_additive_disturbance_process() -> None:
    S_p = np.diag([4e-2] * 3 + [2.5e-3] * 3)
    S_r = [1e-6] * 3 + [1e-8] * 3
    d1, d2, d3 = (AdditiveDisturbance(S_p, S_r, seed=s) for s in (11, 11, 12))
    seq1 = [np.concatenate(d1.sample()) for _ in range(100)]
    seq2 = [np.concatenate(d2.sample()) for _ in range(100)]
    seq3 = [np.concatenate(d3.sample()) for _ in range(100)]
    np.testing.assert_array_equal(seq1, seq2)
    assert not np.allclose(seq1, seq3)
    w_p = np.array([s[:6] for s in seq1])
    w_r = np.array([s[6:] for s in seq1])
    assert _mahalanobis2(S_p, w_p).max() <= 1.0 + 1e-9
    assert _mahalanobis2(np.diag(S_r), w_r).max() <= 1.0 + 1e-9
    desc = json.loads(json.dumps(d1.describe()))
    assert desc["seed"] == 11 and desc["model"] == "additive_ellipsoid_uniform"
    assert np.allclose(desc["S_r"], np.diag(S_r))
    with pytest.raises(ValueError, match="S_p"):
        AdditiveDisturbance(np.eye(5), S_r, seed=0)


def test_actuator_mismatch() -> None:
    ideal = ActuatorMismatch(seed=3)
    u = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(ideal.apply_acceleration(u), u, rtol=1e-15)
    np.testing.assert_allclose(ideal.apply_torque(u), u, rtol=1e-15)
    kw = {"scale_error_p": 0.05, "misalignment_p": math.radians(1.0)}
    kw |= {"scale_error_r": 0.02, "misalignment_r": math.radians(0.5)}
    a, b, c = (
        ActuatorMismatch(5, **kw),
        ActuatorMismatch(5, **kw),
        ActuatorMismatch(6, **kw),
    )
    np.testing.assert_array_equal(a.M_p, b.M_p)
    assert not np.allclose(a.M_p, c.M_p)
    for M, s_max, ang_max in (
        (a.M_p, 0.05, math.radians(1.0)),
        (a.M_r, 0.02, math.radians(0.5)),
    ):
        sv = np.linalg.svd(M, compute_uv=False)
        assert sv.max() <= 1.0 + s_max and sv.min() >= 1.0 - s_max
        # Misalignment: the rotation part R = M diag(scale)^-1 turns by at most ang_max.
        tag = "p" if M is a.M_p else "r"
        R = M @ np.diag(1.0 / np.array(a.describe()[f"scale_{tag}"]))
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0)))
        assert angle <= ang_max + 1e-12
    assert json.loads(json.dumps(a.describe()))["seed"] == 5
    with pytest.raises(ValueError, match="scale_error_p"):
        ActuatorMismatch(0, scale_error_p=1.5)


def test_growing_disturbance_scales_the_same_draws_linearly_in_time() -> None:
    S_p = np.diag([4e-2] * 3 + [2.5e-3] * 3)
    S_r = np.diag([9e-6] * 3 + [9e-8] * 3)
    n = 301
    fixed = AdditiveDisturbance(S_p, S_r, seed=4)
    grown = AdditiveDisturbance(S_p, S_r, seed=4, growth_p=0.5, growth_r=2.5, n_steps=n)
    assert grown.scale(0) == (1.0, 1.0) and grown.scale(n - 1) == (0.5, 2.5)
    assert grown.scale(150) == pytest.approx((0.75, 1.75)) and grown.scale(10_000) == (0.5, 2.5)
    for k in range(n):
        (a_p, a_r), (b_p, b_r) = fixed.sample(k), grown.sample(k)
        s_p, s_r = 1.0 - 0.5 * k / (n - 1), 1.0 + 1.5 * k / (n - 1)
        np.testing.assert_allclose(b_p, s_p * a_p, rtol=1e-15)
        np.testing.assert_allclose(b_r, s_r * a_r, rtol=1e-15)
    # The last steps' attitude inputs lie in the 2.5x ellipsoid, and most leave the 1x one.
    late = np.array([grown.sample(n - 1)[1] for _ in range(200)])
    m2 = _mahalanobis2(S_r, late)
    assert m2.max() <= 2.5**2 + 1e-9 and np.mean(m2 > 1.0) > 0.9
    assert json.loads(json.dumps(grown.describe()))["growth_r"] == 2.5
    with pytest.raises(ValueError, match="growth_r"):
        AdditiveDisturbance(S_p, S_r, seed=0, growth_r=float("nan"))
