"""Python side of the proximity dynamics: discretisation against scipy, horizon, pickling, config,
propagation and constraint bindings."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

import tubempc
import tubempc.models.mpc
from tubempc import PointMassGravity, ProximityModel

GM_BENNU = 5.236
X0 = np.array([959.2404, 162.4966, 752.7547, 7.7649e-4, 0.0844, -0.0192, 0.3142, 2.925, 0.3142, 1e-3, 0.0, 3e-3])
XF = np.array([0, 0, 246.5, 0, 0, 0, 0, 3.1416, 0, 0, 0, 0], dtype=float)


def _fast(kinematics: str) -> dict[str, object]:
    # Fast frame rates so that every block of A is sizeable.
    return {"orbit_radius": 5e7, "spin_rate": 0.05, "kinematics": kinematics, "beta_srp": 1e12}


def _random_points(n: int, seed: int) -> list[tuple[float, np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d = rng.normal(size=3)
        x = np.concatenate(
            [
                (250 + 1000 * rng.uniform()) * d / np.linalg.norm(d),
                0.05 * rng.normal(size=3),
                rng.normal(size=3) * 0.9,
                0.02 * rng.normal(size=3),
            ]
        )
        u = np.concatenate([1e-3 * rng.normal(size=3), 0.5 * rng.normal(size=3)])
        out.append((float(rng.uniform(0, 1e4)), x, u))
    return out


def _augmented(model: ProximityModel, t: float, x: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
    f, A, B = model.linearize(t, x, u)
    c = f - A @ x - B @ u
    M = np.zeros((19, 19))
    M[:12, :12] = A
    M[:12, 12:18] = B
    M[:12, 18] = c
    return M * dt


@pytest.mark.parametrize("kinematics", ["first_order", "exact"])
@pytest.mark.parametrize("dt", [2.0, 60.0])
def test_discretisation_matches_scipy_expm(kinematics: str, dt: float) -> None:
    model = ProximityModel(PointMassGravity(GM_BENNU), _fast(kinematics))
    for t, x, u in _random_points(8, seed=1):
        E = expm(_augmented(model, t, x, u, dt))
        Ad, Bd, cd = model.discretize(t, x, u, dt)
        np.testing.assert_allclose(Ad, E[:12, :12], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(Bd, E[:12, 12:18], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(cd, E[:12, 18], rtol=1e-12, atol=1e-12)


def test_discretisation_matches_fine_integration_of_the_affine_system() -> None:
    model = ProximityModel(PointMassGravity(GM_BENNU), _fast("exact"))
    dt = 2.0
    for t, x, u in _random_points(3, seed=2):
        f, A, B = model.linearize(t, x, u)
        c = f - A @ x - B @ u
        Ad, Bd, cd = model.discretize(t, x, u, dt)
        rng = np.random.default_rng(3)
        for _ in range(3):
            z0 = x + rng.normal(size=12) * np.repeat([10.0, 0.01, 0.1, 0.01], 3)
            v = u + rng.normal(size=6) * 1e-3

            def rhs(_s: float, z: np.ndarray, A=A, B=B, c=c, v=v) -> np.ndarray:
                return A @ z + B @ v + c

            sol = solve_ivp(rhs, (0.0, dt), z0, method="DOP853", rtol=1e-13, atol=1e-14)
            np.testing.assert_allclose(Ad @ z0 + Bd @ v + cd, sol.y[:, -1], rtol=1e-9, atol=1e-9)
        # The affine model reproduces the nonlinear flow to first order: at (x, u) itself the
        # one-step error is O(dt^2 |df/dx| |f|), far below |f| dt.
        truth = model.propagate(t, model.state_to_truth(x), u, dt, "dopri", rtol=1e-12, atol=1e-12)
        x_next = model.truth_to_state(truth.state, x[6:9])
        assert np.linalg.norm(Ad @ x + Bd @ u + cd - x_next) < 1e-3 * np.linalg.norm(f) * dt


def test_horizon_equals_node_by_node_calls() -> None:
    model = ProximityModel(PointMassGravity(GM_BENNU), {"kinematics": "exact"})
    pts = _random_points(5, seed=4)
    X = np.array([p[1] for p in pts])
    U = np.array([p[2] for p in pts])
    A, B, c = model.discretize(100.0, X, U, 2.0)
    assert A.shape == (5, 12, 12) and B.shape == (5, 12, 6) and c.shape == (5, 12)
    for k in range(5):
        Ak, Bk, ck = model.discretize(100.0 + 2.0 * k, X[k], U[k], 2.0)
        np.testing.assert_array_equal(A[k], Ak)
        np.testing.assert_array_equal(B[k], Bk)
        np.testing.assert_array_equal(c[k], ck)
    with pytest.raises(ValueError, match="x_ref must be"):
        model.discretize(0.0, X[:, :11], U, 2.0)
    X[2, 0] = np.nan
    with pytest.raises(ValueError, match="node 2"):
        model.discretize(0.0, X, U, 2.0)


def test_jacobians_match_finite_differences() -> None:
    for kin in ("first_order", "exact"):
        model = ProximityModel(PointMassGravity(GM_BENNU), _fast(kin))
        for t, x, u in _random_points(3, seed=5):
            A, B = model.jacobians(t, x, u)
            steps = np.r_[np.full(3, 0.5), np.full(3, 1e-4), np.full(3, 1e-4), np.full(3, 1e-5)]
            for j in range(12):
                e = np.zeros(12)
                e[j] = steps[j]
                fd = (model.f(t, x + e, u) - model.f(t, x - e, u)) / (2 * steps[j])
                np.testing.assert_allclose(fd, A[:, j], rtol=1e-5, atol=1e-9 * np.abs(A).max())
            np.testing.assert_array_equal(B[3:6, :3], np.eye(3))


def test_pickle_round_trip_keeps_gravity_and_params() -> None:
    model = ProximityModel(
        PointMassGravity(GM_BENNU),
        {"kinematics": "exact", "spin_angle0": 0.4, "inertia_B": [2000.0, 2500.0, 3000.0]},
    )
    clone = pickle.loads(pickle.dumps(model))
    assert isinstance(clone.gravity, PointMassGravity)
    assert clone.gravity.gm == GM_BENNU
    assert clone.config() == model.config()
    np.testing.assert_array_equal(clone.f(5.0, X0, np.ones(6)), model.f(5.0, X0, np.ones(6)))


def test_config_validation_names_the_field() -> None:
    g = PointMassGravity(GM_BENNU)
    with pytest.raises(ValueError, match="unknown model parameter 'spin'"):
        ProximityModel(g, {"spin": 1.0})
    with pytest.raises(ValueError, match="orbit_radius"):
        ProximityModel(g, {"orbit_radius": -1.0})
    with pytest.raises(ValueError, match="inertia_B"):
        ProximityModel(g, {"inertia_B": [1.0, -2.0, 3.0]})
    with pytest.raises(ValueError, match="kinematics"):
        ProximityModel(g, {"kinematics": "fast"})
    with pytest.raises(ValueError, match="gm"):
        PointMassGravity(-1.0)
    model = ProximityModel(g)
    assert model.params.kinematics == tubempc.Kinematics.FirstOrder
    assert model.mean_motion == pytest.approx(np.sqrt(1.32712440018e20 / 1.685e11**3), rel=1e-15)
    bad = X0.copy()
    bad[3] = np.inf
    with pytest.raises(ValueError, match=r"x\[3\]"):
        model.f(0.0, bad, np.zeros(6))
    with pytest.raises(ValueError, match="12 elements"):
        model.f(0.0, X0[:11], np.zeros(6))
    with pytest.raises(ValueError, match="position_tolerance"):
        tubempc.models.mpc.LinearizedProximityModel(model.core, position_tolerance=-1e-6)
    assert tubempc.models.mpc.LinearizedProximityModel(model.core).position_tolerance == 0.3


def test_frames_rotate_at_spin_minus_orbital_rate() -> None:
    model = ProximityModel(PointMassGravity(GM_BENNU), {"spin_angle0": 0.2})
    n = model.mean_motion
    omega = 2 * np.pi / (4.296 * 3600)
    for t in (0.0, 1000.0):
        th = 0.2 + (omega - n) * t
        np.testing.assert_allclose(model.C_AL(t) @ [np.cos(th), np.sin(th), 0.0], [1, 0, 0], atol=1e-14)
        np.testing.assert_allclose(tubempc.so3.rotation_matrix(model.q_AL(t)), model.C_AL(t), atol=1e-15)


def test_propagation_api() -> None:
    model = ProximityModel(PointMassGravity(GM_BENNU), _fast("first_order"))
    s0 = model.state_to_truth(X0)
    u = np.r_[1e-4, 0, -1e-4, 0.1, 0, 0.2]
    rk4 = model.propagate(0.0, s0, u, 2.0, "rk4", substeps=50)
    dop = model.propagate(0.0, s0, u, 2.0, "dopri", rtol=1e-12, atol=1e-12)
    assert rk4.status == tubempc.models.dynamics.PropagationStatus.Success and dop.status_name == "success"
    np.testing.assert_allclose(rk4.state, dop.state, rtol=0, atol=1e-10)
    assert abs(np.linalg.norm(dop.state[6:10]) - 1.0) < 1e-15
    w = np.r_[1e-5, 2e-5, 0, 0, 1e-4, 0]
    const = model.propagate(0.0, s0, u, 2.0, "rk4", disturbance=w)
    call = model.propagate(0.0, s0, u, 2.0, "rk4", disturbance=lambda t, s: w)
    np.testing.assert_array_equal(const.state, call.state)
    assert np.abs(const.state - rk4.state).max() > 1e-6
    bad = s0.copy()
    bad[0] = np.nan
    assert model.propagate(0.0, bad, u, 2.0).status == tubempc.models.dynamics.PropagationStatus.NonFinite
    assert model.propagate(0.0, s0, u, 500.0, "dopri", max_steps=2).status_name == "max_steps_reached"
    with pytest.raises(ValueError, match="method"):
        model.propagate(0.0, s0, u, 2.0, "euler")
    with pytest.raises(ZeroDivisionError):
        model.propagate(0.0, s0, u, 2.0, disturbance=lambda t, s: 1 / 0)
    # the scenario's one description of the truth integrator gives the keyword call's numbers, to the bit
    from tubempc.config import load_config
    from tubempc.scenario import propagator_settings

    for integrator, keywords in (("rk4", {"substeps": 3}), ("dopri5", {"rtol": 1e-9})):
        cfg = load_config().with_overrides(
            {"simulation.integrator": integrator, **{f"simulation.{k}": v for k, v in keywords.items()}}
        )
        by_settings = model.propagate(0.0, s0, u, 2.0, settings=propagator_settings(cfg))
        tol = cfg.simulation.gravity_expansion_tolerance
        by_keywords = model.propagate(0.0, s0, u, 2.0, integrator, gravity_expansion_tolerance=tol, **keywords)
        assert by_settings.state.tobytes() == by_keywords.state.tobytes()
    settings = propagator_settings(load_config().with_overrides({"simulation.integrator": "rk4", "simulation.substeps": 1}))
    one_step = model.propagate(0.0, s0, u, 2.0, settings=settings)
    assert one_step.state.tobytes() != model.propagate(0.0, s0, u, 2.0, "rk4", substeps=2).state.tobytes()


def test_truth_state_conversion_and_unwrap() -> None:
    axis = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    x = X0.copy()
    x[6:9] = (np.pi + 0.2) * axis
    s = tubempc.state_to_truth(x)
    np.testing.assert_allclose(tubempc.truth_to_state(s)[6:9], -(np.pi - 0.2) * axis, atol=1e-12)
    np.testing.assert_allclose(tubempc.truth_to_state(s, np.pi * axis), x, atol=1e-12)


def test_constraints_at_the_paper_boundary_states() -> None:
    model = ProximityModel(PointMassGravity(GM_BENNU))
    for x in (X0, XF):
        g_gs, grad_gs = model.glide_slope(x)
        g_los, grad_los = model.line_of_sight(x)
        assert g_gs < 0 and g_los < 0
        G, h = model.constraints(0.0, x)
        np.testing.assert_allclose(G[0], grad_gs)
        np.testing.assert_allclose(G[1], grad_los)
        np.testing.assert_allclose(G @ x - h, [g_gs, g_los], atol=1e-9)
    g, _ = tubempc.glide_slope_constraint(X0)
    r = X0[:3]
    assert g == pytest.approx(np.linalg.norm(r) * np.cos(np.deg2rad(70)) - r[2], rel=1e-14)
    g_y, _ = tubempc.line_of_sight_constraint(XF, boresight_B=[0.0, 1.0, 0.0])
    assert g_y > 0  # the literal +y_B boresight is violated at the terminal attitude
    with pytest.raises(ValueError, match="apex"):
        tubempc.glide_slope_constraint(np.zeros(12))


def test_propagator_settings_field_table() -> None:
    s = tubempc._core.dynamics.PropagatorSettings
    assert s.field_names() == [
        "method",
        "substeps",
        "rtol",
        "atol",
        "max_steps",
        "initial_step",
        "gravity_expansion_tolerance",
    ]
    assert s.substeps.__doc__ == "RK4 steps per call, >= 1"
    assert s.initial_step.__doc__ == "DOPRI5 first step (s); 0: automatic"
    p = s()
    p.substeps = 7
    assert p.substeps == 7
