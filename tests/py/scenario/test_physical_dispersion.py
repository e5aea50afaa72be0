"""Dispersions of the physical environment (tubempc.scenario.physical.PhysicalTruth.dispersed; docs/model.md
"Dispersions of the physical environment"): a campaign run's truth drawn from its seed within the [physical]
section's half-widths, the body rebuilt with the drawn contrasts, the nominal truth for a single run, and the
ranges refused by name where some value inside them could not be flown."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc import _core
from tubempc.config import ConfigError, load_config
from tubempc.scenario import ScenarioError, build_scenario
from tubempc.scenario.physical import PhysicalTruth

DISPERSIONS = (
    "mass_error_dispersion",
    "inertia_scale_dispersion",
    "inertia_products_dispersion",
    "center_of_mass_dispersion_B",
    "plate_specular_dispersion",
    "plate_diffuse_dispersion",
    "core_density_dispersion",
    "lobe_density_dispersion",
)
ACTUATOR_ERRORS = ("scale_error_p", "misalignment_p", "scale_error_r", "misalignment_r")


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("cache")


@pytest.fixture(scope="module")
def tag(cache: Path) -> Any:
    return build_scenario(load_config(scenario="bennu-tag-physical"), cache_dir=cache)


def _nominal_overrides() -> dict[str, Any]:
    """Every dispersion and actuator error of the physical scenarios set to 0."""
    zero: dict[str, Any] = {f"physical.{n}": 0.0 for n in DISPERSIONS}
    for n in ("inertia_scale_dispersion", "inertia_products_dispersion", "center_of_mass_dispersion_B"):
        zero[f"physical.{n}"] = np.zeros(3)
    zero.update({f"disturbance.{n}": 0.0 for n in ACTUATOR_ERRORS})
    return zero


def test_the_packaged_scenarios_disperse_every_parameter_and_the_default_none() -> None:
    """bennu-tag-physical and bennu-paper-physical set a half-width for each dispersed parameter; the paper
    scenario's section (the defaults of every other file) sets none."""
    default = load_config().physical
    for name in DISPERSIONS:
        assert not np.any(np.asarray(getattr(default, name))), name
    for scenario in ("bennu-tag-physical", "bennu-paper-physical"):
        cfg = load_config(scenario=scenario)
        for name in DISPERSIONS:
            assert np.all(np.asarray(getattr(cfg.physical, name)) > 0.0), (scenario, name)
        for name in ACTUATOR_ERRORS:
            assert getattr(cfg.disturbance, name) > 0.0, (scenario, name)


def test_the_same_seed_draws_the_same_truth_and_other_seeds_differ_in_every_parameter(tag: Any) -> None:
    ph: PhysicalTruth = tag.physical
    a, b = ph.dispersed(12345).describe(), ph.dispersed(12345).describe()
    assert a == b  # to the bit (floats compared exactly)
    np.testing.assert_array_equal(ph.dispersed(12345).thrust_error_B, ph.dispersed(12345).thrust_error_B)
    runs = [ph.dispersed(seed) for seed in (1, 2, 2**62 + 3)]
    for x, y in itertools.combinations(runs, 2):
        assert x.drawn is not None and y.drawn is not None
        for key in ("mass_error", "inertia_scale", "inertia_products", "center_of_mass_B", "plate_specular",
                    "plate_diffuse", "core_density", "lobe_density"):  # fmt: skip
            assert np.all(np.asarray(x.drawn[key]) != np.asarray(y.drawn[key])), key
        assert x.mass_true != y.mass_true
        assert not np.array_equal(x.thrust_error_B, y.thrust_error_B)
        assert not np.array_equal(x.torque_error_B, y.torque_error_B)
        assert not np.array_equal(x.center_of_mass_offset_A, y.center_of_mass_offset_A)
    assert ph.drawn is None  # the scenario keeps the nominal truth


def test_every_drawn_parameter_lies_in_its_range_and_the_body_keeps_its_mass(tag: Any) -> None:
    ph: PhysicalTruth = tag.physical
    p, dist = tag.config.physical, tag.config.disturbance
    J = np.asarray(tag.config.spacecraft.J)
    g = _core.gravity.GRAVITATIONAL_CONSTANT
    lo_hi = {"mass_error": [], "core": [], "lobe": [], "com": []}  # type: dict[str, list[Any]]
    for seed in range(60):
        t = ph.dispersed(seed)
        d = t.drawn
        assert d is not None and d["seed"] == seed
        assert abs(d["mass_error"] - p.mass_error) <= p.mass_error_dispersion
        assert t.mass_true == pytest.approx((1.0 + d["mass_error"]) * p.mass, rel=1e-15)
        assert np.all(np.abs(np.asarray(d["inertia_scale"]) - p.inertia_scale) <= p.inertia_scale_dispersion)
        assert np.all(np.abs(np.asarray(d["inertia_products"]) - p.inertia_products) <= p.inertia_products_dispersion)
        # the truth's inertia: spacecraft.J with the drawn scale factors and products (M47), symmetric
        expected = J * np.where(np.eye(3) > 0, np.asarray(d["inertia_scale"])[:, None], 1.0)
        for (i, j), v in zip(((0, 1), (0, 2), (1, 2)), d["inertia_products"], strict=True):
            expected[i, j] += v
            expected[j, i] += v
        np.testing.assert_allclose(t.inertia_true_B, expected, rtol=0, atol=1e-12)
        assert np.all(np.linalg.eigvalsh(t.inertia_true_B) > 0.0)
        com = np.asarray(d["center_of_mass_B"])
        assert np.all(np.abs(com) <= p.center_of_mass_dispersion_B)
        for plate, nominal, spec, diff in zip(t.plates, ph.plates, p.plate_specular, p.plate_diffuse, strict=True):
            np.testing.assert_array_equal(plate.center_B, nominal.center_B - com)  # lever arms from the new centre
            assert abs(plate.specular - spec) <= p.plate_specular_dispersion
            assert abs(plate.diffuse - diff) <= p.plate_diffuse_dispersion
            assert 0.0 <= plate.specular and 0.0 <= plate.diffuse and plate.specular + plate.diffuse <= 1.0
        assert abs(d["core_density"] - p.core_density) <= p.core_density_dispersion
        assert abs(d["lobe_density"] - p.lobe_density) <= p.lobe_density_dispersion
        # the body: the drawn contrasts, the controller's mass, the centre of mass at the origin again
        _, core, lobe = t.parts
        assert core.density == d["core_density"] and lobe.density == d["lobe_density"]
        assert sum(part.mass for part in t.parts) == pytest.approx(tag.model.gravity.mass, rel=1e-12)
        assert t.gm == pytest.approx(g * tag.model.gravity.mass, rel=1e-12)
        assert np.linalg.norm(t.gravity().center_of_mass) < 1e-9
        # actuator errors within the bounds of [disturbance]: scales per axis, misalignment angles
        a = t.actuators
        assert a["frame"] == "B"
        assert np.all(np.abs(np.asarray(a["scale_p"]) - 1.0) <= dist.scale_error_p)
        assert np.all(np.abs(np.asarray(a["scale_r"]) - 1.0) <= dist.scale_error_r)
        assert 0.0 <= a["angle_p"] <= dist.misalignment_p and 0.0 <= a["angle_r"] <= dist.misalignment_r
        lo_hi["mass_error"].append(d["mass_error"])
        lo_hi["core"].append(d["core_density"])
        lo_hi["lobe"].append(d["lobe_density"])
        lo_hi["com"].append(com)
    # the draws fill their ranges (uniform: 60 draws reach within a fifth of each end)
    for key, nominal, half in (
        ("mass_error", p.mass_error, p.mass_error_dispersion),
        ("core", p.core_density, p.core_density_dispersion),
        ("lobe", p.lobe_density, p.lobe_density_dispersion),
    ):
        v = np.asarray(lo_hi[key])
        assert v.min() < nominal - 0.8 * half and v.max() > nominal + 0.8 * half, key


def test_the_drawn_contrasts_reach_the_bodys_field(tag: Any) -> None:
    """Inside the dispersed core and lobe the field's Laplacian is -4 pi G times the drawn densities (an
    independent check, by Gauss's law, that the C++ body flies what was drawn)."""
    t = tag.physical.dispersed(7)
    body, core, lobe = t.parts
    g = t.gravity()
    four_pi_g = 4.0 * np.pi * _core.gravity.GRAVITATIONAL_CONSTANT
    assert g.laplacian(core.offset_A) == pytest.approx(-four_pi_g * (body.density + core.density), rel=1e-9)
    # each region's mesh is centred on its centroid: its centre lies at its offset
    assert g.laplacian(lobe.offset_A) == pytest.approx(-four_pi_g * (body.density + lobe.density), rel=1e-9)
    assert g.laplacian(0.5 * (core.offset_A + lobe.offset_A) + [0.0, 120.0, 0.0]) == pytest.approx(
        -four_pi_g * body.density, rel=1e-9
    )  # in neither region
    assert body.density != tag.physical.parts[0].density  # the base density follows the contrasts (mass kept)


def test_widening_one_dispersion_leaves_the_others_draws(tag: Any, cache: Path) -> None:
    """Every parameter is drawn in a fixed order whatever its half-width: a campaign that widens one dispersion
    keeps every other run's other draws."""
    cfg = tag.config.with_overrides({"physical.mass_error_dispersion": 0.03})
    wider = build_scenario(cfg, cache_dir=cache).physical.dispersed(3).drawn
    base = tag.physical.dispersed(3).drawn
    assert wider is not None and base is not None
    assert wider["mass_error"] != base["mass_error"]
    assert (wider["mass_error"] - 0.02) / 0.03 == pytest.approx((base["mass_error"] - 0.02) / 0.02, rel=1e-12)
    for key in set(base) - {"mass_error"}:
        assert wider[key] == base[key], key


def test_without_half_widths_a_dispersed_truth_is_the_nominal(tag: Any, cache: Path) -> None:
    scn = build_scenario(tag.config.with_overrides(_nominal_overrides()), cache_dir=cache)
    nominal, drawn = scn.physical, scn.physical.dispersed(99)
    a, b = nominal.describe(), drawn.describe()
    assert b["drawn"] is not None
    a.pop("drawn"), b.pop("drawn")
    assert a == b
    np.testing.assert_array_equal(drawn.thrust_error_B, np.eye(3))
    np.testing.assert_array_equal(drawn.torque_error_B, np.eye(3))
    # and the nominal truth is the one the dispersions widen
    assert tag.physical.describe()["parts"] == nominal.describe()["parts"]
    assert tag.physical.mass_true == nominal.mass_true


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        ({"physical.mass_error_dispersion": 0.5}, "physical.mass_error_dispersion"),
        ({"physical.mass_error_dispersion": -0.01}, "physical.mass_error_dispersion"),
        ({"physical.inertia_scale_dispersion": [0.6, 0.0, 0.0]}, "physical.inertia_scale_dispersion"),
        ({"physical.plate_diffuse_dispersion": 0.03}, "physical.plate_diffuse_dispersion"),
        ({"physical.plate_specular_dispersion": 0.11}, "physical.plate_specular_dispersion"),
        (
            {"physical.plate_specular": [0.6] * 10, "physical.plate_diffuse": [0.38] * 10},
            "physical.plate_diffuse_dispersion",
        ),
    ],
)
def test_a_range_outside_what_the_field_allows_is_a_config_error(overrides: dict[str, Any], field: str) -> None:
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        load_config(scenario="bennu-tag-physical").with_overrides(overrides)
    assert issubclass(ConfigError, ValueError)


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        # a core whose contrast can reach -1400 kg/m^3: the lightest region negative at a corner
        ({"physical.core_density_dispersion": "1300 kg/m^3"}, r"physical\.core_density_dispersion, lobe_density_dispersion"),
        # products of 1500 kg m^2 at a corner: no inertia tensor
        (
            {"physical.inertia_products_dispersion": {"value": [1500.0, 0.0, 0.0], "unit": "kg m^2"}},
            r"physical\.inertia_scale_dispersion, inertia_products_dispersion",
        ),
    ],
)
def test_a_range_the_truth_cannot_fly_is_a_scenario_error_naming_the_field(
    overrides: dict[str, Any], match: str, cache: Path
) -> None:
    cfg = load_config(scenario="bennu-tag-physical").with_overrides(overrides)
    with pytest.raises(ScenarioError, match=match):
        build_scenario(cfg, cache_dir=cache)
    assert issubclass(ScenarioError, ValueError)


def test_a_core_dispersed_from_none_appears_in_a_campaigns_runs(cache: Path) -> None:
    """A contrast of 0 with a half-width: the scenario's nominal body has no core, a dispersed run's has one."""
    cfg = load_config(scenario="bennu-tag-physical").with_overrides(
        {"physical.core_density": "0 kg/m^3", "physical.core_density_dispersion": "50 kg/m^3"}
    )
    ph = build_scenario(cfg, cache_dir=cache).physical
    assert [p.name for p in ph.parts] == ["body", "lobe"]
    t = ph.dispersed(4)
    assert [p.name for p in t.parts] == ["body", "core", "lobe"]
    assert 0.0 < abs(t.parts[1].density) <= 50.0
