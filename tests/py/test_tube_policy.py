"""The tube-update policy alone, with scripted designers (no SDP): which tube each step flies with."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from tubempc.tube import TubeDesigner, TubeResult, TubeStatus
from tubempc.tube_policy import TubeUpdatePolicy

A = np.array([[1.0, 1.0], [0.0, 1.0]])  # double integrator, dt = 1
B = np.array([[0.5], [1.0]])
K = np.array([[-1.0, -1.5]])  # deadbeat: A + B K is nilpotent
A_K = A + B @ K
# Pe_1 = A_K Pe_1 A_K^T / 0.9 + I / 0.1 (nilpotent: two terms): s Pe_1 is invariant for P_W <= s I at alpha 0.9.
PE_1 = A_K @ np.eye(2) @ A_K.T / 0.9 / 0.1 + np.eye(2) / 0.1


def _tube(scale: float, alpha: float = 0.9, status: TubeStatus = TubeStatus.OPTIMAL) -> TubeResult:
    ok = status in (TubeStatus.OPTIMAL, TubeStatus.OPTIMAL_INACCURATE)
    return TubeResult(
        K=K if ok else None,
        Pe=scale * PE_1 if ok else None,
        alpha=alpha,
        objective=scale,
        status=status,
        lmi_residual=-1.0,
        solve_time_s=0.0,
        n_solves=1,
    )


class ScriptedDesigner(TubeDesigner):
    """Returns the scripted results in order and records each call (search or fixed alpha)."""

    def __init__(self, results: list[TubeResult]) -> None:
        self.results = list(results)
        self.calls: list[tuple[str, Any, float | None]] = []
        self.last_feasible: TubeResult | None = None
        self.u_max = 10.0

    def _next(self) -> TubeResult:
        r = self.results.pop(0)
        if r.feasible:
            self.last_feasible = r
        return r

    def design(self, A: Any, B: Any, P_W: Any, alpha_prev: float | None = None) -> TubeResult:  # type: ignore[override]
        self.calls.append(("search", np.asarray(P_W).copy(), alpha_prev))
        return self._next()

    def design_fixed_alpha(self, A: Any, B: Any, P_W: Any, alpha: float) -> TubeResult:  # type: ignore[override]
        self.calls.append(("fixed", np.asarray(P_W).copy(), alpha))
        return self._next()


def _update(policy: TubeUpdatePolicy, k: int, P_W: float) -> tuple[list[TubeResult], str | None]:
    return policy.update(k, [A], [B], [P_W * np.eye(2)])


def test_tbmpc_designs_once_and_keeps_the_tube() -> None:
    des = ScriptedDesigner([_tube(1.0)])
    with TubeUpdatePolicy([des], adaptive=False, margin=0.5, alpha_search_period=3, threads=1) as policy:
        first, status = _update(policy, 0, 0.01)
        assert status == "OPTIMAL" and len(des.calls) == 1 and des.calls[0][0] == "search"
        np.testing.assert_array_equal(des.calls[0][1], 0.01 * np.eye(2))  # no margin for TBMPC
        for k in range(1, 5):
            tubes, status = _update(policy, k, 100.0)  # whatever P_W says, TBMPC keeps its tube
            assert status is None and tubes[0] is first[0]
    assert len(des.calls) == 1


def test_ffa_searches_alpha_periodically_and_keeps_certified_tubes() -> None:
    # a generous tube (Pe = 10 I) stays invariant for the small P_W: kept between alpha searches
    des = ScriptedDesigner([_tube(10.0, 0.9), _tube(10.0, 0.8)])
    with TubeUpdatePolicy([des], adaptive=True, margin=0.2, alpha_search_period=3, threads=1) as policy:
        statuses = [_update(policy, k, 1e-3)[1] for k in range(4)]
    assert statuses == ["OPTIMAL", "KEPT", "KEPT", "OPTIMAL"]
    assert [c[0] for c in des.calls] == ["search", "search"]
    assert des.calls[1][2] == 0.9  # warm-started from the previous alpha
    np.testing.assert_allclose(des.calls[0][1], 1.2e-3 * np.eye(2))  # designed for (1 + margin) P_W


def test_ffa_redesigns_at_the_last_alpha_when_the_tube_is_no_longer_certified() -> None:
    # P_W grows by 100x: the kept tube is no longer invariant, so a fixed-alpha design runs
    des = ScriptedDesigner([_tube(0.02, 0.9), _tube(2.0, 0.9)])
    with TubeUpdatePolicy([des], adaptive=True, margin=0.2, alpha_search_period=10, threads=1) as policy:
        _update(policy, 0, 1e-3)
        tubes, status = _update(policy, 1, 1e-1)
    assert status == "OPTIMAL" and [c[0] for c in des.calls] == ["search", "fixed"]
    assert des.calls[1][2] == 0.9 and tubes[0].Pe is not None and tubes[0].Pe[0, 0] == 2.0 * PE_1[0, 0]


def test_a_failed_design_falls_back_to_the_last_feasible_tube() -> None:
    good = _tube(0.02, 0.9)
    des = ScriptedDesigner([good, _tube(0.0, status=TubeStatus.INFEASIBLE)])
    with TubeUpdatePolicy([des], adaptive=True, margin=0.0, alpha_search_period=1, threads=1) as policy:
        _update(policy, 0, 1e-3)
        tubes, status = _update(policy, 1, 1e3)
    assert status == "INFEASIBLE" and tubes[0] is good


def test_an_infeasible_first_design_is_an_error() -> None:
    des = ScriptedDesigner([_tube(0.0, status=TubeStatus.INFEASIBLE)])
    with TubeUpdatePolicy([des], adaptive=True, threads=1) as policy, pytest.raises(RuntimeError, match="initial tube"):
        _update(policy, 0, 1e-3)


def test_subsystems_are_independent_and_statuses_joined() -> None:
    p = ScriptedDesigner([_tube(10.0), _tube(10.0)])
    r = ScriptedDesigner([_tube(0.02), _tube(3.0)])
    with TubeUpdatePolicy([p, r], adaptive=True, margin=0.2, alpha_search_period=5, threads=2) as policy:
        policy.update(0, [A, A], [B, B], [1e-3 * np.eye(2), 1e-3 * np.eye(2)])
        tubes, status = policy.update(1, [A, A], [B, B], [1e-3 * np.eye(2), 1e-1 * np.eye(2)])
    assert status == "KEPT/OPTIMAL" and tubes[1].Pe is not None and tubes[1].Pe[0, 0] == 3.0 * PE_1[0, 0]


def test_bad_settings_are_rejected() -> None:
    with pytest.raises(ValueError, match="alpha_search_period"):
        TubeUpdatePolicy([], adaptive=True, alpha_search_period=0)
    with pytest.raises(ValueError, match="margin"):
        TubeUpdatePolicy([], adaptive=True, margin=-0.1)
    with pytest.raises(ValueError, match="worker"):
        TubeUpdatePolicy([], adaptive=True, worker="gpu")
    with pytest.raises(ValueError, match="concurrent worker"):
        TubeUpdatePolicy([], adaptive=True, adopt_when_ready=True, worker="inline")


class SlowDesigner(ScriptedDesigner):
    """A design that takes ``delay`` seconds (the background worker must not hold up the steps)."""

    def __init__(self, results: list[TubeResult], delay: float) -> None:
        super().__init__(results)
        self.delay = delay

    def design(self, A: Any, B: Any, P_W: Any, alpha_prev: float | None = None) -> TubeResult:  # type: ignore[override]
        if self.calls:  # the first (set-up) design is immediate
            time.sleep(self.delay)
        return super().design(A, B, P_W, alpha_prev)


def test_lyapunov_updates_between_designs_use_the_designs_gain() -> None:
    des = ScriptedDesigner([_tube(0.02, 0.9), _tube(0.02, 0.9)])
    with TubeUpdatePolicy([des], adaptive=True, alpha_search_period=3, threads=1, update="lyapunov") as policy:
        statuses = [_update(policy, k, 1e-3 * (1 + k))[1] for k in range(4)]
        tubes, _ = _update(policy, 4, 5e-3)
    assert statuses == ["OPTIMAL", "LYAPUNOV", "LYAPUNOV", "OPTIMAL"]
    assert tubes[0].K is K and tubes[0].alpha == 0.9 and tubes[0].Pe is not None
    # the Lyapunov tube follows P_W: for P_W = s I it is s times the unit one (here PE_1 is for alpha 0.9, P_W = I)
    np.testing.assert_allclose(tubes[0].Pe, 5e-3 * PE_1, rtol=1e-6)
    # with a redesign margin the Lyapunov tube is for (1 + margin) P_W, as the designs are
    des = ScriptedDesigner([_tube(0.02, 0.9)])
    with TubeUpdatePolicy([des], adaptive=True, alpha_search_period=3, threads=1, update="lyapunov", margin=0.5) as p:
        _update(p, 0, 1e-3)
        tubes, status = _update(p, 1, 4e-3)
    assert status == "LYAPUNOV"
    np.testing.assert_allclose(tubes[0].Pe, 1.5 * 4e-3 * PE_1, rtol=1e-6)


def test_background_design_is_adopted_at_a_deterministic_step() -> None:
    des = ScriptedDesigner([_tube(0.02, 0.9), _tube(0.03, 0.8)])
    with TubeUpdatePolicy(
        [des], adaptive=True, alpha_search_period=4, threads=1, update="lyapunov", design_delay=2, worker="thread"
    ) as policy:
        alphas = [_update(policy, k, 1e-3)[0][0].alpha for k in range(8)]
    assert policy.adoptions == [6]  # submitted at k = 4, adopted at k = 4 + 2
    assert alphas == [0.9] * 6 + [0.8] * 2


def test_a_slow_background_design_does_not_delay_the_steps() -> None:
    des = SlowDesigner([_tube(0.02, 0.9), _tube(0.03, 0.8)], delay=1.0)
    with TubeUpdatePolicy(
        [des],
        adaptive=True,
        alpha_search_period=2,
        threads=1,
        update="lyapunov",
        design_delay=1,
        adopt_when_ready=True,
        worker="thread",
    ) as policy:
        _update(policy, 0, 1e-3)
        t0 = time.perf_counter()
        durations = []
        for k in range(1, 40):
            s = time.perf_counter()
            _update(policy, k, 1e-3)
            durations.append(time.perf_counter() - s)
            time.sleep(0.005)
        elapsed = time.perf_counter() - t0
        assert max(durations) < 0.1 and elapsed < 1.0  # no step waited for the 1 s design
        assert policy.adoptions == []
        time.sleep(1.1)
        _update(policy, 40, 1e-3)
    assert policy.adoptions == [40]


@pytest.mark.parametrize("worker", ["process", "inline"])
def test_every_design_worker_gives_the_threads_numbers(worker: str) -> None:
    """Deterministic adoption: the tubes do not depend on where the designs ran (a real SDP designer,
    rebuilt from its spec in the design process)."""
    A2, B2 = np.array([[1.0, 0.1], [0.0, 1.0]]), np.array([[0.005], [0.1]])

    def fly(w: str) -> list[np.ndarray]:
        des = TubeDesigner(2, 1, Q=np.eye(2), R=np.eye(1), u_max=1.0)
        with TubeUpdatePolicy(
            [des], adaptive=True, alpha_search_period=3, update="lyapunov", design_delay=2, worker=w
        ) as policy:
            pes = [np.asarray(policy.update(k, [A2], [B2], [(1e-4 + 2e-5 * k) * np.eye(2)])[0][0].Pe) for k in range(10)]
        assert policy.adoptions == [5, 8]
        return pes

    for a, b in zip(fly("thread"), fly(worker), strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("sync_status", [TubeStatus.OPTIMAL, TubeStatus.INFEASIBLE])
def test_a_growing_disturbance_drops_the_margin_then_designs_in_the_step(sync_status: TubeStatus) -> None:
    # u_max admits the Lyapunov tube of the design's K for P_W up to 1.2e-2 I: with the margin 0.5 up to 0.8e-2 I.
    c = float(np.sqrt(K @ PE_1 @ K.T)[0, 0])
    des = ScriptedDesigner([_tube(0.02, 0.9), _tube(0.03, 0.8), _tube(0.04, 0.7, sync_status)])
    des.u_max = c * np.sqrt(1.2e-2)
    kw: dict[str, Any] = {"alpha_search_period": 100, "threads": 1, "update": "lyapunov", "margin": 0.5}
    with TubeUpdatePolicy([des], adaptive=True, design_delay=2, worker="inline", **kw) as policy:
        steps = [_update(policy, k, P_W) for k, P_W in enumerate([1e-3, 5e-3, 1e-2, 2e-2, 1e-3, 1e-3])]
    statuses = [s for _, s in steps]
    assert statuses == ["OPTIMAL", "LYAPUNOV", "LYAPUNOV_NO_MARGIN", f"SYNC_{sync_status.name}", "LYAPUNOV", "LYAPUNOV"]
    np.testing.assert_allclose(steps[1][0][0].Pe, 1.5 * 5e-3 * PE_1, rtol=1e-6)
    np.testing.assert_allclose(steps[2][0][0].Pe, 1e-2 * PE_1, rtol=1e-6)  # certified for P_W itself
    # step 3: the lost margin started a background design (for 1.5 P_W), and nothing certified for 2e-2 I
    # made the step design its own tube
    assert [call[0] for call in des.calls] == ["search", "search", "search"]
    np.testing.assert_allclose(des.calls[2][1], 1.5 * 2e-2 * np.eye(2))
    # step 5 adopts the background design started at step 3 (alpha 0.8) unless the step designed its own
    # tube since (alpha 0.7): an in-step design is never replaced by an older one
    assert policy.adoptions == [5]
    if sync_status is TubeStatus.OPTIMAL:
        assert steps[3][0][0].alpha == 0.7 and not policy.design_failures
        assert steps[5][0][0].alpha == 0.7
    else:  # an infeasible design: the last certified tube, and the failure is recorded
        np.testing.assert_allclose(steps[3][0][0].Pe, 1e-2 * PE_1, rtol=1e-6)
        assert policy.design_failures == ["3:0:INFEASIBLE"]
        assert steps[4][0][0].alpha == 0.9 and steps[5][0][0].alpha == 0.8
