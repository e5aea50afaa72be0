"""Forgetting-factor identification (paper Eq. 26-29; docs/model.md "Disturbance identification")."""

import itertools
import math

import numpy as np
import pytest

from tubempc.testing.identification import (
    ForgettingFactorIdentifier,
    measured_reference_deviation,
    measured_residual,
    zeta_closed_form,
)


def test_three_steps_by_hand_with_prior() -> None:
    # Scalar case, lam = 0.9, prior w^_0 = 0.5, S^_0 = 2, prior weight zeta(0) = 1.
    q = math.exp(0.9 - 1.0)
    ident = ForgettingFactorIdentifier(0.9, [0.5], [[2.0]])
    # k = 0, w_0 = 1.0
    z1 = q * (1.0 + 1.0)
    w1 = q / z1 * (1.0 * 0.5 + 1.0)  # = 0.75
    s1 = q / z1 * (1.0 * 2.0 + (1.0 - w1) ** 2)  # = (2 + 0.0625) / 2
    w, S = ident.update([1.0])
    assert w1 == pytest.approx(0.75) and s1 == pytest.approx(1.03125)
    assert w[0] == pytest.approx(w1, rel=1e-14) and S[0, 0] == pytest.approx(s1, rel=1e-14)
    # k = 1, w_1 = -2.0
    z2 = q * (z1 + 1.0)
    w2 = q / z2 * (z1 * w1 + (-2.0))
    s2 = q / z2 * (z1 * s1 + (-2.0 - w2) ** 2)
    w, S = ident.update([-2.0])
    assert w[0] == pytest.approx(w2, rel=1e-14) and S[0, 0] == pytest.approx(s2, rel=1e-14)
    # k = 2, w_2 = 4.0
    z3 = q * (z2 + 1.0)
    w3 = q / z3 * (z2 * w2 + 4.0)
    s3 = q / z3 * (z2 * s2 + (4.0 - w3) ** 2)
    w, S = ident.update([4.0])
    assert w[0] == pytest.approx(w3, rel=1e-14) and S[0, 0] == pytest.approx(s3, rel=1e-14)
    assert ident.zeta == pytest.approx(z3, rel=1e-14)
    assert ident.P_W[0, 0] == pytest.approx(9.0 * s3, rel=1e-14)


def test_three_steps_literal_recursion_forgets_the_prior() -> None:
    # prior_weight = 0 is the paper's literal recursion: zeta(1) = q, w^_1 = w_0, S^_1 = 0.
    q = math.exp(0.95 - 1.0)
    a, b, c = np.array([1.0, -1.0]), np.array([3.0, 1.0]), np.array([0.0, 2.0])
    ident = ForgettingFactorIdentifier(0.95, [7.0, 7.0], np.diag([1.0, 4.0]), prior_weight=0.0)
    w, S = ident.update(a)
    np.testing.assert_allclose(w, a, rtol=1e-15)
    # S^_1 = 0 exactly; the returned matrix is floored at 1e-6 of the prior's variances.
    np.testing.assert_allclose(S, np.diag([1e-6, 4e-6]), rtol=1e-9)
    w, S = ident.update(b)
    w2 = (q * a + b) / (1.0 + q)  # q / (q (q + 1)) (q w^_1 + w_1)
    d = b - w2
    S2 = np.array([[d[0] * d[0], d[0] * d[1]], [d[1] * d[0], d[1] * d[1]]]) / (1.0 + q)
    np.testing.assert_allclose(w, w2, rtol=1e-14)
    assert np.linalg.matrix_rank(S2) == 1  # singular: the floor lifts the null direction
    assert np.all(np.linalg.eigvalsh(S) > 0.0)
    w, S = ident.update(c)
    z2, z3 = q * (q + 1.0), q * (q * (q + 1.0) + 1.0)
    w3 = q / z3 * (z2 * w2 + c)
    d3 = c - w3
    S3 = q / z3 * (z2 * S2 + np.outer(d3, d3))
    np.testing.assert_allclose(w, w3, rtol=1e-14)
    np.testing.assert_allclose(S, S3, rtol=1e-12)
    np.testing.assert_allclose(S, S.T, rtol=0, atol=0)


@pytest.mark.parametrize("lam", [0.95, 0.96, 0.98, 0.5])
def test_zeta_recursion_matches_closed_form(lam: float) -> None:
    q = math.exp(lam - 1.0)
    ident = ForgettingFactorIdentifier(lam, [0.0], [[1.0]], prior_weight=0.0)
    for k in range(1, 60):
        ident.update([0.1 * k])
        explicit = sum(q ** (k - i) for i in range(k))  # sum_{i=0..k-1} q^(k-i)
        paper = q * (1.0 - q**k) / (1.0 - q)  # paper Eq. (27)
        assert ident.zeta == pytest.approx(explicit, rel=1e-12)
        assert zeta_closed_form(lam, k) == pytest.approx(paper, rel=1e-12)
        assert ident.zeta == pytest.approx(paper, rel=1e-12)
    with_prior = ForgettingFactorIdentifier(lam, [0.0], [[1.0]], prior_weight=2.5)
    for _ in range(7):
        with_prior.update([1.0])
    assert with_prior.zeta == pytest.approx(q**7 * 2.5 + q * (1 - q**7) / (1 - q), rel=1e-12)
    assert zeta_closed_form(lam, 7, 2.5) == pytest.approx(with_prior.zeta, rel=1e-12)


def test_constant_input_mean_converges_and_covariance_shrinks() -> None:
    S0 = np.diag([4e-2, 4e-2, 4e-2, 2.5e-3, 2.5e-3, 2.5e-3])
    ident = ForgettingFactorIdentifier(0.96, np.zeros(6), S0)
    w_const = np.array([0.1, -0.2, 0.05, 1e-3, 0.0, -2e-3])
    traces = [np.trace(ident.S_hat)]
    for _ in range(400):
        w, S = ident.update(w_const)
        traces.append(np.trace(S))
    np.testing.assert_allclose(w, w_const, rtol=1e-6, atol=1e-12)
    assert all(t1 <= t0 * (1 + 1e-12) for t0, t1 in itertools.pairwise(traces[5:]))
    assert traces[-1] < 1e-4 * traces[0]
    # The eigenvalue floor keeps S^ positive definite.
    assert np.linalg.eigvalsh(ident.S_hat).min() >= 0.999e-6 * 2.5e-3


@pytest.mark.parametrize("bad", [[np.nan, 0.0], [0.0, np.inf], [-np.inf, 1.0]])
def test_non_finite_input_raises(bad: list[float]) -> None:
    ident = ForgettingFactorIdentifier(0.96, [0.0, 0.0], np.eye(2))
    with pytest.raises(ValueError, match="non-finite"):
        ident.update(bad)
    assert ident.k == 0


def test_invalid_arguments_raise() -> None:
    with pytest.raises(ValueError, match="shape"):
        ForgettingFactorIdentifier(0.96, [0.0, 0.0], np.eye(2)).update([1.0, 2.0, 3.0])
    for lam in (0.0, 1.0, 1.5, math.nan):
        with pytest.raises(ValueError, match="lam"):
            ForgettingFactorIdentifier(lam, [0.0], [[1.0]])
    with pytest.raises(ValueError, match="positive definite"):
        ForgettingFactorIdentifier(0.9, [0.0, 0.0], np.diag([1.0, 0.0]))


def test_measured_input_definitions() -> None:
    A = np.array([[1.0, 2.0], [0.0, 1.0]])
    B = np.array([[2.0], [2.0]])
    c = np.array([0.5, -0.5])
    x, u, x_next = np.array([1.0, 1.0]), np.array([0.25]), np.array([4.0, 1.0])
    # A x + B u + c = [3 + 0.5 + 0.5, 1 + 0.5 - 0.5] = [4, 1]
    np.testing.assert_allclose(measured_residual(x_next + 0.1, A, B, c, x, u), [0.1, 0.1])
    np.testing.assert_allclose(measured_reference_deviation(x_next, [3.0, 3.0]), [1.0, -2.0])
    with pytest.raises(ValueError, match="non-finite"):
        measured_reference_deviation([np.nan, 0.0], [0.0, 0.0])


@pytest.mark.parametrize(("lam_p", "lam_r"), [(0.96, 0.98), (0.98, 0.995), (0.5, 0.8)])
def test_a_prior_worth_one_memory_is_forgotten_at_the_forgetting_rate(lam_p: float, lam_r: float) -> None:
    # prior_memory = 1: zeta(0) = q / (1 - q) stays constant, so with inputs at the prior mean the
    # estimate is exactly the prior decayed by q^k = e^((lam - 1) k), the rate of every measurement.
    from tubempc.config import load_config
    from tubempc.design.library import memory_weight
    from tubempc.testing.identification import identifiers

    cfg = load_config()
    assert cfg.identification.prior_memory == 1.0
    for ident, lam, S0 in zip(
        identifiers(cfg, lam_p, lam_r), (lam_p, lam_r), (cfg.identification.S0_p, cfg.identification.S0_r), strict=True
    ):
        q = math.exp(lam - 1.0)
        assert ident.zeta == pytest.approx(memory_weight(lam), rel=1e-15) == pytest.approx(q / (1 - q))
        for k in range(1, 40):
            ident.update(np.zeros(6))
            assert ident.zeta == pytest.approx(q / (1 - q), rel=1e-12)
            np.testing.assert_allclose(ident.S_hat, max(q**k, 1e-6) * S0, rtol=1e-9)
    literal = identifiers(cfg.with_overrides({"identification.prior_memory": 0.0}))
    assert literal[0].zeta == 0.0 and literal[1].zeta == 0.0
