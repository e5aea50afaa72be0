"""One declaration per field: the field declarations of tubempc.config drive the parser, the packaged
file's field list, docs/configuration.md and the C++ navigation settings."""

from __future__ import annotations

import importlib.util
import tomllib
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc import _core
from tubempc.config import SCENARIOS, Config, NavigationSection, load_config
from tubempc.config.fields import Spec
from tubempc.config.load import DEFAULT_FILE, packaged_text
from tubempc.config.parse import SECTIONS
from tubempc.config.quantities import KINDS
from tubempc.scenario.navigation import navigation_settings

ROOT = Path(__file__).resolve().parents[3]
SENSORS = ("altimeter", "camera", "imu", "star_tracker")


def _specs() -> list[tuple[str, str, Spec]]:
    return [(section, f.name, f.metadata["spec"]) for section, cls in SECTIONS.items() for f in fields(cls)]


def test_the_sections_are_configs_fields_and_the_packaged_files_tables() -> None:
    assert list(SECTIONS) == [f.name for f in fields(Config) if f.name not in ("source", "defaulted")]
    packaged = tomllib.loads(packaged_text(DEFAULT_FILE))
    assert list(packaged) == list(SECTIONS)
    for section, cls in SECTIONS.items():
        assert set(packaged[section]) == {f.name for f in fields(cls)}, section  # the default of every field


def test_every_field_declares_its_kind_and_one_documentation_line() -> None:
    used = set()
    for section, name, spec in _specs():
        assert spec.doc and "\n" not in spec.doc and spec.doc == spec.doc.strip(), f"{section}.{name}"
        if spec.unit:
            assert KINDS[spec.quantity] == spec.unit, f"{section}.{name}"
            used.add(spec.quantity)
    assert used == set(KINDS)  # every kind has a field
    for cls in SECTIONS.values():
        assert cls.__doc__ and cls.__doc__.strip()


def test_the_docs_page_is_what_the_declarations_generate() -> None:
    spec = importlib.util.spec_from_file_location("config_md", ROOT / "tools" / "config_md.py")
    assert spec is not None and spec.loader is not None
    config_md = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(config_md)
    page = config_md.PAGE.read_text(encoding="utf-8")
    expected = config_md.render()
    assert page == expected, f"docs/configuration.md is not what the declarations generate; run `{config_md.COMMAND}`"
    for section, name, _ in _specs():
        assert f"| `{section}.{name}` |" in page


def test_the_page_shows_the_packaged_default_and_the_check() -> None:
    page = (ROOT / "docs" / "configuration.md").read_text(encoding="utf-8")
    row = next(line for line in page.splitlines() if line.startswith("| `navigation.camera_fov` |"))
    cells = [c.strip() for c in row.strip("|").split(" | ")]
    assert cells == [
        "`navigation.camera_fov`",
        "angle, `rad`",
        "in (0, 180) deg",
        '`"37.7 deg"`',
        "full field of view of the square image",
    ]


# ---------------------------------------------------------------------------------------------------
# The C++ navigation settings from the declarations


def _members(struct: Any) -> dict[str, Any]:
    """A settings struct's members (nested structs as dicts, arrays as lists): what its binding exposes."""
    out = {}
    for name in dir(struct):
        value = getattr(struct, name)
        if name.startswith("_") or callable(value):
            continue
        if isinstance(value, (bool, int, float)):
            out[name] = value
        elif isinstance(value, np.ndarray):
            out[name] = (value.shape, value.tolist())
        else:
            out[name] = _members(value)
    return out


def _hand_mapped(cfg: Config) -> Any:
    """The settings as navigation_settings wrote them field by field before the declarations named
    their C++ members (the reference the generic mapping must reproduce exactly)."""
    n, nav = cfg.navigation, _core.nav
    s = nav.NavigationSettings()
    imu = nav.ImuSettings()
    imu.period = n.imu_period
    imu.gyro_noise_density, imu.gyro_bias_sigma = n.gyro_noise_density, n.gyro_bias_sigma
    imu.gyro_bias_random_walk = n.gyro_bias_random_walk
    imu.accel_noise_density, imu.accel_bias_sigma = n.accel_noise_density, n.accel_bias_sigma
    imu.accel_bias_random_walk, imu.dropout_probability = n.accel_bias_random_walk, n.imu_dropout
    alt = nav.AltimeterSettings()
    alt.boresight_B = np.asarray(n.altimeter_boresight_B, dtype=float)
    alt.sigma, alt.bias, alt.period = n.altimeter_sigma, n.altimeter_bias, n.altimeter_period
    alt.min_range, alt.max_range, alt.dropout_probability = n.altimeter_min_range, n.altimeter_max_range, n.altimeter_dropout
    cam = nav.CameraSettings()
    cam.width_px = cam.height_px = n.camera_pixels
    cam.focal_length_px = nav.CameraSettings.focal_length_from_fov(n.camera_fov, n.camera_pixels)
    z = np.asarray(n.camera_boresight_B, dtype=float)
    z = z / np.linalg.norm(z)
    seed = np.eye(3)[int(np.argmin(np.abs(z)))]
    x = seed - z * float(seed @ z)
    x /= np.linalg.norm(x)
    cam.C_BC = np.column_stack([x, np.cross(z, x), z])
    cam.pixel_sigma, cam.period, cam.dropout_probability = n.camera_pixel_sigma, n.camera_period, n.camera_dropout
    cam.max_emission_angle, cam.max_incidence_angle = n.camera_max_emission_angle, n.camera_max_incidence_angle
    cam.min_range, cam.max_range, cam.max_landmarks = n.camera_min_range, n.camera_max_range, n.camera_max_landmarks
    star = nav.StarTrackerSettings()
    star.period, star.sigma_B, star.dropout_probability = (
        n.star_tracker_period,
        np.asarray(n.star_tracker_sigma_B, dtype=float),
        n.star_tracker_dropout,
    )
    filt = nav.FilterSettings()
    filt.altimeter, filt.camera, filt.imu, filt.star_tracker = alt, cam, imu, star
    filt.altimeter_terrain_sigma, filt.accel_model_noise = n.altimeter_terrain_sigma, n.accel_model_noise
    filt.innovation_gate = n.innovation_gate
    filt.gravity_relinearization_distance = n.gravity_relinearization_distance
    filt.gravity_expansion_tolerance = n.gravity_expansion_tolerance
    filt.covariance_step = n.covariance_step
    s.altimeter, s.camera, s.imu, s.star_tracker, s.filter = alt, cam, imu, star, filt
    s.initial_sigma = np.repeat([n.initial_sigma_position, n.initial_sigma_velocity, n.initial_sigma_attitude], 3)
    sigma = np.zeros(9)
    if n.period_noise == "disturbance":
        d = cfg.disturbance
        var_p = np.diag(d.S_p) * max(1.0, d.growth_p) ** 2 / 8
        var_r = np.diag(d.S_r) * max(1.0, d.growth_r) ** 2 / 8
        sigma = n.period_noise_scale * np.sqrt(np.concatenate([var_p, var_r[:3]]))
    s.period_noise_sigma = sigma
    s.max_samples = max(1, round(cfg.mpc.dt / n.imu_period))
    return s


# Every [navigation] field the settings read, changed from both its packaged value and the C++ default.
_EVERY_FIELD = {
    "navigation.imu_period": "0.05 s",
    "navigation.gyro_noise_density": "2e-6 rad/s/Hz^0.5",
    "navigation.gyro_bias_sigma": "3e-5 rad/s",
    "navigation.gyro_bias_random_walk": "4e-8 rad/s^2/Hz^0.5",
    "navigation.accel_noise_density": "5e-6 m/s^2/Hz^0.5",
    "navigation.accel_bias_sigma": "6e-5 m/s^2",
    "navigation.accel_bias_random_walk": "7e-8 m/s^3/Hz^0.5",
    "navigation.imu_dropout": 0.01,
    "navigation.altimeter_boresight_B": [1.0, 0.0, 0.0],
    "navigation.altimeter_period": "0.5 s",
    "navigation.altimeter_sigma": "0.07 m",
    "navigation.altimeter_bias": "0.02 m",
    "navigation.altimeter_min_range": "2 m",
    "navigation.altimeter_max_range": "900 m",
    "navigation.altimeter_dropout": 0.02,
    "navigation.camera_boresight_B": [0.3, -1.0, 0.2],
    "navigation.camera_period": "1.5 s",
    "navigation.camera_fov": "20 deg",
    "navigation.camera_pixels": 512,
    "navigation.camera_pixel_sigma": 0.7,
    "navigation.camera_max_emission_angle": "60 deg",
    "navigation.camera_max_incidence_angle": "85 deg",
    "navigation.camera_min_range": "3 m",
    "navigation.camera_max_range": "4000 m",
    "navigation.camera_max_landmarks": 8,
    "navigation.camera_dropout": 0.03,
    "navigation.star_tracker_period": "0.5 s",
    "navigation.star_tracker_sigma_B": [1e-5, 2e-5, 3e-5],
    "navigation.star_tracker_dropout": 0.04,
    "navigation.altimeter_terrain_sigma": "0.2 m",
    "navigation.accel_model_noise": "1e-7 m/s^2/Hz^0.5",
    "navigation.innovation_gate": 50.0,
    "navigation.gravity_relinearization_distance": "2 m",
    "navigation.gravity_expansion_tolerance": "2e-7 m/s^2",
    "navigation.covariance_step": "0.5 s",
    "navigation.initial_sigma_position": "2 m",
    "navigation.initial_sigma_velocity": "0.02 m/s",
    "navigation.initial_sigma_attitude": "2e-3 rad",
    "navigation.period_noise_scale": 2.0,
    "disturbance.growth_r": 3.0,
}


@pytest.mark.parametrize("scenario", list(SCENARIOS))
def test_navigation_settings_are_the_hand_mapped_ones(scenario: str) -> None:
    """Every member of every nested struct, the filter's copies of the sensors included, equals what the
    hand mapping gave, for each packaged scenario as written and with its navigation fields changed."""
    cfg = load_config(scenario=scenario)
    for c in (cfg, cfg.with_overrides(_EVERY_FIELD), cfg.with_overrides({"navigation.period_noise": "none"})):
        built = _members(navigation_settings(c))
        assert built == _members(_hand_mapped(c))
        assert set(built) >= {*SENSORS, "filter", "initial_sigma", "period_noise_sigma", "max_samples"}
        for sensor in SENSORS:
            assert built["filter"][sensor] == built[sensor]


# Members set from more than one field (navigation_settings derives them) or left at the core's default.
DERIVED = {"camera.width_px", "camera.height_px", "camera.focal_length_px", "camera.C_BC"}
CORE_DEFAULT = {"camera.pixel_bias", "star_tracker.misalignment_B", "filter.max_step", "filter.max_substeps", "filter.split"}


def test_each_declared_cpp_member_takes_its_field_and_every_member_is_accounted_for() -> None:
    cfg = load_config(scenario="bennu-tag-nav").with_overrides(_EVERY_FIELD)
    built = _members(navigation_settings(cfg))
    declared = {f.metadata["spec"].cpp: f.name for f in fields(NavigationSection) if f.metadata["spec"].cpp}
    assert len(declared) == len([f for f in fields(NavigationSection) if f.metadata["spec"].cpp])  # one field each
    for target, name in declared.items():
        part, member = target.split(".")
        value = getattr(cfg.navigation, name)
        expected = (value.shape, value.tolist()) if isinstance(value, np.ndarray) else value
        assert built[part][member] == expected, target
    members = {f"{part}.{m}" for part in (*SENSORS, "filter") for m in built[part] if m not in SENSORS}
    assert set(declared).isdisjoint(DERIVED | CORE_DEFAULT)
    assert members == set(declared) | DERIVED | CORE_DEFAULT
