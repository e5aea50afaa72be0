"""Actuators (docs/model.md "Actuators"): the allocation against scipy's bounded least squares, the
modulated impulse against its analytic value, the certified actuation-error box against sampled errors,
a failed thruster's named status, and the preset loader's units and errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from tubempc import _core
from tubempc._core import actuators as act
from tubempc.models.disturbances import sample_ellipsoid_surface
from tubempc.scenario import actuators as A

PERIOD = 2.0


@pytest.fixture(scope="module")
def suite() -> A.ActuatorSuite:
    return A.load_actuators("osiris_rex_like", PERIOD)


def _objective(Amat: np.ndarray, b: np.ndarray, x: np.ndarray) -> float:
    return float(np.sum((Amat @ x - b) ** 2))


def _check_against_scipy(alloc: act.Allocator, r: act.AllocationResult) -> None:
    Amat, b, lo, hi = alloc.last_problem()
    x = np.concatenate([r.thrust, r.wheel_torque])
    fixed = lo == hi
    free = ~fixed
    # scipy's BVLS on the free variables (lsq_linear needs lower < upper), the fixed ones moved to b.
    ref = lsq_linear(Amat[:, free], b - Amat[:, fixed] @ lo[fixed], bounds=(lo[free], hi[free]), method="bvls", tol=1e-14)
    x_ref = lo.copy()
    x_ref[free] = ref.x
    f, f_ref = _objective(Amat, b, x), _objective(Amat, b, x_ref)
    assert f <= f_ref * (1 + 1e-9) + 1e-15
    scale = 1.0 + np.abs(hi).max()
    np.testing.assert_allclose(x, x_ref, atol=1e-6 * scale)
    assert np.all(x >= lo) and np.all(x <= hi)


def test_allocation_matches_scipy_bvls_on_random_commands(suite: A.ActuatorSuite) -> None:
    rng = np.random.default_rng(1)
    alloc = suite.allocator()
    statuses = set()
    for k in range(200):
        scale = 3.0 if k % 2 else 40.0  # half beyond the cluster's reach
        w = scale * rng.normal(size=6)
        r = alloc.solve(suite.cluster, suite.wheels, 0.0, w)
        statuses.add(r.info.status)
        _check_against_scipy(alloc, r)
        np.testing.assert_allclose(r.wrench_B + r.remainder_B, w, rtol=1e-12, atol=1e-12)
    assert statuses == {act.AllocationStatus.Ok, act.AllocationStatus.Saturated}


def test_allocation_with_dumping_wheels_matches_scipy(suite: A.ActuatorSuite) -> None:
    wheels = suite.wheels.copy()
    wheels.set_momentum(np.array([45.0, -20.0, 5.0, 0.0]))
    assert wheels.dumping
    alloc = act.Allocator(suite.cluster, wheels, suite.allocation)
    rng = np.random.default_rng(2)
    for _ in range(50):
        r = alloc.solve(suite.cluster, wheels, 0.0, 0.5 * rng.normal(size=6))
        assert r.info.dumping
        _check_against_scipy(alloc, r)
    r = alloc.solve(suite.cluster, wheels, 0.0, np.zeros(6))
    pref = wheels.preferred_torque()
    np.testing.assert_allclose(r.wheel_torque, pref, atol=1e-3 * np.abs(pref).max())
    assert np.linalg.norm(r.wrench_B) < 1e-5  # the thrusters hold the attitude while the wheels unload


def test_failed_thruster_gives_the_named_status_and_a_resolved_allocation(suite: A.ActuatorSuite) -> None:
    cluster = suite.cluster.copy()
    alloc = act.Allocator(cluster, suite.wheels, suite.allocation)
    w = np.array([0.0, 0.0, 3.0, 0.2, 0.0, 0.0])  # +z force and a torque about x: the +z thrusters
    r0 = alloc.solve(cluster, suite.wheels, 0.0, w)
    assert r0.info.status == act.AllocationStatus.Ok
    busiest = int(np.argmax(r0.thrust))
    cluster.set_fault(busiest, act.FaultKind.FailedOff, 10.0)
    r1 = alloc.solve(cluster, suite.wheels, 10.0, w)
    assert r1.info.status == act.AllocationStatus.ThrusterFailed
    assert str(r1.info.status) == "thruster_failed"
    assert r1.info.resetup and r1.info.failed_thrusters == 1
    assert r1.thrust[busiest] == 0.0
    np.testing.assert_allclose(r1.wrench_B, w, atol=1e-4)
    _check_against_scipy(alloc, r1)
    cluster.set_fault(busiest, act.FaultKind.StuckOn, 20.0)
    r2 = alloc.solve(cluster, suite.wheels, 20.0, w)
    assert r2.thrust[busiest] == cluster.max_thrust[busiest]
    assert r2.info.status == act.AllocationStatus.ThrusterFailed
    _check_against_scipy(alloc, r2)


def test_modulated_impulse_matches_its_analytic_value(suite: A.ActuatorSuite) -> None:
    mod = suite.modulator()
    cluster = suite.cluster
    F = cluster.max_thrust
    t_min = mod.effective_min_on_time(cluster, 0)
    rng = np.random.default_rng(3)
    f = F * rng.uniform(0.0, 0.05, size=len(cluster))  # mostly below one minimum impulse per period
    total = np.zeros(len(cluster))
    propellant = 0.0
    K = 400
    for k in range(K):
        fire = mod.modulate(cluster, k * PERIOD, f)
        assert np.all((fire.on_time == 0.0) | (fire.on_time >= t_min - 1e-15))
        total += fire.impulse
        propellant += fire.propellant
    # delivered = commanded - F * remainder, the remainder within [0, r_max)
    np.testing.assert_allclose(total, f * K * PERIOD - F * mod.remainder, rtol=1e-12, atol=1e-9)
    r_max = np.array([mod.remainder_bound(cluster, j) for j in range(len(cluster))])
    assert np.all((mod.remainder >= 0) & (mod.remainder < r_max))
    isp = np.array([cluster.thruster(j).isp for j in range(len(cluster))])
    assert propellant == pytest.approx(float(np.sum(total / (isp * act.STANDARD_GRAVITY))), rel=1e-12)
    # A third of a minimum on-time per period fires one minimum-length pulse every third period.
    mod.reset()
    g = np.zeros(len(cluster))
    g[0] = F[0] * (t_min / 3) / PERIOD
    pulses = [mod.modulate(cluster, k * PERIOD, g).on_time[0] for k in range(12)]
    np.testing.assert_allclose(pulses, [0, 0, t_min] * 4, atol=1.5e-3)  # on-time resolution 1 ms
    assert int(mod.pulse_counts[0]) == 4


def test_sampled_actuation_errors_lie_in_the_certified_box(suite: A.ActuatorSuite) -> None:
    rng = np.random.default_rng(4)
    truth = A.sample_truth_errors(suite.cluster, rng)
    assert any(abs(truth.thruster(j).scale_error) > 0 for j in range(len(truth)))
    mod = suite.modulator()
    bound = act.actuation_error_bound(truth, mod, suite.mass)
    alloc = act.Allocator(truth, suite.wheels, suite.allocation)  # its nominal mapping ignores truth errors
    worst = np.zeros(6)
    C_BL = np.eye(3)
    for k in range(1500):
        u = rng.normal(size=6) * np.array([2e-3, 2e-3, 2e-3, 1.0, 1.0, 1.0]) * (0.01 if k % 3 == 0 else 1.0)
        r = alloc.solve(truth, suite.wheels, k * PERIOD, act.wrench_from_input(u, C_BL, suite.mass))
        fire = mod.modulate(truth, k * PERIOD, r.thrust)
        e = r.wrench_B - (fire.delivered_B + np.concatenate([np.zeros(3), suite.wheels.axes_B @ r.wheel_torque]))
        assert np.all(np.abs(e) <= bound.wrench_B), (k, e, bound.wrench_B)
        e_u = act.input_from_wrench(e, C_BL, suite.mass)
        assert np.all(np.abs(e_u) <= bound.input)
        assert e_u[:3] @ np.linalg.solve(bound.shape_p, e_u[:3]) <= 1.0
        assert e_u[3:] @ np.linalg.solve(bound.shape_T, e_u[3:]) <= 1.0
        worst = np.maximum(worst, np.abs(e) / bound.wrench_B)
    assert worst.max() > 0.05  # not vacuous: the sampled errors reach a visible part of the box


def test_achievable_box_holds_with_any_one_thruster_failed(suite: A.ActuatorSuite) -> None:
    box = act.achievable_box(suite.cluster, suite.wheels, suite.allocation, suite.mass)
    assert box.scale > 0.0 and box.limiting_failure >= 0
    rng = np.random.default_rng(5)
    for j in range(len(suite.cluster)):
        cluster = suite.cluster.copy()
        cluster.set_fault(j, act.FaultKind.FailedOff, 0.0)
        alloc = act.Allocator(cluster, suite.wheels, suite.allocation)
        for _ in range(10):
            w = rng.uniform(-1.0, 1.0, size=6) * box.half_width_B
            assert alloc.solve(cluster, suite.wheels, 0.0, w).info.status == act.AllocationStatus.ThrusterFailed
    # the MPC's box: any u_p in it maps into the wrench box at every attitude
    for _ in range(50):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        x, y, z, w = q
        C = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )
        u = np.sign(rng.normal(size=6)) * box.input_half_width
        assert np.all(np.abs(act.wrench_from_input(u, C, suite.mass)) <= box.half_width_B * (1 + 1e-12))


def test_loader_reads_units_and_names_bad_fields(tmp_path: Path) -> None:
    s = A.load_actuators("osiris_rex_like", 1.0)
    assert "osiris_rex_like" in A.preset_names()
    assert s.cluster.max_thrust[0] == pytest.approx(4.4482216152605)  # 1 lbf
    assert s.cluster.thruster(0).min_on_time == pytest.approx(0.02)
    assert s.cluster.thruster(0).misalignment_bound == pytest.approx(np.deg2rad(0.5))
    assert s.modulation.on_time_resolution == pytest.approx(1e-3)
    assert s.wheels.max_momentum[0] == 50.0 and s.mass == 1500.0
    text = (A.PRESET_DIR / "osiris_rex_like.toml").read_text(encoding="utf-8")
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace('min_on_time = "20 ms"', 'min_on_time = "20 kg"'), encoding="utf-8")
    with pytest.raises(A.ActuatorConfigError, match="min_on_time"):
        A.load_actuators(bad, 1.0)
    bad.write_text(text.replace("start_fraction = 0.8", "start_fractoin = 0.8"), encoding="utf-8")
    with pytest.raises(A.ActuatorConfigError, match=r"momentum_dump: unknown field\(s\) \['start_fractoin'\]"):
        A.load_actuators(bad, 1.0)
    with pytest.raises(A.ActuatorConfigError, match=r"thrusters\[0\].min_on_time: longer than"):
        A.load_actuators("osiris_rex_like", 0.015)
    faulty = tmp_path / "faulty.toml"
    faulty.write_text(
        text + '\n[[faults]]\nthruster = 3\nkind = "stuck_on"\ntime = "random"\n'
        'window = { value = [100.0, 200.0], unit = "s" }\n',
        encoding="utf-8",
    )
    a, b = A.load_actuators(faulty, 1.0, seed=7), A.load_actuators(faulty, 1.0, seed=7)
    t = a.cluster.thruster(3).fault_time
    assert 100.0 <= t <= 200.0 and t == b.cluster.thruster(3).fault_time
    assert a.cluster.fault_at(3, t) == act.FaultKind.StuckOn and a.cluster.fault_at(3, t - 1e-9) == act.FaultKind.None_
    faulty.write_text(text + '\n[[faults]]\nthruster = 16\nkind = "stuck_on"\ntime = "1 s"\n', encoding="utf-8")
    with pytest.raises(A.ActuatorConfigError, match=r"faults\[0\].thruster"):
        A.load_actuators(faulty, 1.0)
    with pytest.raises(ValueError, match=r"thrusters\[0\].direction_B"):
        spec = act.ThrusterSpec()
        spec.direction_B = np.array([0.0, 0.0, 2.0])
        act.ThrusterCluster([spec])


def test_modulation_matches_basilisk_thr_firing_remainder() -> None:
    """Without on-time quantisation and below saturation, the on-times are Basilisk's thrFiringRemainder's
    (an independent implementation of the same remainder carry-over)."""
    pytest.importorskip("Basilisk")
    from Basilisk.architecture import messaging
    from Basilisk.fswAlgorithms import thrFiringRemainder
    from Basilisk.utilities import SimulationBaseClass, macros

    n, dt, t_min, F = 4, 2.0, 0.02, 4.5
    sim = SimulationBaseClass.SimBaseClass()
    sim.CreateNewProcess("p").addTask(sim.CreateNewTask("t", macros.sec2nano(dt)))
    bsk = thrFiringRemainder.thrFiringRemainder()
    bsk.thrMinFireTime = t_min
    sim.AddModelToTask("t", bsk)
    cfg = messaging.THRArrayConfigMsgPayload()
    cfg.numThrusters = n
    for i in range(n):
        thr = messaging.THRConfigMsgPayload()
        thr.maxThrust = F
        thr.rThrust_B = [0.0, 0.0, 0.0]
        thr.tHatThrust_B = [0.0, 0.0, 1.0]
        messaging.ThrustConfigArray_setitem(cfg.thrusters, i, thr)
    cfg_msg = messaging.THRArrayConfigMsg().write(cfg)
    force_msg = messaging.THRArrayCmdForceMsg()
    bsk.thrConfInMsg.subscribeTo(cfg_msg)
    bsk.thrForceInMsg.subscribeTo(force_msg)
    log = bsk.onTimeOutMsg.recorder()
    sim.AddModelToTask("t", log)
    cmds = F * np.random.default_rng(6).uniform(0.0, 0.03, size=(60, n))  # on-times around t_min
    sim.InitializeSimulation()
    for k in range(len(cmds)):
        payload = messaging.THRArrayCmdForceMsgPayload()
        payload.thrForce = [float(f) for f in cmds[k]]
        force_msg.write(payload)
        sim.ConfigureStopTime(macros.sec2nano((k + 1) * dt))
        sim.ExecuteSimulation()
    # Records 0 and 1 (t = 0 and dt) are Basilisk's start-up calls; record r >= 2 answers cmds[r - 1].
    on_bsk = np.array(log.OnTimeRequest)[2:, :n]

    spec = act.ThrusterSpec()
    spec.max_thrust = F
    spec.min_on_time = t_min
    cluster = act.ThrusterCluster([spec] * n)
    ms = act.ModulationSettings()
    ms.period = dt
    ms.on_time_resolution = 0.0
    mod = act.PulseModulator(cluster, ms)
    mine = np.array([mod.modulate(cluster, k * dt, cmds[k]).on_time for k in range(1, len(cmds))])
    assert np.count_nonzero(mine == 0.0) > 10 and np.count_nonzero(mine) > 10
    np.testing.assert_allclose(mine, on_bsk, rtol=0, atol=1e-12)


def test_errors_of_commands_in_the_achievable_box_lie_in_the_tighter_box(suite: A.ActuatorSuite) -> None:
    """Commands inside the one-failure achievable box, wheels dumping, a thruster failing half-way: every
    allocation's thrust norm and every sampled error stay inside the in-box bound, tighter than the other."""
    rng = np.random.default_rng(9)
    truth = A.sample_truth_errors(suite.cluster, rng)
    box = act.achievable_box(truth, suite.wheels, suite.allocation, suite.mass)
    mod = suite.modulator()
    any_cmd = act.actuation_error_bound(truth, mod, suite.mass)
    bound = act.actuation_error_bound(truth, mod, suite.mass, suite.wheels, suite.allocation, box.half_width_B)
    assert bound.thrust_norm < 0.5 * any_cmd.thrust_norm
    assert np.all(bound.wrench_B <= any_cmd.wrench_B) and bound.wrench_B[0] < 0.7 * any_cmd.wrench_B[0]
    wheels = suite.wheels.copy()
    wheels.set_momentum(np.array([45.0, -45.0, 30.0, -30.0]))
    truth.set_fault(5, act.FaultKind.FailedOff, 300 * PERIOD)
    alloc = act.Allocator(truth, wheels, suite.allocation)
    worst, dumping, failed = np.zeros(6), 0, 0
    for k in range(600):
        t = k * PERIOD
        r = alloc.solve(truth, wheels, t, rng.uniform(-1.0, 1.0, size=6) * box.half_width_B)
        assert r.info.status in (act.AllocationStatus.Ok, act.AllocationStatus.ThrusterFailed)
        assert np.linalg.norm(r.thrust) <= bound.thrust_norm
        fire = mod.modulate(truth, t, r.thrust)
        wheels.apply(r.wheel_torque, PERIOD)
        dumping += r.info.dumping
        failed += r.info.failed_thrusters
        e = fire.commanded_B - fire.delivered_B
        assert np.all(np.abs(e) <= bound.wrench_B), (k, e, bound.wrench_B)
        worst = np.maximum(worst, np.abs(e) / bound.wrench_B)
    assert dumping > 10 and failed == 300
    assert worst.max() > 0.1


def test_system_call_allocates_like_scipy_and_fires_what_it_allocated(suite: A.ActuatorSuite) -> None:
    """Through ActuationSystem.step: each period's allocation is the bounded least-squares optimum (scipy's
    BVLS), the firing delivers the truth's mapping of the modulated on-times plus the wheels' torques, and the
    delivered input is that wrench in the MPC's coordinates."""
    rng = np.random.default_rng(21)
    truth = A.sample_truth_errors(suite.cluster, rng)
    sys_ = act.ActuationSystem(truth, suite.wheels, A.actuation_settings(suite))
    D_true, F = np.asarray(truth.true_mapping), np.asarray(truth.max_thrust)
    G = np.asarray(suite.wheels.axes_B)
    statuses = set()
    for k in range(120):
        axis = rng.normal(size=3)
        C_BL = np.asarray(_core.so3.rotation_matrix(np.r_[np.sin(0.4) * axis / np.linalg.norm(axis), np.cos(0.4)])).T
        u = rng.normal(size=6) * np.array([1e-3, 1e-3, 1e-3, 0.5, 0.5, 0.5]) * (20.0 if k % 4 == 0 else 1.0)
        st = sys_.step(k * PERIOD, u, C_BL)
        statuses.add(st.status)
        Amat, b, lo, hi = sys_.last_problem()
        fixed = lo == hi
        free = ~fixed
        ref = lsq_linear(
            Amat[:, free], b - Amat[:, fixed] @ lo[fixed], bounds=(lo[free], hi[free]), method="bvls", tol=1e-14
        )
        x_ref = lo.copy()
        x_ref[free] = ref.x
        np.testing.assert_allclose(st.thrust, x_ref[: len(truth)], atol=1e-6 * (1.0 + np.abs(hi).max()))
        np.testing.assert_allclose(st.commanded_B, act.wrench_from_input(u, C_BL, suite.mass), rtol=1e-14, atol=1e-14)
        delivered = D_true @ (F * np.asarray(st.on_time) / PERIOD) + np.r_[np.zeros(3), G @ np.asarray(st.wheel_torque)]
        np.testing.assert_allclose(st.delivered_B, delivered, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(
            st.u_delivered, act.input_from_wrench(delivered, C_BL, suite.mass), rtol=1e-12, atol=1e-15
        )
    assert {act.AllocationStatus.Ok, act.AllocationStatus.Saturated} <= statuses


def test_certified_error_set_contains_every_sampled_commanded_minus_delivered_input(suite: A.ActuatorSuite) -> None:
    """Commands inside the MPC's bounds of the preset, at random attitudes, truth errors drawn, wheels dumping and
    a thruster failing half-way: every commanded-minus-delivered input lies in the certified ellipsoids (M38)."""
    setup = A.scenario_actuation("osiris_rex_like", A.PRESET_DIR, PERIOD, 0.55, 3.0)
    assert setup is not None
    E_p, E_T = setup.error_shapes()
    rng = np.random.default_rng(5)
    sys_ = setup.system(7)
    cluster = sys_.cluster.copy()
    cluster.set_fault(11, act.FaultKind.FailedOff, 200 * PERIOD)
    wheels = suite.wheels.copy()
    wheels.set_momentum(np.array([42.0, -42.0, 30.0, -30.0]))
    sys_ = act.ActuationSystem(cluster, wheels, A.actuation_settings(suite))
    worst = np.zeros(2)
    bound = np.r_[[setup.u_max] * 3, [setup.T_max] * 3]
    for k in range(400):
        q = rng.normal(size=4)
        C_BL = np.asarray(_core.so3.rotation_matrix(q / np.linalg.norm(q))).T
        u = rng.uniform(-1.0, 1.0, size=6) * bound * (0.05 if k % 3 == 0 else 1.0)
        st = sys_.step(k * PERIOD, u, C_BL)
        assert st.status in (act.AllocationStatus.Ok, act.AllocationStatus.ThrusterFailed), (k, st.status)
        e = np.asarray(st.u_commanded) - np.asarray(st.u_delivered)
        r = np.array([e[:3] @ np.linalg.solve(E_p, e[:3]), e[3:] @ np.linalg.solve(E_T, e[3:])])
        assert np.all(r <= 1.0), (k, r)
        worst = np.maximum(worst, r)
    assert worst.min() > 1e-3  # not vacuous


def test_disturbance_with_actuation_error_contains_the_minkowski_sum() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        L = rng.normal(size=(6, 6)) * np.r_[1.0, 1.0, 1.0, 0.01, 0.01, 0.01][:, None]
        P_W = L @ L.T + 1e-6 * np.eye(6)
        B = rng.normal(size=(6, 3)) * np.r_[2.0, 2.0, 2.0, 2.0, 2.0, 2.0][:, None]
        M = rng.normal(size=(3, 3)) * 1e-3
        E = M @ M.T
        P = np.asarray(act.disturbance_with_actuation_error(P_W, B, E))
        w = sample_ellipsoid_surface(P_W, 500, rng)
        e = sample_ellipsoid_surface(E, 500, rng)
        s = w + e @ B.T
        assert np.max(np.einsum("ij,ij->i", s, np.linalg.solve(P, s.T).T)) <= 1.0 + 1e-9
    assert np.array_equal(np.asarray(act.disturbance_with_actuation_error(P_W, B, np.zeros((3, 3)))), P_W)
