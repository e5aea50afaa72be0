"""Faults injected into a run and the navigation's fault detection (docs/model.md M49-M51; [faults],
tubempc.scenario.faults, nav/faults.hpp): the section's errors name the field, a random fault is drawn from the
seed and reproduced, each sensor fault changes its sensor's output, the burst scales the drawn disturbance, and a
camera outage is reported detected with its latency."""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np
import pytest

from tubempc import _core
from tubempc.analysis.metrics import run_metrics
from tubempc.config import ConfigError, load_config
from tubempc.results.summaries import RunMetrics
from tubempc.scenario import build_scenario
from tubempc.scenario.faults import run_fault
from tubempc.sim.closed_loop import simulate

ALT, CAM, IMU, STAR = 0, 1, 2, 3


@pytest.fixture(scope="module")
def tag_nav(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return build_scenario(load_config(scenario="bennu-tag-nav"), cache_dir=tmp_path_factory.mktemp("cache"))


def _with(scn: Any, overrides: dict[str, Any]) -> Any:
    return dataclasses.replace(scn, config=scn.config.with_overrides(overrides))


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"faults.kind": "blind_camera"}, "faults.kind"),
        ({"faults.random_kinds": "camera_outage,solar_flare"}, "faults.random_kinds"),
        ({"faults.random": True, "faults.random_window": {"value": [10.0, 900.0], "unit": "s"}}, "faults.random_window"),
        ({"faults.random_window": {"value": [50.0, 10.0], "unit": "s"}}, "faults.random_window"),
        ({"faults.kind": "camera_outage", "faults.start": "2000 s"}, "faults.start"),
        ({"faults.persistence": 0}, "faults.persistence"),
        ({"faults.false_alarm_probability": 1.5}, "faults.false_alarm_probability"),
        ({"faults.outage_time": "0 s"}, "faults.outage_time"),
        ({"faults.altimeter_spike": "3 rad"}, "faults.altimeter_spike"),
        ({"faults.bias_axis_B": [0.0, 0.0, 0.0]}, "faults.bias_axis_B"),
    ],
)
def test_bad_fields_are_named(overrides: dict[str, Any], field: str) -> None:
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        load_config(scenario="bennu-tag-nav").with_overrides(overrides)


def test_no_fault_by_default_and_a_random_fault_is_drawn_from_the_seed() -> None:
    cfg = load_config(scenario="bennu-tag-nav")
    assert cfg.faults.kind == "none" and not cfg.faults.random and run_fault(cfg, 3) is None
    rnd = cfg.with_overrides({"faults.random": True, "faults.random_kinds": "camera_outage, altimeter_spike"})
    draws = [run_fault(rnd, seed) for seed in range(40)]
    assert all(d is not None for d in draws)
    kinds = {d["kind"] for d in draws if d is not None}
    assert kinds == {"camera_outage", "altimeter_spike"}
    starts = np.array([d["start"] for d in draws if d is not None])
    assert np.all((starts >= 20.0) & (starts <= 200.0)) and len(set(starts.tolist())) == 40
    assert run_fault(rnd, 7) == draws[7]  # re-drawn identically: a re-flight flies the same fault
    spike = next(d for d in draws if d is not None and d["kind"] == "altimeter_spike")
    assert spike["magnitude"] == pytest.approx(20.0) and spike["duration"] is None


def _short(scn: Any, overrides: dict[str, Any], steps: int = 4, seed: int = 1) -> Any:
    return simulate(_with(scn, overrides), "tbmpc", seed=seed, max_steps=steps, design_worker="none")


@pytest.fixture(scope="module")
def clean(tag_nav):  # type: ignore[no-untyped-def]
    return _short(tag_nav, {})


@pytest.mark.parametrize(
    ("kind", "sensor"),
    [("camera_outage", CAM), ("altimeter_dropout", ALT), ("star_tracker_loss", STAR)],
)
def test_a_lost_sensor_gives_no_sample(tag_nav, clean, kind: str, sensor: int) -> None:  # type: ignore[no-untyped-def]
    rec = _short(tag_nav, {"faults.kind": kind, "faults.start": "0 s"})
    nav = rec.navigation
    assert nav.accepted[1:, sensor].sum() == 0 < clean.navigation.accepted[1:, sensor].sum()
    assert all(s.split("/")[sensor] == "failed" for s in nav.sensor_status[1:])
    others = [i for i in (ALT, CAM, STAR) if i != sensor]
    assert np.all(nav.accepted[1:, others].sum(axis=0) > 0)
    assert rec.applied["fault"]["kind"] == kind


def test_an_altimeter_spike_is_excluded_and_an_outlier_landmark_rejected(tag_nav, clean) -> None:  # type: ignore[no-untyped-def]
    # from 1 s on (after the initialisation's fold-in): every range refused by the gate, declared at the third
    spike = _short(tag_nav, {"faults.kind": "altimeter_spike", "faults.start": "1 s"}).navigation
    assert spike.excluded[-1, ALT] == 1 and spike.fault_cause[-1] == "altimeter_fault"
    assert spike.fault_cause[1] == "none" and spike.fault_cause[2] == "altimeter_fault"  # ranges at 1, 2, 3 s
    assert spike.accepted[1:, ALT].sum() == 0 and spike.accepted[1:, CAM].sum() > 0
    # from 2 s on: at the initialisation (1 m, 1 mrad sigmas, about 10 px at 125 m) a 200 px outlier passes the
    # default gate (1e4) and corrupts the estimate; after it, the gate refuses it alone
    outlier = _short(tag_nav, {"faults.kind": "landmark_outlier", "faults.start": "2 s"}).navigation
    frames = outlier.samples[1:, CAM] > 0
    assert frames.any()
    rejected_more = (clean.navigation.accepted[1:, CAM] - outlier.accepted[1:, CAM])[frames]
    assert np.all(rejected_more == outlier.samples[1:, CAM][frames])  # one landmark fewer per frame
    assert outlier.fault_cause[-1] == "none"


@pytest.mark.parametrize("kind", ["gyro_bias_step", "accel_bias_step", "gyro_scale_step", "accel_scale_step"])
def test_an_imu_step_moves_the_estimate(tag_nav, clean, kind: str) -> None:  # type: ignore[no-untyped-def]
    rec = _short(tag_nav, {"faults.kind": kind, "faults.start": "0 s"})
    # the truth is the same until the controller reacts to the estimate: the estimate moved first
    d = np.abs(rec.navigation.x_hat[1] - clean.navigation.x_hat[1])
    assert d.max() > 0.0
    group = slice(6, 12) if kind.startswith("gyro") else slice(0, 6)
    assert d[group].max() > 0.0


def test_a_disturbance_burst_scales_the_draw(tmp_path) -> None:  # type: ignore[no-untyped-def]
    scn = build_scenario(load_config(scenario="bennu-tag"), cache_dir=tmp_path)
    base = simulate(scn, "tbmpc", seed=2, max_steps=4, design_worker="none")
    burst = simulate(
        _with(scn, {"faults.kind": "disturbance_burst", "faults.start": "2 s", "faults.duration": "4 s"}),
        "tbmpc",
        seed=2,
        max_steps=4,
        design_worker="none",
    )
    scale = burst.applied["fault"]["magnitude"]
    assert scale == 10.0
    np.testing.assert_array_equal(burst.w_true[0], base.w_true[0])  # t = 0 s: before the burst
    np.testing.assert_allclose(burst.w_true[1:3], scale * base.w_true[1:3], rtol=0, atol=0)  # 2 s and 4 s
    np.testing.assert_array_equal(burst.w_true[3], base.w_true[3])  # 6 s: after it


def test_a_camera_outage_is_reported_detected_with_its_latency(tag_nav) -> None:  # type: ignore[no-untyped-def]
    onset, outage = 10.0, tag_nav.config.faults.outage_time
    rec = _short(tag_nav, {"faults.kind": "camera_outage", "faults.start": f"{onset} s"}, steps=14)
    metrics = run_metrics(rec, tag_nav.config.mpc.dt, tag_nav.reference.x[-1])
    assert RunMetrics.from_json(json.loads(json.dumps(metrics.to_json()))) == metrics  # the summary's round trip
    summary = metrics.navigation
    assert summary is not None and summary.faults is not None
    f = summary.faults
    assert f.injected == "camera_outage" and f.detected and f.cause == "camera_outage"
    assert f.onset == onset and f.latency is not None
    # the last frame before the onset is at 8 s: declared at the first period's end later than 8 s + outage_time
    assert outage - 2.0 < f.latency <= outage
    k = math.ceil(f.detection_time / tag_nav.config.mpc.dt)
    assert rec.navigation.fault_detected[k] == 1 and rec.navigation.fault_detected[k - 1] == 0
    assert rec.navigation.fault_cause[k] == "camera_outage"


def test_chi_square_quantiles_match_scipy() -> None:
    from scipy.stats import chi2

    for q, dof in [(1e-3, 1), (1e-3, 3), (1e-6, 32), (0.05, 128)]:
        assert _core.nav.chi_square_upper_quantile(q, dof) == pytest.approx(chi2.isf(q, dof), rel=1e-10)


def test_a_sensor_fault_needs_navigation() -> None:
    with pytest.raises(ConfigError, match=r"faults\.kind: the sensor fault 'camera_outage' needs navigation\.enabled"):
        load_config(scenario="bennu-tag").with_overrides({"faults.kind": "camera_outage"})
    with pytest.raises(ConfigError, match=r"faults\.random_kinds: the sensor fault 'camera_outage'"):
        load_config(scenario="bennu-tag").with_overrides({"faults.random": True})
    load_config(scenario="bennu-tag").with_overrides({"faults.kind": "disturbance_burst"})  # the plant's: no navigation


def test_an_actuator_fault_needs_actuators_and_names_its_unit() -> None:
    from tubempc.scenario.faults import actuator_fault

    with pytest.raises(ConfigError, match=r"faults\.kind: the actuator fault 'wheel_failure' needs spacecraft\.actuators"):
        load_config(scenario="bennu-tag").with_overrides({"faults.kind": "wheel_failure"})
    cfg = load_config(scenario="bennu-tag-osirisrex").with_overrides(
        {"faults.random": True, "faults.random_kinds": "thruster_stuck_on,wheel_failure"}
    )
    plain = load_config(scenario="bennu-tag-osirisrex").with_overrides(
        {"faults.random": True, "faults.random_kinds": "thruster_stuck_on,wheel_failure,disturbance_burst"}
    )
    seen = set()
    for seed in range(30):
        fault = run_fault(cfg, seed)
        assert fault is not None and 0.0 <= fault["actuator_draw"] < 1.0
        kind, index, onset = actuator_fault(fault, 16, 4)  # type: ignore[misc]
        assert kind == fault["kind"] and onset == fault["start"]
        assert index == int(fault["actuator_draw"] * (4 if kind == "wheel_failure" else 16))
        seen.add(kind)
        # the draw of the unit comes after the kind's and the onset's: a seed's onset does not depend on the kinds
        assert run_fault(plain, seed)["start"] == fault["start"]  # type: ignore[index]
    assert seen == {"thruster_stuck_on", "wheel_failure"}
    given = run_fault(
        cfg.with_overrides({"faults.random": False, "faults.kind": "wheel_failure", "faults.actuator_index": 5}), 0
    )
    with pytest.raises(ValueError, match=r"faults\.actuator_index: 5 is not an index of the 4"):
        actuator_fault(given, 16, 4)
    burst = run_fault(cfg.with_overrides({"faults.random": False, "faults.kind": "disturbance_burst"}), 0)
    assert burst is not None and "actuator_draw" not in burst and actuator_fault(burst, 16, 4) is None


def test_a_failed_wheel_and_a_stuck_thruster_reach_the_run_s_actuators(tmp_path_factory: pytest.TempPathFactory) -> None:
    from tubempc.scenario.actuators import scenario_actuation

    act = scenario_actuation("osiris_rex_like_calibrated", tmp_path_factory.mktemp("a"), 5.0, 1.0, 10.0)
    assert act is not None
    u = np.zeros(6)
    u[3:] = [0.01, -0.02, 0.015]  # N m: the wheels' work
    wheel = act.system(7, ("wheel_failure", 1, 10.0))
    assert wheel.step(5.0, u, np.eye(3)).failed_wheels == 0
    st = wheel.step(10.0, u, np.eye(3))
    assert st.failed_wheels == 1 and st.wheel_torque[1] == 0.0 and np.any(np.asarray(st.wheel_torque) != 0.0)
    stuck = act.system(7, ("thruster_stuck_on", 3, 10.0))
    assert stuck.step(10.0, np.zeros(6), np.eye(3)).failed_thrusters == 1
    assert stuck.step(15.0, np.zeros(6), np.eye(3)).on_time[3] == pytest.approx(5.0)  # fires the whole period
    healthy = act.system(7)
    assert healthy.step(10.0, u, np.eye(3)).failed_wheels == 0
