"""The Basilisk plant (tubempc.sim.basilisk): the two truths agree open loop, the state conversions are
inverse, the drawn disturbance reaches Basilisk as the increment drawn, what it cannot fly is refused
by name, and the safe abort flies its truth back to the hover."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from tubempc import _core
from tubempc.config import load_config
from tubempc.design.library import initial_tube
from tubempc.models.disturbances import ActuatorMismatch, AdditiveDisturbance
from tubempc.scenario import P_STATES, R_STATES, build_scenario
from tubempc.scenario.build import propagator_settings
from tubempc.sim.basilisk import (
    BasiliskPlant,
    BasiliskPlantError,
    BasiliskTruth,
    cross_check,
    split_increment,
    unsupported,
)
from tubempc.sim.closed_loop import simulate
from tubempc.sim.plant import ProjectPlant

pytest.importorskip("Basilisk")  # tubempc.sim.basilisk imports Basilisk when a plant is built


@pytest.fixture(scope="module")
def scenario(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    cfg = load_config().with_overrides({"simulation.plant": "basilisk"})
    return build_scenario(cfg, cache_dir=tmp_path_factory.mktemp("cache"))


def test_open_loop_agrees_with_the_project_plant(scenario) -> None:  # type: ignore[no-untyped-def]
    """The paper mission's reference inputs, open loop, through both truths: the positions differ by less
    than 1 % of TBMPC's smallest position semi-axis at every step. The rest is explained in docs/model.md
    ("Basilisk plant"): the force held fixed in N over a segment (the project holds u_p fixed in L), the
    exact solar tide against Hill's linear one, and RK4 in N against RK4 in L. Without the spin message,
    the Sun's position relative to the asteroid, or the ephemeris before the spacecraft, the difference is
    orders of magnitude larger."""
    _, Pe = initial_tube(scenario)
    semi_axis = math.sqrt(float(np.linalg.eigvalsh(Pe[0:3, 0:3]).min()))
    check = cross_check(scenario)
    assert len(check.position_m) == scenario.n_steps
    assert np.all(check.position_m < 0.01 * semi_axis), (check.position_m.max(), semi_axis)
    assert check.position_m.max() < 1e-6  # measured 5e-8 m; 1.6e-4 m with the force turned into N at the start
    assert check.velocity_m_s.max() < 1e-6
    assert check.attitude_rad.max() < 1e-9
    assert check.rate_rad_s.max() < 1e-12


def test_states_convert_both_ways(scenario) -> None:  # type: ignore[no-untyped-def]
    truth = BasiliskTruth(scenario, scenario.model.state_to_truth(scenario.x0))
    rng = np.random.default_rng(4)
    for t in (0.0, 317.0, 5000.0):
        q = rng.standard_normal(4)
        state = np.concatenate([rng.standard_normal(3) * 500, rng.standard_normal(3) * 0.1, q / np.linalg.norm(q)])
        state = np.concatenate([state, rng.standard_normal(3) * 1e-3])
        back = truth.from_basilisk(t, *truth.to_basilisk(t, state))
        np.testing.assert_allclose(back[:6], state[:6], rtol=0, atol=1e-9)
        assert abs(abs(float(back[6:10] @ state[6:10])) - 1.0) < 1e-12
        np.testing.assert_allclose(back[10:], state[10:], rtol=0, atol=1e-15)
    # the hub read back after initialisation is the initial state
    np.testing.assert_allclose(truth.state(), scenario.model.state_to_truth(scenario.x0), atol=1e-9)


def test_split_increment_is_the_double_integrator_inverse() -> None:
    d_pos, d_vel, h = np.array([1e-3, -2e-3, 5e-4]), np.array([3e-4, 1e-4, -2e-4]), 1.0
    a1, a2 = split_increment(d_pos, d_vel, h)
    v1 = a1 * h
    np.testing.assert_allclose(v1 + a2 * h, d_vel, rtol=1e-14, atol=0)
    np.testing.assert_allclose(0.5 * a1 * h**2 + v1 * h + 0.5 * a2 * h**2, d_pos, rtol=1e-14, atol=1e-18)


def test_drawn_disturbance_reaches_basilisk_as_drawn(scenario) -> None:  # type: ignore[no-untyped-def]
    """Only the paper's drawn disturbance, no input: over a period, Basilisk's state with the draw minus its
    state without it is the draw. Translation to 1e-6 of the draw (the gravity gradient's coupling over
    2 s); attitude to 2 % (the body turns while the torque acts: the draw's rotation vector is in the
    controller's phi coordinates at the period's start)."""
    cfg = scenario.config
    d = cfg.disturbance
    zero = np.zeros((6, 6))
    no_error = ActuatorMismatch(0, 0.0, 0.0, 0.0, 0.0)
    settings = propagator_settings(cfg)
    state0 = scenario.model.state_to_truth(scenario.x0)
    for seed in (5, 6):
        drawn = BasiliskPlant(scenario, AdditiveDisturbance(d.S_p, d.S_r, seed=seed), no_error, settings, state0.copy())
        calm = BasiliskPlant(scenario, AdditiveDisturbance(zero, zero, seed=seed), no_error, settings, state0.copy())
        x_d, w = drawn.step(0, np.zeros(6))
        x_c, w_calm = calm.step(0, np.zeros(6))
        assert not np.any(w_calm) and np.all(np.abs(w) > 0)
        for sx, part, tol in ((P_STATES, w[:6], 1e-6), (R_STATES, w[6:], 2e-2)):
            err = (x_d - x_c)[sx] - part
            assert np.linalg.norm(err[:3]) <= tol * np.linalg.norm(part[:3]), (sx, err, part)
            assert np.linalg.norm(err[3:]) <= tol * np.linalg.norm(part[3:]), (sx, err, part)


def test_closed_loop_flies_and_names_its_plant(scenario) -> None:  # type: ignore[no-untyped-def]
    rec = simulate(scenario, "ffa", seed=1, max_steps=5, design_worker="inline")
    assert rec.applied["plant"]["name"] == "basilisk" and rec.applied["plant"]["bsk"]
    assert np.all(np.isfinite(rec.x)) and np.all(rec.excursion <= 1.0)


def test_navigation_flies_with_the_noise_of_forces_and_torques(scenario, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """With navigation, a Basilisk run's filter takes the draw as Basilisk delivers it (docs/model.md M39):
    no attitude noise, the gyro measuring the torques' turn."""
    from tubempc.sim import closed_loop

    scn = dataclasses.replace(scenario, config=scenario.config.with_overrides({"navigation.enabled": True}))
    built: list[np.ndarray] = []
    new_navigation = closed_loop.new_navigation

    def spy(scn, seed, delivery="jump"):  # type: ignore[no-untyped-def]
        nav = new_navigation(scn, seed, delivery)
        built.append(np.asarray(nav.system.settings.period_noise_sigma))
        return nav

    monkeypatch.setattr(closed_loop, "new_navigation", spy)
    rec = simulate(scn, "ffa", seed=1, max_steps=2, design_worker="none")
    assert rec.navigation is not None and np.all(np.isfinite(rec.navigation.x_hat))
    assert len(built) == 1 and np.all(built[0][:6] > 0.0) and np.all(built[0][6:] == 0.0)


def test_refused_by_name(scenario, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    assert unsupported(scenario) == []
    odd = build_scenario(scenario.config.with_overrides({"simulation.integrator": "dopri5"}), cache_dir=tmp_path)
    assert "simulation.integrator" in " ".join(unsupported(odd))
    with pytest.raises(BasiliskPlantError, match=r"simulation\.integrator"):
        BasiliskTruth(odd, scenario.model.state_to_truth(scenario.x0))


def test_another_sun_flies(scenario, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """The Sun is the plant's (its state relative to the asteroid, written each step), not Basilisk's
    ephemeris of planets: another mu_sun and distance still agree with the project's plant."""
    cfg = scenario.config.with_overrides({"environment.mu_sun": 1.0e20, "environment.R": 1.2e11})
    check = cross_check(build_scenario(cfg, cache_dir=tmp_path), steps=60)
    assert check.position_m.max() < 1e-6


def test_project_plant_is_unchanged_by_the_split(scenario) -> None:  # type: ignore[no-untyped-def]
    """The project's plant (the default) still draws and adds w to x_{k+1} (paper Eq. 16)."""
    cfg = scenario.config
    d = cfg.disturbance
    plant = ProjectPlant(
        scenario,
        AdditiveDisturbance(d.S_p, d.S_r, seed=2),
        ActuatorMismatch(0, 0.0, 0.0, 0.0, 0.0),
        propagator_settings(cfg),
        scenario.model.state_to_truth(scenario.x0),
    )
    prop = scenario.truth.propagate(0.0, plant.state, np.zeros(6), cfg.mpc.dt, settings=propagator_settings(cfg))
    x_next, w = plant.step(0, np.zeros(6))
    free = scenario.truth.truth_to_state(np.asarray(prop.state), scenario.reference.x[1, 6:9])
    np.testing.assert_allclose(x_next - free, w, atol=1e-12)
    assert _core is not None


@pytest.fixture(scope="module")
def osirisrex(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    cfg = load_config(scenario="bennu-tag-osirisrex").with_overrides({"simulation.plant": "basilisk"})
    return build_scenario(cfg, cache_dir=tmp_path_factory.mktemp("cache"))


def test_a_pulse_delivers_its_impulse(osirisrex) -> None:  # type: ignore[no-untyped-def]
    """A 0.7 s pulse of one thruster inside a 2 s period (Basilisk's step 1 s): the velocity change against
    an unfired twin is (1 + s) F tau / m along the thruster's true direction, to 1e-9 of it (a step that
    ended past the pulse's end would lose or add up to half of it)."""
    state0 = osirisrex.model.state_to_truth(osirisrex.x0)
    system = osirisrex.actuation.system(1)
    fired, idle = BasiliskTruth(osirisrex, state0, system), BasiliskTruth(osirisrex, state0, system)
    n = len(system.cluster)
    on = np.zeros(n, dtype=bool)
    on[3] = True
    zero, no_torque = np.zeros(3), np.zeros(len(system.wheels))
    fired.advance(700_000_000, zero, zero, on, no_torque)
    fired.advance(2_000_000_000, zero, zero, np.zeros(n, dtype=bool), no_torque)
    idle.advance(2_000_000_000, zero, zero, np.zeros(n, dtype=bool), no_torque)
    dv_L = fired.state()[3:6] - idle.state()[3:6]
    column = np.asarray(system.cluster.true_mapping)[:3, 3]  # (1 + s) R d
    C_LB = np.asarray(_core.so3.rotation_matrix(state0[6:10]))
    expected = C_LB @ column * system.cluster.thruster(3).max_thrust * 0.7 / system.settings.mass
    # the body turns by ~omega dt during the 2 s: the pulse's direction in L moves by that much
    assert np.linalg.norm(dv_L - expected) < 2e-3 * np.linalg.norm(expected), (dv_L, expected)


def test_thrusters_and_wheels_fly_the_tag(osirisrex) -> None:  # type: ignore[no-untyped-def]
    """bennu-tag-osirisrex on Basilisk's thrusters and wheels: the first 20 steps of TBMPC-FFA stay in the
    tube, and Basilisk's wheel momenta are the project's accounting of the torques it commanded."""
    rec = simulate(osirisrex, "ffa", seed=0, max_steps=20, design_worker="inline")
    assert np.all(np.isfinite(rec.x)) and np.all(rec.excursion <= 1.0)
    assert rec.pulses.sum() > 0
    assert rec.applied["plant"]["actuators"].startswith("thrusterDynamicEffector")
    cfg = osirisrex.config
    zero = np.zeros((6, 6))
    system = osirisrex.actuation.system(1)
    plant = BasiliskPlant(
        osirisrex,
        AdditiveDisturbance(zero, zero, seed=0),
        ActuatorMismatch(0, 0.0, 0.0, 0.0, 0.0),
        propagator_settings(cfg),
        osirisrex.model.state_to_truth(osirisrex.x0),
        system,
    )
    assert plant.bsk is not None
    h0_basilisk, h0_project = (
        plant.bsk.wheel_momentum(),
        np.array(system.wheels.momentum),
    )  # a copy: the property views the live state
    for k in range(5):
        plant.step(k, np.array([0.0, 0.0, 0.0, 0.05, -0.03, 0.02]))
    dh_project = np.asarray(system.wheels.momentum) - h0_project
    assert np.linalg.norm(dh_project) > 0.1
    np.testing.assert_allclose(plant.bsk.wheel_momentum() - h0_basilisk, dh_project, rtol=1e-9, atol=1e-12)


def test_the_accelerometer_senses_the_pulses(osirisrex) -> None:  # type: ignore[no-untyped-def]
    """With navigation on Basilisk's thrusters, each IMU sample's specific force is the mean over its 0.1 s
    of the pulses Basilisk fires (M34, centred in the period), not the period's average: the samples add up
    to the on-times' impulse per unit mass in B, the ones outside every pulse sense only the SRP, and a
    pulse shorter than the period senses more than the average."""
    from tubempc.scenario.navigation import Navigation

    cfg = osirisrex.config
    zero = np.zeros((6, 6))
    system = osirisrex.actuation.system(1)
    plant = BasiliskPlant(
        osirisrex,
        AdditiveDisturbance(zero, zero, seed=0),
        ActuatorMismatch(0, 0.0, 0.0, 0.0, 0.0),
        propagator_settings(cfg),
        osirisrex.model.state_to_truth(osirisrex.x0),
        system,
    )
    srp_L = np.asarray(osirisrex.truth.srp_acceleration_L, dtype=np.float64)
    h, dt = 0.1, cfg.mpc.dt
    plant.nav = nav = Navigation(system=None, scale=1.0, h=h, n_sub=round(dt / h), srp_L=srp_L)
    plant.step(0, np.array([2e-4, -1e-4, 3e-4, 0.0, 0.0, 0.0]))
    u_average, st = plant.delivered
    on_time = np.asarray(st.on_time, dtype=np.float64)
    assert 0.0 < on_time.max() < 0.5 * dt
    C_BL = np.stack([np.asarray(_core.so3.rotation_matrix(x[6:10])).T for x in nav.truth])
    f_B = np.einsum("jab,jb->ja", C_BL, nav.accel - srp_L)  # what the IMU is told, in B
    impulse_B = plant.thrust_B @ (np.round(on_time * 1e9) / 1e9) / plant.bsk.mass  # type: ignore[union-attr]
    np.testing.assert_allclose(f_B.sum(axis=0) * h, impulse_B, rtol=1e-12, atol=1e-18)
    quiet = np.linalg.norm(f_B, axis=1) == 0.0
    assert quiet.sum() >= 10  # the pulses centred in the period leave its ends quiet: SRP only
    assert np.linalg.norm(f_B, axis=1).max() > 1.5 * np.linalg.norm(u_average[:3])


def test_basilisk_volume_is_right_only_about_the_origin() -> None:
    """Basilisk's polyhedral volume (the trap the plant works around): a unit cube about the origin has
    volume 1; moved 5 m away, Basilisk's formula counts more."""
    from tubempc.sim.basilisk import basilisk_volume

    v = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    from scipy.spatial import ConvexHull

    hull = ConvexHull(v)
    faces = np.array(hull.simplices, dtype=np.int64)
    assert basilisk_volume(v, faces) == pytest.approx(1.0, rel=1e-12)
    assert basilisk_volume(v + np.array([5.0, 0.0, 0.0]), faces) > 1.5


def test_physical_environment_agrees_with_the_project_plant(tmp_path: Path) -> None:
    """bennu-tag-physical open loop (its heterogeneous body, plates, shadow, gravity gradient, truth mass and
    inertia) through both plants: 1e-6 m and 1e-6 rad after 40 steps. Without the lobe's mu corrected for
    Basilisk's volume, or with the parts' internal pull left in, the positions part by millimetres."""
    cfg = load_config(scenario="bennu-tag-physical").with_overrides({"simulation.plant": "basilisk"})
    check = cross_check(build_scenario(cfg, cache_dir=tmp_path), steps=40)
    assert check.position_m.max() < 1e-6
    assert check.attitude_rad.max() < 1e-6


def test_a_campaign_run_flies_the_same_dispersed_truth_in_both_plants(tmp_path: Path) -> None:
    """A dispersed run of bennu-tag-physical (a campaign's run, seed 17) in Basilisk: Basilisk is given the drawn
    truth (the hub's mass and inertia, each body part's mu from the drawn densities, the plates' drawn lever arms
    and coefficients), both plants record the same truth, fly the same closed loop to 1e-6 m, and open loop the
    same dispersed truth agrees while the nominal one lies millimetres away."""
    from tubempc.sim.basilisk import basilisk_volume
    from tubempc.sim.closed_loop import _new_plant
    from tubempc.sim.setup import run_truth

    seed = 17
    cfg = load_config(scenario="bennu-tag-physical")
    project_scn = build_scenario(cfg, cache_dir=tmp_path)
    bsk_scn = build_scenario(cfg.with_overrides({"simulation.plant": "basilisk"}), cache_dir=tmp_path)
    truth = project_scn.physical.dispersed(seed)
    plant = _new_plant(bsk_scn, seed, True)
    assert isinstance(plant, BasiliskPlant) and plant.bsk is not None
    assert plant.bsk.mass == truth.mass_true != bsk_scn.physical.mass_true
    np.testing.assert_array_equal(plant.bsk.hub_inertia_B, truth.inertia_true_B)
    g = _core.gravity.GRAVITATIONAL_CONSTANT
    expected_mu = [
        g * p.density * basilisk_volume(np.asarray(p.shape.vertices) + p.offset_A, np.asarray(p.shape.faces))
        for p in truth.parts
    ]
    np.testing.assert_allclose(plant.bsk.part_mu, expected_mu, rtol=1e-15)
    for mine, drawn in zip(plant.physical.plates, truth.plates, strict=True):  # type: ignore[union-attr]
        np.testing.assert_array_equal(mine.center_B, drawn.center_B)
        assert (mine.specular, mine.diffuse) == (drawn.specular, drawn.diffuse)
    np.testing.assert_array_equal(plant.environment.thrust_error_B, truth.thrust_error_B)
    # the closed loop: both records keep the same truth, the states agree
    runs = [simulate(s, "tbmpc", seed, max_steps=4, dispersed=True) for s in (project_scn, bsk_scn)]
    assert runs[0].applied["truth"] == runs[1].applied["truth"]
    assert runs[0].applied["actuators"] == runs[1].applied["actuators"]
    assert np.max(np.abs(runs[0].x[:, :3] - runs[1].x[:, :3])) < 1e-6
    # open loop: the dispersed truth in both plants agrees; the nominal truth flies elsewhere
    check = cross_check(bsk_scn, steps=20, dispersed_seed=seed)
    assert check.position_m.max() < 1e-6 and check.attitude_rad.max() < 1e-6
    ends = []
    for dispersed in (False, True):
        model, physical = run_truth(project_scn, seed, dispersed)
        assert physical is not None
        p = ProjectPlant(
            project_scn,
            AdditiveDisturbance(np.zeros((6, 6)), np.zeros((6, 6)), seed=0),
            ActuatorMismatch(0),
            propagator_settings(cfg),
            project_scn.model.state_to_truth(project_scn.x0),
            environment=physical.environment(),
            truth=model,
            physical=physical,
        )
        for k in range(20):
            p.step(k, project_scn.reference.u[k])
        ends.append(p.state[:3].copy())
    assert np.linalg.norm(ends[1] - ends[0]) > 1e-3


def test_a_camera_outage_in_basilisk_backs_away_certified(tmp_path: Path) -> None:
    """bennu-tag-faults with Basilisk as the truth and a camera outage from 100 s: the navigation's detection enters
    the safe abort, which flies Basilisk's truth back to the hover on tubes certified at every step and ends safe."""
    from tubempc.analysis.runner import aborted, guarantee_lost, run_summary

    cfg = load_config(scenario="bennu-tag-faults").with_overrides(
        {
            "simulation.plant": "basilisk",
            "faults.random": False,
            "faults.kind": "camera_outage",
            "faults.start": "100 s",
            "abort.entry_period": 25,
        }
    )
    scn = build_scenario(cfg, cache_dir=tmp_path)
    rec = simulate(scn, "ffa", seed=3, design_worker="none")
    assert rec.applied is not None and rec.applied["plant"]["name"] == "basilisk"
    s = run_summary(scn, rec)
    a = s.abort
    assert a is not None and a.outcome == "aborted" and a.cause == "navigation_fault"
    assert 100.0 < a.entered_at <= 100.0 + 2.0 * cfg.faults.outage_time
    assert a.safe and a.uncertified_steps == 0 and a.max_residual is not None and a.max_residual <= 0.0
    assert a.final_height == pytest.approx(cfg.abort.hover_altitude, abs=2.0)
    assert a.states_inside_body == 0 and a.max_glide_slope_g is not None and a.max_glide_slope_g <= 0.0
    assert not guarantee_lost(s) and aborted(s)  # exit status 7
