"""Navigation in the closed loop (docs/model.md "Output-feedback tube"; tubempc.scenario.navigation): the
[navigation] section, off leaving a run untouched, a short descent flown on the estimate, broken
sensors, the output-feedback tube's gauge and the record's round trip."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize
import scipy.special

from tubempc import _core
from tubempc.analysis.metrics import run_metrics
from tubempc.config import ConfigError, load_config
from tubempc.results import load_record, save_record
from tubempc.scenario import build_scenario
from tubempc.scenario.navigation import (
    DISTURBANCE_DELIVERIES,
    NavigationRecord,
    error_set_scale,
    navigation_settings,
    tube_gauge,
)
from tubempc.sim import closed_loop
from tubempc.sim.basilisk import BasiliskPlant
from tubempc.sim.closed_loop import simulate
from tubempc.sim.plant import ProjectPlant


@pytest.fixture(scope="module")
def tag_nav(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return build_scenario(load_config(scenario="bennu-tag-nav"), cache_dir=tmp_path_factory.mktemp("cache"))


def test_navigation_is_off_by_default_and_bad_fields_are_named() -> None:
    cfg = load_config()
    assert cfg.navigation.enabled is False
    with pytest.raises(ConfigError, match=r"navigation\.camera_period.*integer multiple"):
        cfg.with_overrides({"navigation.camera_period": "0.25 s"})
    with pytest.raises(ConfigError, match=r"navigation\.imu_period.*mpc\.dt"):
        cfg.with_overrides({"navigation.imu_period": "0.5 s", "mpc.dt": "0.75 s"})
    with pytest.raises(ConfigError, match=r"navigation\.site_landmarks"):
        cfg.with_overrides({"navigation.site_landmarks": 10})
    with pytest.raises(ConfigError, match=r"navigation\.altimeter_max_range"):
        cfg.with_overrides({"navigation.altimeter_max_range": "0.5 m"})
    with pytest.raises(ConfigError, match=r"navigation\.enabled: expected true or false"):
        cfg.with_overrides({"navigation.enabled": "yes"})
    capacity = _core.nav.MAX_LANDMARKS_PER_FRAME
    with pytest.raises(ConfigError, match=rf"navigation\.camera_max_landmarks: expected in \[1, {capacity}\]"):
        cfg.with_overrides({"navigation.camera_max_landmarks": capacity + 1})
    for sensor in ("camera", "altimeter"):
        with pytest.raises(ConfigError, match=rf"navigation\.{sensor}_boresight_B: expected non-zero"):
            cfg.with_overrides({f"navigation.{sensor}_boresight_B": [0.0, 0.0, 0.0]})
    # the C++ settings take the section's values (the camera's focal length from its field of view)
    s = navigation_settings(cfg)
    assert s.camera.focal_length_px == pytest.approx(1024 / (2 * np.tan(cfg.navigation.camera_fov / 2)))
    assert s.filter.camera.pixel_sigma == s.camera.pixel_sigma == cfg.navigation.camera_pixel_sigma


def test_an_off_section_changes_nothing(tmp_path: Path) -> None:
    """With enabled = false every other [navigation] value is unused: the runs are identical to the bit
    (the default run against the code before navigation: tools/compare_runs.py, docs/decisions.md)."""
    base = load_config()
    other = base.with_overrides(
        {"navigation.camera_pixel_sigma": 5.0, "navigation.imu_period": "1 s", "navigation.landmarks": 3}
    )
    runs = [simulate(build_scenario(c, cache_dir=tmp_path), "ffa", seed=2, max_steps=4) for c in (base, other)]
    assert runs[0].navigation is None and runs[1].navigation is None
    for f in dataclasses.fields(runs[0]):
        a, b = getattr(runs[0], f.name), getattr(runs[1], f.name)
        if f.name.startswith("time_") or f.name == "wall_time_s":
            continue
        if isinstance(a, np.ndarray):
            assert a.tobytes() == b.tobytes(), f.name
        else:
            assert a == b, f.name


def test_a_short_descent_on_the_estimate(tag_nav, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    rec = simulate(tag_nav, "ffa", seed=1, max_steps=20, design_worker="none")
    nav = rec.navigation
    assert nav is not None and nav.x_hat.shape == (21, 12)
    assert set(nav.status) == {"ok"}
    assert np.all(np.isfinite(nav.x_hat)) and np.all(np.isfinite(rec.u))
    assert nav.landmarks.min() >= 1  # the site map is in view
    # the estimate is what the controller flew: x_hat != x, but close to it
    assert np.all(np.abs(nav.error[:, :3]) > 0) and np.max(np.abs(nav.error[:, :3])) < 5.0
    # the estimation error stays inside its 3-sigma bounds most of the time (99.7 % for a consistent filter)
    inside = np.abs(nav.error) <= 3.0 * nav.sigma
    assert inside.mean() > 0.95, inside.mean(axis=0)
    # and it shrinks from the initial 1 m: the landmarks are used
    assert np.linalg.norm(nav.error[-1, :3]) < 0.2
    # the true state stays in the output-feedback tube z + Omega (+) E, the estimate in Omega
    assert np.all(nav.gauge <= 1.0) and np.all(nav.gauge_estimate <= 1.0)
    path = save_record(tmp_path / "ffa.h5", rec, config=tag_nav.config.to_dict())
    again, _ = load_record(path)
    assert again.navigation is not None
    np.testing.assert_array_equal(again.navigation.x_hat, nav.x_hat)
    assert again.navigation.sensor_status == nav.sensor_status
    # every step's navigation call is timed (bench controller's navigation figures), and kept
    assert nav.time_step.shape == (20,) and np.all(nav.time_step > 0.0)
    np.testing.assert_array_equal(again.navigation.time_step, nav.time_step)
    # the samples per sensor: the initial call samples each once, a 2 s period the 20 IMU samples of 0.1 s,
    # one camera frame (2 s) and two altimeter and star-tracker samples (1 s); kept in the file
    np.testing.assert_array_equal(nav.samples[0], [1, 1, 1, 1])
    np.testing.assert_array_equal(nav.samples[1:], np.tile([2, 1, 20, 2], (20, 1)))
    np.testing.assert_array_equal(again.navigation.samples, nav.samples)
    old = NavigationRecord.from_arrays({k: v for k, v in nav.arrays().items() if k != "nav_samples"})
    assert old is not None and old.samples.shape == (21, 4) and np.all(np.isnan(old.samples))  # unknown
    # the run's summary of its navigation (tubempc.analysis.metrics.navigation_summary)
    s = run_metrics(rec, tag_nav.config.mpc.dt, tag_nav.xf).navigation
    assert s is not None and s.nees is not None and s.nees.steps == 21 and s.nees.dof == 15
    assert s.touchdown_error.position == pytest.approx(np.linalg.norm(nav.error[-1, :3]), rel=1e-15)
    assert s.nees.mean == pytest.approx(np.mean(nav.nees), rel=1e-12)
    assert s.camera_frames == 21 and s.landmarks_used == int(nav.accepted[:, 1].sum()) > 0
    assert s.max_gauge.translation == nav.gauge[:, 0].max() and s.steps_outside_output_tube == 0


def test_period_noise_is_what_the_plants_delivery_leaves_unsensed(tag_nav, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """M39: the project's plant adds the draw at the period's end, where nothing senses it (noise on r, v and
    the attitude); Basilisk's applies it as half-period forces and torques, whose turn the gyro measures (no
    attitude noise); without a draw (the physical environment) both keep the jump's; a run hands its plant's
    delivery to the navigation."""
    cfg = tag_nav.config
    d, n = cfg.disturbance, cfg.navigation
    var = np.concatenate([np.diag(d.S_p) * max(1.0, d.growth_p) ** 2, np.diag(d.S_r)[:3] * max(1.0, d.growth_r) ** 2])
    drawn = n.period_noise_scale * np.sqrt(var / 8.0)  # a uniform draw in a 6-dimensional ellipsoid: S / 8
    assert drawn[6:].min() > 0.0
    jump = np.asarray(navigation_settings(cfg).period_noise_sigma)
    forces = np.asarray(navigation_settings(cfg, "half_period_forces").period_noise_sigma)
    np.testing.assert_allclose(jump, drawn, rtol=1e-14)
    np.testing.assert_array_equal(forces[:6], jump[:6])
    np.testing.assert_array_equal(forces[6:], np.zeros(3))
    physical = load_config(scenario="bennu-tag-physical")
    no_draw = [navigation_settings(physical, delivery).period_noise_sigma for delivery in DISTURBANCE_DELIVERIES]
    np.testing.assert_array_equal(no_draw[0], no_draw[1])
    with pytest.raises(ValueError, match="disturbance delivery 'impulse'"):
        navigation_settings(cfg, "impulse")
    assert (ProjectPlant.DISTURBANCE_DELIVERY, BasiliskPlant.DISTURBANCE_DELIVERY) == DISTURBANCE_DELIVERIES
    handed: list[str] = []

    def spy(scn, seed, delivery="jump"):  # type: ignore[no-untyped-def]
        handed.append(delivery)
        return new_navigation(scn, seed, delivery)

    new_navigation = closed_loop.new_navigation
    monkeypatch.setattr(closed_loop, "new_navigation", spy)
    simulate(tag_nav, "ffa", seed=0, max_steps=1, design_worker="none")
    assert handed == ["jump"]


def test_broken_sensors_fly_on_prediction_without_nan(tag_nav) -> None:  # type: ignore[no-untyped-def]
    cfg = tag_nav.config.with_overrides(
        {
            "navigation.camera_max_range": "2 m",  # no landmark is that close
            "navigation.altimeter_max_range": "2 m",  # nor the surface
            "navigation.star_tracker_dropout": 1.0,
        }
    )
    scn = dataclasses.replace(tag_nav, config=cfg)
    rec = simulate(scn, "tbmpc", seed=0, max_steps=8, design_worker="none")
    nav = rec.navigation
    assert nav is not None
    assert set(nav.status) == {"prediction_only"}
    assert set(nav.sensor_status) == {"out_of_range/no_landmark_visible/ok/dropout"}
    assert nav.landmarks.max() == 0
    assert np.all(np.isfinite(rec.u)) and np.all(np.isfinite(nav.x_hat)) and np.all(np.isfinite(nav.sigma))
    assert np.all(np.diff(nav.sigma[:, 0]) > 0)  # the uncertainty grows on prediction alone
    assert all(s in ("solved", "solved_inaccurate", "max_iterations") for s in rec.statuses), rec.statuses


def test_tube_gauge_is_the_minkowski_sums_support_gauge() -> None:
    """The gauge of e in Pe (+) E equals max_d d.e / (h_Pe(d) + h_E(d)) (support functions): sampled
    directions never exceed it and a local optimisation from the best of them reaches it."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        A, B = rng.standard_normal((2, 6, 6))
        Pe, E = A @ A.T + 0.1 * np.eye(6), 0.3 * (B @ B.T) + 0.01 * np.eye(6)
        e = rng.standard_normal(6)
        g = tube_gauge(e, Pe, E)
        d = rng.standard_normal((5000, 6))
        ratio = d @ e / (np.sqrt(np.einsum("ij,jk,ik->i", d, Pe, d)) + np.sqrt(np.einsum("ij,jk,ik->i", d, E, d)))
        assert ratio.max() <= g * (1 + 1e-9)
        best = scipy.optimize.minimize(
            lambda v, e=e, Pe=Pe, E=E: -(v @ e) / (np.sqrt(v @ Pe @ v) + np.sqrt(v @ E @ v)),
            d[np.argmax(ratio)],
            method="BFGS",
        )
        assert g * (1 - 1e-6) <= -best.fun <= g * (1 + 1e-9)
    # the chi-square quantile against the regularised incomplete gamma function: P(chi2_12 <= c) = P(6, c / 2)
    assert scipy.special.gammainc(6.0, error_set_scale(0.9973, 12) / 2.0) == pytest.approx(0.9973, abs=1e-12)


def test_touchdown_dispersion_ellipse_holds_its_share_of_a_gaussian_sample() -> None:
    """The figure's ellipse of probability p holds about p of a large Gaussian sample (its fit)."""
    from tubempc.analysis import figures

    rng = np.random.default_rng(0)
    L = np.array([[0.3, 0.0], [0.2, 0.1]])
    pts = rng.standard_normal((4000, 2)) @ L.T + [0.05, -0.02]
    fig = figures.touchdown_dispersion(pts, "test", probability=0.9)
    ring = fig.axes[0].lines[1].get_xydata()
    from matplotlib.path import Path as MplPath

    share = MplPath(ring).contains_points(pts).mean()
    assert share == pytest.approx(0.9, abs=0.015)


def test_claims_table_gets_navigation_rows_only_for_a_run_on_navigation(tmp_path: Path) -> None:
    """A whole bennu-tag-nav descent (TBMPC-FFA): the claims table's navigation rows are measured and
    hold (touchdown within 1 m and 2 cm/s, the truth in the output-feedback tube, errors within 3 sigma);
    a record without navigation gets none."""
    from tubempc.analysis.claims import paper_claims
    from tubempc.analysis.runner import run_methods

    cfg = load_config(scenario="bennu-tag-nav").with_overrides({"tube.design_worker": "none"})
    run_methods(cfg, ["ffa"], 0, tmp_path / "nav", progress=False, cache_dir=tmp_path / "cache", make_figures=False)
    rows = [c for c in paper_claims(tmp_path / "nav") if "on navigation" in c.claim.lower()]
    assert len(rows) == 3 and all(c.verdict == "yes" for c in rows), [(c.claim, c.measured) for c in rows]
    # both methods on navigation: the J_p reduction row (issue #30's 80 %) against the summary's J_p
    summary = json.loads((tmp_path / "nav" / "summary.json").read_text())
    # the summary says how the navigation went (issue #40): finite figures, the whole descent's steps
    nav = summary["methods"]["ffa"]["navigation"]
    assert nav["nees"]["steps"] == 151 and nav["nees"]["dof"] == 15 and nav["camera_frames"] == 151
    assert nav["nees"]["lower"] < 15.0 < nav["nees"]["upper"] and isinstance(nav["nees"]["inside"], bool)
    figures = [*nav["touchdown_error"].values(), nav["nees"]["mean"], *nav["max_gauge"].values()]
    figures += [nav["landmarks_per_frame_mean"], nav["landmarks_per_frame_min"]]
    assert np.all(np.isfinite(figures)) and 0 <= nav["landmarks_per_frame_min"] <= nav["landmarks_per_frame_mean"]
    assert nav["landmarks_used"] == round(nav["landmarks_per_frame_mean"] * 151) > 151  # over 1 landmark a frame
    assert nav["touchdown_error"]["position"] < 0.2 and nav["steps_outside_output_tube"] == 0
    shutil.copytree(tmp_path / "nav", tmp_path / "both")
    shutil.copy(tmp_path / "nav" / "ffa.h5", tmp_path / "both" / "tbmpc.h5")
    for factor, verdict in ((5.5, "yes"), (4.5, "no")):
        ffa = summary["methods"]["ffa"]
        summary["methods"]["tbmpc"] = {**ffa, "J_p": factor * ffa["J_p"]}
        (tmp_path / "both" / "summary.json").write_text(json.dumps(summary))
        row = [c for c in paper_claims(tmp_path / "both") if c.claim.startswith("On navigation")]
        assert len(row) == 1 and row[0].verdict == verdict, (factor, row)
        assert f"{100 * (1 - 1 / factor):.1f} %" in row[0].measured
    # the same folder with the records of a run on the true state (no nav_* arrays): no navigation row
    rec, _ = load_record(tmp_path / "nav" / "ffa.h5")
    rec.navigation = None
    save_record(tmp_path / "nav" / "ffa.h5", rec, config=cfg.to_dict())
    assert not [c for c in paper_claims(tmp_path / "nav") if "on navigation" in c.claim.lower()]
