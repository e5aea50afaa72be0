"""The truth's physical environment on the scenario (tubempc.scenario.physical; docs/model.md "Physical
environment"): the heterogeneous body, its one description, the C++ settings of the same names."""

from __future__ import annotations

import pickle
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from tubempc import _core
from tubempc.config import PhysicalSection, load_config
from tubempc.scenario import ScenarioError, build_scenario
from tubempc.scenario.physical import physical_settings
from tubempc.scenario.sites import inside


@pytest.fixture(scope="module")
def tag(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return build_scenario(load_config(scenario="bennu-tag-physical"), cache_dir=tmp_path_factory.mktemp("cache"))


def test_the_truth_body_is_heterogeneous_with_the_controllers_mass_and_its_centre_of_mass_at_the_origin(tag) -> None:  # type: ignore[no-untyped-def]
    ph, cfg = tag.physical, tag.config
    assert [p.name for p in ph.parts] == ["body", "core", "lobe"]
    body, core, lobe = ph.parts
    # the truth's shape: twice the controller's resolution
    assert body.shape.n_faces == 4 * tag.shape.n_faces == 11520
    # the contrasts are the configured ones, and the total mass is the controller's (density_scale = 1)
    assert core.density == cfg.physical.core_density and lobe.density == cfg.physical.lobe_density
    assert sum(p.mass for p in ph.parts) == pytest.approx(tag.model.gravity.mass, rel=1e-12)
    assert ph.gm == pytest.approx(tag.model.gravity.gm, rel=1e-12)
    assert body.density > cfg.asteroid.density  # lighter regions inside: the rest is denser
    # the lighter lobe in the bulge moves the centre of mass away from it by about a metre, which is removed
    offset = ph.center_of_mass_offset_A
    assert -1.2 < offset[0] < -0.7 and abs(offset[1]) < 1e-9 and abs(offset[2]) < 1e-9
    g = tag.truth.gravity
    assert isinstance(g, _core.gravity.CompositeGravity)
    assert np.linalg.norm(g.center_of_mass) < 1e-9
    for p, (_, density, offset_A) in zip(ph.parts, g.parts, strict=True):
        assert density == p.density
        np.testing.assert_array_equal(offset_A, p.offset_A)
    # inside the lobe (its centre, moved with the body) the density is the body's plus the lobe's contrast
    centre = np.asarray(cfg.physical.lobe_center_A) - offset
    four_pi_g = 4.0 * np.pi * _core.gravity.GRAVITATIONAL_CONSTANT
    assert g.laplacian(centre) == pytest.approx(-four_pi_g * (body.density + lobe.density), rel=1e-9)
    assert g.laplacian(-offset) == pytest.approx(-four_pi_g * (body.density + core.density), rel=1e-9)
    assert inside(body.shape, np.asarray(lobe.shape.vertices) + lobe.offset_A - body.offset_A).all()


def test_the_truth_spacecraft_and_its_model(tag) -> None:  # type: ignore[no-untyped-def]
    ph, cfg = tag.physical, tag.config
    assert ph.mass_model == 2110.0 and ph.mass_true == pytest.approx(1.02 * 2110.0)
    J = np.asarray(cfg.spacecraft.J)
    np.testing.assert_allclose(np.diag(ph.inertia_true_B), np.asarray(cfg.physical.inertia_scale) * np.diag(J))
    assert ph.inertia_true_B[0, 1] == 15.0 and ph.inertia_true_B[0, 2] == -10.0 and ph.inertia_true_B[1, 2] == 8.0
    truth = tag.truth.params
    np.testing.assert_array_equal(truth.inertia_B, ph.inertia_true_B)
    assert not truth.srp_enabled and tag.model.params.srp_enabled  # the plates' SRP replaces the cannonball
    np.testing.assert_array_equal(tag.model.params.inertia_B, J)
    assert len(ph.plates) == 10 and sum(p.area for p in ph.plates[6::2]) == pytest.approx(8.5)  # the wings' fronts
    assert all(abs(np.linalg.norm(p.normal_B) - 1.0) < 1e-15 for p in ph.plates)
    assert ph.pressure == pytest.approx(4.56e-6 * (_core.dynamics.ASTRONOMICAL_UNIT / cfg.environment.R) ** 2)
    assert ph.srp and ph.gravity_gradient and ph.shadow_radius == 246.0
    env = ph.environment()
    assert env.true_mass == ph.mass_true and env.gm == ph.gm
    np.testing.assert_array_equal(env.inertia_B, ph.inertia_true_B)
    d = ph.describe()
    assert d["model"] == "physical" and [p["name"] for p in d["parts"]] == ["body", "core", "lobe"]
    # the description is plain data: it pickles (Monte Carlo workers), and its C++ settings are the section's
    again = pickle.loads(pickle.dumps(ph))
    assert again.gm == ph.gm and len(again.parts) == 3
    np.testing.assert_array_equal(again.parts[2].shape.vertices, ph.parts[2].shape.vertices)
    s, ref = again.settings(), physical_settings(cfg)
    for name in _core.dynamics.PhysicalSettings.field_names():
        np.testing.assert_array_equal(getattr(s, name), getattr(ref, name))
    for a, b in zip(s.plates, ref.plates, strict=True):
        for member in _core.dynamics.FlatPlate.field_names():
            np.testing.assert_array_equal(getattr(a, member), getattr(b, member))
    truth = pickle.loads(pickle.dumps(tag.truth))
    r = np.array([150.0, 200.0, 220.0])
    np.testing.assert_array_equal(truth.gravity_L(10.0, r)[0], tag.truth.gravity_L(10.0, r)[0])


def test_the_cpp_settings_are_the_sections_fields_of_the_same_names() -> None:
    cfg = load_config(scenario="bennu-tag-physical")
    s = physical_settings(cfg)
    mapped = {f.metadata["spec"].cpp for f in fields(PhysicalSection)} - {None}
    members = set(_core.dynamics.PhysicalSettings.field_names())
    plate_members = {f"plates[].{n}" for n in _core.dynamics.FlatPlate.field_names()}
    assert mapped == members | plate_members  # every C++ member has its field, and no field names another
    for name in members:
        assert name in {f.name for f in fields(PhysicalSection)}  # the TOML name is the C++ name
        np.testing.assert_array_equal(getattr(s, name), getattr(cfg.physical, name))
    for i, plate in enumerate(s.plates):
        for member in _core.dynamics.FlatPlate.field_names():
            np.testing.assert_array_equal(getattr(plate, member), np.asarray(getattr(cfg.physical, f"plate_{member}"))[i])


def test_a_drawn_scenario_has_no_physical_truth(tmp_path: Path) -> None:
    scn = build_scenario(load_config(scenario="bennu-tag"), cache_dir=tmp_path)
    assert scn.physical is None
    assert isinstance(scn.truth.gravity, _core.gravity.PolyhedronGravity)
    assert scn.truth.params.srp_enabled


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"physical.lobe_center_A": [220.0, 0.0, 0.0]}, r"physical\.lobe_scale: the lobe .* reaches outside the body"),
        ({"physical.core_density": "-1500 kg/m^3"}, r"physical\.core_density, lobe_density: .* positive density"),
        ({"physical.inertia_products": {"value": [3000.0, 0.0, 0.0], "unit": "kg m^2"}}, r"physical\.inertia_products"),
    ],
)
def test_a_body_or_spacecraft_that_cannot_be_is_an_error_naming_the_field(
    tmp_path: Path, overrides: dict[str, object], message: str
) -> None:
    cfg = load_config(scenario="bennu-tag-physical").with_overrides({**overrides, "simulation.truth_shape_subdivisions": 12})
    with pytest.raises(ScenarioError, match=message):
        build_scenario(cfg, cache_dir=tmp_path)


def test_the_preset_mass_is_the_controllers(tmp_path: Path) -> None:
    cfg = load_config(scenario="bennu-tag-osirisrex").with_overrides({"disturbance.model": "physical"})
    with pytest.raises(ScenarioError, match=r"physical\.mass: 2110 kg, but the actuators' preset .* is 1500 kg"):
        build_scenario(cfg, cache_dir=tmp_path)
