"""Metrics against hand-computed values on a small synthetic trajectory; the convergence fit."""

from __future__ import annotations

import numpy as np
import pytest

from tubempc.analysis import metrics


def _trajectory() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # T = 2 steps: x has 3 rows, u has 2 rows.
    zbar = np.zeros((3, 12))
    x = np.zeros((3, 12))
    x[0, 0] = 1.0  # position error 1 m at k = 0
    x[1, 4] = 2.0  # velocity error 2 m/s at k = 1
    x[2, 2] = 3.0  # position error 3 m at k = T (terminal, not in J)
    x[1, 6] = 0.5  # attitude error 0.5 rad at k = 1
    u = np.zeros((2, 6))
    u[0, :3] = [3.0, 4.0, 0.0]  # |u_p| = 5
    u[1, 3:] = [0.0, 0.0, 2.0]  # |T| = 2
    return x, zbar, u


def test_performance_indices_by_hand() -> None:
    x, zbar, u = _trajectory()
    # J_p = 1^2 + 2^2 (states k = 0, 1) + 5^2 (input k = 0) = 30
    assert metrics.performance_index(x, zbar, u, "translation") == pytest.approx(30.0)
    # J_r = 0.5^2 + 2^2 = 4.25
    assert metrics.performance_index(x, zbar, u, "rotation") == pytest.approx(4.25)
    # weights scale each term
    assert metrics.performance_index(x, zbar, u, "translation", Q=2 * np.eye(6), R=np.eye(3)) == pytest.approx(35.0)


def test_effort_terminal_and_rms_by_hand() -> None:
    x, zbar, u = _trajectory()
    eff = metrics.control_effort(u, dt=2.0)
    assert eff == pytest.approx({"translation": 5.0, "rotation": 2.0, "delta_v": 10.0})
    term = metrics.terminal_error(x, np.zeros(12))
    assert term["position"] == pytest.approx(3.0) and term["velocity"] == 0.0
    rms = metrics.rms_error(x, zbar)
    assert rms["position"] == pytest.approx(np.sqrt((1.0 + 9.0) / 3))
    assert rms["velocity"] == pytest.approx(np.sqrt(4.0 / 3))
    assert rms["attitude"] == pytest.approx(np.sqrt(0.25 / 3))


def test_tube_excursion() -> None:
    Pe = np.diag([4.0, 1.0])
    e = np.array([[2.0, 0.0], [0.0, 0.5], [1.0, 1.0]])
    np.testing.assert_allclose(metrics.tube_excursion(e, np.zeros_like(e), Pe), [1.0, 0.25, 1.25])


def test_bad_input_is_rejected() -> None:
    x, zbar, u = _trajectory()
    x[1, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        metrics.performance_index(x, zbar, u, "translation")
    with pytest.raises(ValueError, match=r"\(T, 6\)"):
        metrics.performance_index(zbar, zbar, u[:1], "translation")


@pytest.mark.parametrize(("C", "rho"), [(1.0, 0.9), (2.5, 0.97), (0.8, 0.6)])
def test_convergence_fit_recovers_known_envelope(C: float, rho: float) -> None:
    rng = np.random.default_rng(5)
    k = np.arange(300)
    e0, ebar = 4.0, 1e-3
    errors = C * rho**k * e0 + ebar * rng.uniform(0.0, 1.0, size=k.size)
    errors[0] = e0 * C + ebar * 0.5
    fit = metrics.fit_exponential_convergence(errors, ebar=ebar)
    assert fit.rho == pytest.approx(rho, rel=2e-3)
    assert fit.C * fit.e0 == pytest.approx(C * e0, rel=1e-2)
    assert np.all(errors <= fit.bound(k) * (1 + 1e-12))
