"""Tube design (paper Eq. 25; docs/model.md "Tube design")."""

import numpy as np
import pytest
import scipy.linalg

from tubempc.design.tube import (
    DesignResult,
    DesignStatus,
    TubeDesigner,
    lmi_residual,
    sample_invariance,
)

DT = 2.0
I3, Z3 = np.eye(3), np.zeros((3, 3))
A_DI = np.block([[I3, DT * I3], [Z3, I3]])  # discrete double integrator, dt = 2 s
B_TRANS = np.vstack([0.5 * DT**2 * I3, DT * I3])  # input u_p in m/s^2
J = np.diag([2750.0, 2750.0, 2030.0])  # kg m^2
B_ROT = np.vstack([0.5 * DT**2 * np.linalg.inv(J), DT * np.linalg.inv(J)])  # torque in N m
PW_TRANS = 9.0 * np.diag([4e-2] * 3 + [2.5e-3] * 3)  # Table 1, 3 sigma
PW_ROT = 9.0 * np.diag([1e-6] * 3 + [1e-8] * 3)  # Table 1, 3 sigma: badly scaled
U_MAX, T_MAX = 0.55, 3.0


def _trans() -> TubeDesigner:
    return TubeDesigner(Q=np.eye(6), R=1e3 * np.eye(3), u_max=U_MAX)


def _rot(**kw: object) -> TubeDesigner:
    return TubeDesigner(Q=np.eye(6), R=1e4 * np.eye(3), u_max=T_MAX, **kw)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def trans() -> tuple[TubeDesigner, DesignResult]:
    d = _trans()
    return d, d.design(A_DI, B_TRANS, PW_TRANS)


@pytest.fixture(scope="module")
def rot() -> tuple[TubeDesigner, DesignResult]:
    d = _rot()
    return d, d.design(A_DI, B_ROT, PW_ROT)


def _check_valid(r: DesignResult, A: np.ndarray, B: np.ndarray, PW: np.ndarray, u_max: float) -> None:
    assert r.status is DesignStatus.OPTIMAL and r.feasible
    assert r.K is not None and r.Pe is not None
    assert 0.0 < r.alpha < 1.0
    assert r.lmi_residual <= 1e-7
    assert lmi_residual(A, B, r.K, r.Pe, PW, r.alpha) == r.lmi_residual
    assert np.linalg.eigvalsh(r.Pe).min() > 0.0
    rng = np.random.default_rng(0)
    assert sample_invariance(A, B, r.K, r.Pe, PW, 4000, rng) <= 1.0 + 1e-6
    assert np.abs(np.linalg.eigvals(A + B @ r.K)).max() < 1.0
    # the input constraint of the LMI: the tube's feedback stays within u_max, max_e |K_i e| = sqrt(K_i Pe K_i^T)
    assert np.all(np.sqrt(np.einsum("ij,jk,ik->i", r.K, r.Pe, r.K)) <= u_max * (1.0 + 1e-7))


def test_translational_tube_is_invariant(
    trans: tuple[TubeDesigner, DesignResult],
) -> None:
    _check_valid(trans[1], A_DI, B_TRANS, PW_TRANS, U_MAX)
    assert trans[1].objective > 0.0 and trans[1].n_solves >= 1


def test_badly_scaled_rotational_tube_is_valid(
    rot: tuple[TubeDesigner, DesignResult],
) -> None:
    _check_valid(rot[1], A_DI, B_ROT, PW_ROT, T_MAX)


def test_a_design_does_not_depend_on_the_designs_before_it() -> None:
    # A designer rebuilt elsewhere (the background design process) must design as this one does.
    used, fresh = _rot(), _rot()
    used.design(A_DI, B_ROT, 0.5 * PW_ROT)
    a, b = used.design(A_DI, B_ROT, PW_ROT, 0.9), fresh.design(A_DI, B_ROT, PW_ROT, 0.9)
    assert a.alpha == b.alpha
    np.testing.assert_array_equal(a.Pe, b.Pe)


def test_checks_detect_a_non_invariant_tube(
    trans: tuple[TubeDesigner, DesignResult],
) -> None:
    r = trans[1]
    assert r.K is not None and r.Pe is not None
    small = 0.5 * r.Pe
    assert lmi_residual(A_DI, B_TRANS, r.K, small, PW_TRANS, r.alpha) > 0.1
    rng = np.random.default_rng(1)
    assert sample_invariance(A_DI, B_TRANS, r.K, small, PW_TRANS, 2000, rng) > 1.1


def test_larger_disturbance_gives_larger_tube(
    trans: tuple[TubeDesigner, DesignResult],
) -> None:
    d, r = trans
    assert r.Pe is not None
    big = d.design(A_DI, B_TRANS, 2.0 * PW_TRANS)
    assert big.Pe is not None
    assert np.trace(big.Pe) > 1.5 * np.trace(r.Pe)
    assert np.trace(PW_TRANS @ np.linalg.inv(big.Pe)) < np.trace(PW_TRANS @ np.linalg.inv(r.Pe))


def test_alpha_search_beats_fixed_alpha(
    trans: tuple[TubeDesigner, DesignResult], rot: tuple[TubeDesigner, DesignResult]
) -> None:
    for (d, r), A, B, PW in (
        (trans, A_DI, B_TRANS, PW_TRANS),
        (rot, A_DI, B_ROT, PW_ROT),
    ):
        fixed = d.design_fixed_alpha(A, B, PW, 0.5)
        assert fixed.status is DesignStatus.OPTIMAL and fixed.n_solves == 1
        assert r.objective < 0.99 * fixed.objective


def test_warm_start_uses_few_solves(trans: tuple[TubeDesigner, DesignResult]) -> None:
    d, r = trans
    warm = d.design(A_DI, B_TRANS, 1.1 * PW_TRANS, alpha_prev=r.alpha)
    cold = d.design(A_DI, B_TRANS, 1.1 * PW_TRANS)
    assert warm.status is DesignStatus.OPTIMAL and warm.n_solves <= 3 < cold.n_solves
    assert warm.objective <= cold.objective * (1.0 + 5e-3)
    # Warm start far from the optimum widens the bracket and still finds it.
    far = d.design(A_DI, B_TRANS, PW_TRANS, alpha_prev=0.2)
    assert far.objective <= r.objective * (1.0 + 5e-3)


def test_infeasible_is_reported_not_raised(
    trans: tuple[TubeDesigner, DesignResult],
) -> None:
    tiny = TubeDesigner(Q=np.eye(6), R=1e3 * np.eye(3), u_max=1e-6)
    bad = tiny.design(A_DI, B_TRANS, 1e4 * PW_TRANS)
    assert bad.status is DesignStatus.INFEASIBLE and not bad.feasible
    assert bad.K is None and bad.Pe is None
    assert bad.n_solves == len(tiny.alpha_grid)


def test_problem_is_dpp_and_compiled_once() -> None:
    d = _rot()
    assert d.problem.is_dpp()
    d.design_fixed_alpha(A_DI, B_ROT, PW_ROT, 0.9)
    prog = d.problem._cache.param_prog
    assert prog is not None
    d.design_fixed_alpha(A_DI + 1e-3, B_ROT, 2.0 * PW_ROT, 0.95)
    assert d.problem._cache.param_prog is prog  # no re-canonicalisation: the compiled program is re-used
    other = _trans()  # another designer of the same size (a campaign's next run): compiles nothing either
    assert other.problem is d.problem


def test_a_designer_designs_alike_after_other_designs_and_in_another_thread() -> None:
    """The compiled SDP is shared by the designers of one thread (and not across threads): a design after other
    designs of other data, and one in another thread with its own compiled SDP, equal a first design to the bit."""
    import threading

    first = _rot().design(A_DI, B_ROT, PW_ROT)
    _trans().design(A_DI + 1e-3, B_TRANS, 3.0 * PW_TRANS)
    again = _rot().design(A_DI, B_ROT, PW_ROT)
    out: list[DesignResult] = []
    t = threading.Thread(target=lambda: out.append(_rot().design(A_DI, B_ROT, PW_ROT)))
    t.start()
    t.join()
    for r in (again, out[0]):
        assert r.alpha == first.alpha and r.n_solves == first.n_solves
        np.testing.assert_array_equal(r.K, first.K)
        np.testing.assert_array_equal(r.Pe, first.Pe)


def test_input_validation() -> None:
    d = _trans()
    with pytest.raises(ValueError, match="A"):
        d.design(np.eye(5), B_TRANS, PW_TRANS)
    with pytest.raises(ValueError, match="non-finite"):
        d.design(A_DI, B_TRANS, np.full((6, 6), np.nan))
    with pytest.raises(ValueError, match="alpha"):
        d.design_fixed_alpha(A_DI, B_TRANS, PW_TRANS, 1.0)


def test_dual_slope_matches_finite_difference() -> None:
    # The alpha search relies on df/ds from the invariance LMI's dual (envelope theorem).
    d = _trans()
    sdp = d._sdp()
    d._set_data(sdp, A_DI, B_TRANS, PW_TRANS)
    for s in (-0.5, 0.4, 1.5):
        h = 1e-4
        mid = d._evaluate(sdp, s)
        fd = (d._evaluate(sdp, s + h).value - d._evaluate(sdp, s - h).value) / (2.0 * h)
        assert mid.slope == pytest.approx(fd, rel=2e-3, abs=1e-6 * abs(mid.value))


def _random_stable(rng: np.random.Generator, n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    A = rng.normal(size=(n, n)) * 0.6
    B = rng.normal(size=(n, m))
    # a gain placing A + B K well inside the unit circle: LQR-like via a Riccati solve
    P = scipy.linalg.solve_discrete_are(A, B, np.eye(n), np.eye(m))
    K = -np.linalg.solve(B.T @ P @ B + np.eye(m), B.T @ P @ A)
    return A, B, K


@pytest.mark.parametrize("seed", range(6))
def test_lyapunov_tube_is_invariant_and_minimal(seed: int) -> None:
    """The Lyapunov tube meets the LMI condition (independent check: the Schur form and sampling) and is
    the smallest of its family: shrunk by 1 % it violates the condition."""
    from tubempc.design.tube import lyapunov_tube

    rng = np.random.default_rng(seed)
    A, B, K = _random_stable(rng, 6, 3)
    rho = float(np.max(np.abs(np.linalg.eigvals(A + B @ K))))
    alpha = min(0.99, max(rho**2 * 1.2, 0.3))
    design = DesignResult(
        K=K,
        Pe=np.eye(6),
        alpha=alpha,
        objective=1.0,
        status=DesignStatus.OPTIMAL,
        lmi_residual=-1.0,
        solve_time_s=0.0,
        n_solves=1,
    )
    L = rng.normal(size=(6, 6))
    P_W = 1e-3 * (L @ L.T + 0.1 * np.eye(6))
    tube, why = lyapunov_tube(A, B, design, P_W, u_max=1e6)
    assert tube is not None, why
    assert tube.status == DesignStatus.LYAPUNOV
    Pe = tube.Pe
    # independent: the Schur-complement LMI [[Pe - P_W/(1-a), A_K Pe], [Pe A_K^T, a Pe]] >= 0
    AK = A + B @ K
    M = np.block([[Pe - P_W / (1 - alpha), AK @ Pe], [Pe @ AK.T, alpha * Pe]])
    scale = np.sqrt(np.outer(np.r_[np.diag(Pe), np.diag(Pe)], np.r_[np.diag(Pe), np.diag(Pe)]))
    assert np.linalg.eigvalsh(M / scale).min() > -1e-9
    assert sample_invariance(A, B, K, Pe, P_W, 4000, rng) <= 1.0 + 1e-9
    assert lmi_residual(A, B, K, 0.99 * Pe, P_W, alpha) > 0.0  # minimal: a smaller one is not invariant


def test_lyapunov_tube_certification_refuses_what_it_cannot_certify() -> None:
    from tubempc.design.tube import lyapunov_tube

    rng = np.random.default_rng(1)
    A, B, K = _random_stable(rng, 4, 2)
    rho2 = float(np.max(np.abs(np.linalg.eigvals(A + B @ K)))) ** 2
    design = DesignResult(
        K=K,
        Pe=np.eye(4),
        alpha=min(0.99, rho2 * 1.5 + 0.05),
        objective=1.0,
        status=DesignStatus.OPTIMAL,
        lmi_residual=-1.0,
        solve_time_s=0.0,
        n_solves=1,
    )
    P_W = 1e-4 * np.eye(4)
    ok, _ = lyapunov_tube(A, B, design, P_W, u_max=1e6)
    assert ok is not None
    slow = DesignResult(
        K=K,
        Pe=np.eye(4),
        alpha=rho2 * 0.5,
        objective=1.0,
        status=DesignStatus.OPTIMAL,
        lmi_residual=-1.0,
        solve_time_s=0.0,
        n_solves=1,
    )
    refused, why = lyapunov_tube(A, B, slow, P_W, u_max=1e6)
    assert refused is None and "not contractive enough" in why
    _, why = lyapunov_tube(A, B, design, P_W, u_max=1e-9)
    assert "empty input tightening" in why
    failed = DesignResult(
        K=None,
        Pe=None,
        alpha=0.5,
        objective=np.inf,
        status=DesignStatus.INFEASIBLE,
        lmi_residual=np.inf,
        solve_time_s=0.0,
        n_solves=1,
    )
    assert lyapunov_tube(A, B, failed, P_W, u_max=1.0)[1] == "no designed gain"
