"""Tube MPC bindings: a Python plant through the trampoline, the exported QP against independent
solvers (cvxpy + Clarabel, PIQP), the DARE against scipy, settings errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from tubempc import LinearizedModel, LtiModel, TubeMPC, _core, solve_qp
from tubempc.models import mpc


class DoubleIntegrator(LinearizedModel):
    """Two decoupled double integrators (x = [p1, p2, v1, v2], u = a) with p1 <= p_max, |v_i| <= v_max."""

    def __init__(self, dt: float, p_max: float, v_max: float) -> None:
        super().__init__()
        I2 = np.eye(2)
        self.A = np.block([[I2, dt * I2], [np.zeros((2, 2)), I2]])
        self.B = np.vstack([0.5 * dt * dt * I2, dt * I2])
        self.G = np.array([[1.0, 0, 0, 0], [0, 0, 1, 0], [0, 0, -1, 0], [0, 0, 0, 1], [0, 0, 0, -1]])
        self.h = np.array([p_max, v_max, v_max, v_max, v_max])
        self.dt = dt

    def nx(self) -> int:
        return 4

    def nu(self) -> int:
        return 2

    def n_constraints(self) -> int:
        return 5

    def discretize(self, t, dt, x_lin, u_lin):
        assert dt == self.dt
        return self.A, self.B, np.zeros(4)

    def constraints(self, t, x_lin):
        return self.G, self.h


def _settings(soft: bool) -> mpc.Settings:
    s = mpc.Settings()
    s.horizon = 12
    s.dt = 0.5
    s.u_max = np.array([0.4, 0.4])
    s.R = np.diag([2.0, 3.0])
    s.time_limit = np.inf
    s.soft_state_constraints = soft
    s.soft_penalty = 50.0
    return s


def _reference(T: int) -> mpc.Reference:
    z = np.zeros((4, T + 1))
    z[0] = np.linspace(0.0, 3.0, T + 1)  # crosses p_max = 1.0 before the end: active constraints
    z[1] = np.linspace(1.0, 0.0, T + 1)
    return mpc.Reference(z, np.zeros((2, T)))


def _tube() -> mpc.Tube:
    K = np.array([[-0.3, 0.0, -0.8, 0.0], [0.0, -0.3, 0.0, -0.8]])
    return mpc.Tube(K, 1e-3 * np.eye(4))


@pytest.mark.parametrize("soft", [False, True])
def test_exported_qp_has_the_same_optimum_with_independent_solvers(soft: bool) -> None:
    plant = DoubleIntegrator(0.5, 1.0, 0.3)
    ctrl = TubeMPC(plant, _settings(soft))
    ctrl.setup(_reference(20))
    r = ctrl.step(0, np.array([0.05, 0.9, 0.25, -0.1]), _tube())
    assert r.status == mpc.Status.Solved, (r.status, r.failure)
    qp = ctrl.qp_data()
    assert qp.P.shape[0] == ctrl.qp_dimensions[0]
    clarabel = solve_qp(qp, "cvxpy-clarabel")
    assert clarabel.status == "optimal"
    assert clarabel.objective == pytest.approx(r.objective, rel=1e-6)
    piqp = solve_qp(qp, "cvxpy-piqp")
    assert piqp.objective == pytest.approx(r.objective, rel=1e-6)
    if not soft:  # the same QP written node by node (the benchmark's "Python user" baseline)
        node = mpc.solve_qp_per_node(qp, 4, 2, plant.n_constraints(), 12)
        assert node.status == "optimal"
        assert node.objective == pytest.approx(r.objective, rel=1e-6)
    else:
        with pytest.raises(ValueError, match="slacks"):
            mpc.solve_qp_per_node(qp, 4, 2, plant.n_constraints(), 12)
    # Same minimiser (the QP is strictly convex in the inputs and states).
    w = ctrl.qp_solution().w
    assert np.max(np.abs(clarabel.w - w)) < 1e-4 * max(1.0, np.max(np.abs(w)))
    # The plan is read from the minimiser: its first block is z_0 - zbar_0.
    np.testing.assert_allclose(r.z[:, 0], w[:4] + _reference(20).z[:, 0], atol=1e-12)
    # Some tightened state constraint is active (else this test would not exercise them).
    Gw = qp.G @ w
    assert np.any(np.isfinite(qp.h_u) & (np.abs(Gw - qp.h_u) < 1e-6))


def test_python_model_matches_the_cpp_model() -> None:
    dt = 0.5
    py_model = DoubleIntegrator(dt, 1.0, 0.3)
    Ac = np.zeros((4, 4))
    Ac[0:2, 2:4] = np.eye(2)
    Bc = np.vstack([np.zeros((2, 2)), np.eye(2)])
    cpp_model = LtiModel(Ac, Bc, np.zeros(4), dt, py_model.G, py_model.h)
    A, B, _ = cpp_model.discretize(0.0, dt, np.zeros(4), np.zeros(2))
    np.testing.assert_allclose(A, py_model.A, atol=1e-13)
    np.testing.assert_allclose(B, py_model.B, atol=1e-13)
    results = []
    for model in (py_model, cpp_model):
        ctrl = TubeMPC(model, _settings(False))
        ctrl.setup(_reference(20))
        x = np.array([0.05, 0.9, 0.25, -0.1])
        plan = []
        for k in range(3):
            r = ctrl.step(k, x, _tube())
            plan.append(r.u)
            x = A @ x + B @ r.u
        results.append(np.array(plan))
    np.testing.assert_allclose(results[0], results[1], atol=1e-8)


def test_python_model_shape_errors_name_the_output() -> None:
    class Bad(DoubleIntegrator):
        def discretize(self, t, dt, x_lin, u_lin):
            return np.eye(3), self.B, np.zeros(4)

    ctrl = TubeMPC(Bad(0.5, 1.0, 0.3), _settings(False))
    with pytest.raises(ValueError, match="discretize: A"):
        ctrl.setup(_reference(20))


def test_settings_errors_name_the_field() -> None:
    s = _settings(False)
    s.u_max = np.array([0.4])
    with pytest.raises(ValueError, match="u_max"):
        TubeMPC(DoubleIntegrator(0.5, 1.0, 0.3), s)
    s = _settings(False)
    s.horizon = 0
    with pytest.raises(ValueError, match="horizon"):
        s.validate(4, 2)


def test_dare_matches_scipy() -> None:
    rng = np.random.default_rng(4)
    for _ in range(10):
        A = 0.7 * rng.normal(size=(5, 5))
        B = rng.normal(size=(5, 2))
        M = rng.normal(size=(5, 5))
        Q = M @ M.T + 0.1 * np.eye(5)
        R = np.diag(rng.uniform(0.5, 2.0, size=2))
        X = mpc.solve_dare(A, B, Q, R)
        X_ref = scipy.linalg.solve_discrete_are(A, B, Q, R)
        np.testing.assert_allclose(X, X_ref, rtol=1e-8, atol=1e-8 * np.max(np.abs(X_ref)))


def test_step_reports_fallback_with_finite_output() -> None:
    ctrl = TubeMPC(DoubleIntegrator(0.5, 1.0, 0.3), _settings(False))
    ctrl.setup(_reference(20))
    tube = _tube()
    ctrl.step(0, np.array([0.05, 0.9, 0.25, -0.1]), tube)
    fat = mpc.Tube(tube.K * 100.0, tube.Pe)  # tightened input box is empty
    r = ctrl.step(1, np.array([0.1, 0.9, 0.25, -0.1]), fat)
    assert r.status == mpc.Status.FallbackShiftedPlan
    assert r.failure == mpc.Status.EmptyTightening
    assert str(r.failure) == "empty_tightening"
    assert np.all(np.isfinite(r.u)) and np.all(np.abs(r.u) <= 0.4)


def test_benchmark_mission_runs_and_agrees_with_the_baseline(tmp_path) -> None:
    """Short run of ``tubempc bench mpc``: every step solved, the C++ QPs satisfy KKT, and the same
    QPs solved through cvxpy's PIQP interface give the same optimum."""
    import argparse
    import json

    from tubempc.benchmarks import mpc as bench

    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    out = tmp_path / "bench.json"
    # The whole 600 s mission: shorter ones make the reference exceed the input limits.
    args = parser.parse_args(
        ["--plant", "stand-in", "--qp-samples", "3", "--solvers", "cvxpy-piqp", "--repeats", "2", "--json", str(out)]
    )
    assert bench.run(args) == 0  # the repeated flight must end in the same state, or run raises
    data = json.loads(out.read_text())
    assert data["statuses"] == {"solved": 300}
    assert len(data["runs"]) == 2 and all(r["total"]["p99"] >= r["total"]["median"] > 0.0 for r in data["runs"])
    assert data["cpp_max_kkt_residual"] < 1e-8
    assert data["cpp_max_violation"] < 1e-8
    assert data["baseline"]["cvxpy-piqp"]["median_abs_rel_objective_diff"] < 1e-6


class CountingDoubleIntegrator(DoubleIntegrator):
    """The double integrator, counting discretize calls and recording each call's node time."""

    def __init__(self, dt: float, p_max: float, v_max: float) -> None:
        super().__init__(dt, p_max, v_max)
        self.times: list[float] = []

    def discretize(self, t, dt, x_lin, u_lin):
        self.times.append(t)
        return super().discretize(t, dt, x_lin, u_lin)


def test_reused_linearization_calls_the_model_less_with_identical_plans() -> None:
    """A linear plant's model data do not depend on the linearisation point: with and without re-use the
    QPs, hence the plans and SCP iterations, are identical, while a re-using step's first iteration calls
    the model only at the appended node (time (k + N - 1) dt; none in the shrinking phase; at k = 0 too:
    setup linearised about the reference) and later iterations only where the plan moved by scp_eps or more."""
    dt, T = 0.5, 20
    plans, evals, times = [], [], []
    for reuse in (True, False):
        model = CountingDoubleIntegrator(dt, 1.0, 0.3)
        s = _settings(False)
        s.linearization = mpc.Linearization.Reuse if reuse else mpc.Linearization.EveryIteration
        ctrl = TubeMPC(model, s)
        ctrl.setup(_reference(T))
        model.times.clear()
        x = np.array([0.05, 0.9, 0.25, -0.1])
        zs, ev, ts = [], [], []
        for k in range(T):
            before = len(model.times)
            r = ctrl.step(k, x, _tube())
            assert r.status == mpc.Status.Solved
            assert r.model_evaluations == len(model.times) - before
            zs.append(r.z.copy())
            ev.append((r.model_evaluations, r.horizon, r.scp_iterations))
            ts.append(model.times[before:])
            x = model.A @ x + model.B @ r.u
        plans.append(np.array(zs))
        evals.append(ev)
        times.append(ts)
    np.testing.assert_array_equal(plans[0], plans[1])
    N = _settings(False).horizon
    for k, ((e_re, n, it_re), (e_fr, _, it_fr)) in enumerate(zip(evals[0], evals[1], strict=True)):
        assert it_re == it_fr
        appended = [(k + N - 1) * dt] if n == N else []
        assert e_fr in (n * it_fr, n * (it_fr + 1))  # + 1: the linear plant's exit (same model data)
        assert e_re <= e_fr - n + len(appended)
        assert times[0][k][: len(appended)] == appended
    assert sum(e for e, _, _ in evals[0]) < 0.6 * sum(e for e, _, _ in evals[1])


def test_shrinking_phase_qps_have_clarabels_optimum() -> None:
    """Every QP of the default mission's shrinking phase (the last N steps: padded nodes, the soft
    terminal penalty, multipliers up to ~1e6) against Clarabel at 1e-10: the objectives agree to 1e-6
    relative. Before the active set judged its constraint rows on their own scale, 7 of them differed
    by up to 1.4e-5 (a violation of ~1e-9 times multipliers of ~5e5)."""
    from tubempc.benchmarks.mpc import bennu_plant, run_mission

    model, settings, reference, tube, truth = bennu_plant(0)
    T, N = reference.z.shape[1] - 1, settings.horizon
    _, qps = run_mission(model, settings, reference, tube, truth, set(range(T - N, T)))
    assert len(qps) >= N - 2  # every solved step of the phase
    worst = 0.0
    for qp, _, objective, _ in qps.values():
        clarabel = solve_qp(qp, "cvxpy-clarabel", 1e-10)
        assert clarabel.status == "optimal"
        worst = max(worst, abs(objective - clarabel.objective) / max(1.0, abs(clarabel.objective)))
    assert worst < 1e-6


@pytest.mark.parametrize(
    "enum",
    [
        mpc.InitialCondition,
        mpc.InputCost,
        mpc.QpSolver,
        mpc.Linearization,
        mpc.ScpMode,
        mpc.KktSolver,
        _core.dynamics.Kinematics,
        _core.dynamics.Integrator,
        _core.control.MeasuredInput,
    ],
)
def test_option_enums_map_their_file_names_both_ways(enum: type[mpc.QpSolver]) -> None:
    members = list(enum.__members__.values())
    assert len(enum.names()) == len(members) == len(set(enum.names()))
    for value in members:
        assert enum.from_string(value.to_string()) == value
    with pytest.raises(ValueError, match="unknown value 'nope' \\(known: '"):
        enum.from_string("nope")


@pytest.mark.parametrize(
    "enum",
    [
        mpc.Status,
        _core.dynamics.PropagationStatus,
        _core.control.Method,
        _core.control.TubeStatus,
        _core.control.Certification,
        _core.control.MeasuredInput,
        _core.actuators.FaultKind,
        _core.actuators.AllocationStatus,
        _core.nav.SensorStatus,
        _core.nav.FilterStatus,
        _core.nav.Sensor,
        _core.nav.NavigationStatus,
    ],
)
def test_status_enums_str_is_their_table_name(enum: type[mpc.Status]) -> None:
    members = list(enum.__members__.values())
    assert len(enum.names()) == len(members) == len(set(enum.names()))
    for value in members:
        assert str(value) == value.to_string()
        assert enum.from_string(str(value)) == value


def test_fallback_statuses_are_the_fallback_ones() -> None:
    fallbacks = {s for s in mpc.Status.__members__.values() if _core.mpc.is_fallback(s)}
    assert fallbacks == {mpc.Status.FallbackShiftedPlan, mpc.Status.FallbackSafeInput}
    from tubempc.results.summaries import fallback_steps

    assert fallback_steps({"solved": 5, "fallback_safe_input": 2, "fallback_shifted_plan": 1}) == 3


def test_estimation_error_set_tightens_each_state_constraint_by_its_support() -> None:
    """Output feedback (docs/model.md M40): with P_est the bound of every state-constraint row a^T z <= b
    drops by sqrt(a^T P_est a) and nothing else of the QP changes; a non-finite P_est is a status."""
    plant = DoubleIntegrator(0.5, 1.0, 0.3)
    x0 = np.array([0.05, 0.9, 0.25, -0.1])
    plain = TubeMPC(plant, _settings(False))
    plain.setup(_reference(20))
    plain.step(0, x0, _tube())
    qp0 = plain.qp_data()
    rng = np.random.default_rng(3)
    L = 0.05 * rng.standard_normal((4, 4))
    P_est = L @ L.T
    tube = _tube()
    tube.P_est = P_est
    out = TubeMPC(plant, _settings(False))
    out.setup(_reference(20))
    out.step(0, x0, tube)
    qp1 = out.qp_data()
    G = qp0.G.toarray() if hasattr(qp0.G, "toarray") else np.asarray(qp0.G)
    finite = np.isfinite(qp0.h_u) & (np.abs(G).sum(axis=1) > 0)
    support = np.zeros(len(G))
    for row in np.flatnonzero(finite):  # a row acts on one node's dz_i: w = [dz_0 (4), v_0 (2), dz_1, ...]
        cols = np.flatnonzero(G[row])
        j = cols % 6
        assert np.all(j < 4)
        support[row] = np.sqrt(G[row, cols] @ P_est[np.ix_(j, j)] @ G[row, cols])
    assert finite.sum() >= 5 * 13  # every node's five rows
    np.testing.assert_allclose(qp1.h_u[finite], qp0.h_u[finite] - support[finite], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(qp1.b, qp0.b)
    np.testing.assert_array_equal(qp1.x_u, qp0.x_u)  # the inputs' tightening is the tube's alone
    tube.P_est = np.full((4, 4), np.nan)
    r = out.step(1, x0, tube)
    assert r.status != mpc.Status.Solved and np.all(np.isfinite(r.u))
    tube.P_est = np.eye(3)
    with pytest.raises(ValueError, match="P_est"):
        out.step(1, x0, tube)
