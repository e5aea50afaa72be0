"""Own missions: landing sites on a rotating body, generated bodies, scenario validation, packaged scenarios."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tubempc import _core, so3
from tubempc.config import SCENARIOS, Config, ConfigError, load_config
from tubempc.models.dynamics import ProximityModel
from tubempc.scenario import ScenarioError, boundary_states, build_scenario, landing_site, model_params, scenario_shape
from tubempc.scenario.bodies import contact_binary_shape, ellipsoid_shape
from tubempc.scenario.shapes import bennu_like_shape, save_shape
from tubempc.scenario.sites import Site, inside, ray_cast, site_from_lat_lon, terminal_state

HERE = Path(__file__).parent


@pytest.fixture(scope="module")
def bennu() -> _core.gravity.Shape:
    return bennu_like_shape()


def test_ray_cast_and_normal_on_an_ellipsoid() -> None:
    a = np.array([300.0, 200.0, 150.0])
    shape = ellipsoid_shape(a, subdivisions=16)
    rng = np.random.default_rng(3)
    for _ in range(20):
        d = rng.normal(size=3)
        p = ray_cast(shape, d)
        assert np.linalg.norm(np.cross(p, d)) < 1e-9 * np.linalg.norm(p) * np.linalg.norm(d)  # on the ray
        assert abs(np.sum((p / a) ** 2) - 1.0) < 0.01  # on the (faceted) ellipsoid
        lat, lon = np.arcsin(d[2] / np.linalg.norm(d)), np.arctan2(d[1], d[0])
        s = site_from_lat_lon(shape, lat, lon, 7.0)
        exact_n = (p / a**2) / np.linalg.norm(p / a**2)  # gradient of the implicit surface
        assert np.degrees(np.arccos(np.clip(s.normal_A @ exact_n, -1, 1))) < 3.0
        np.testing.assert_allclose(s.target_A, s.surface_A + 7.0 * s.normal_A)


def test_inside_test_against_the_ellipsoid() -> None:
    a = np.array([300.0, 200.0, 150.0])
    shape = ellipsoid_shape(a, subdivisions=16)
    pts = np.random.default_rng(1).uniform(-320, 320, size=(200, 3))
    q = np.sum((pts / a) ** 2, axis=1)
    clear = np.abs(q - 1.0) > 0.03  # away from the faceted surface
    np.testing.assert_array_equal(inside(shape, pts[clear]), q[clear] < 1.0)


def _equator(bennu: _core.gravity.Shape) -> tuple[Config, Site, ProximityModel]:
    """The bennu-equator scenario's configuration, site and controller model on the generated Bennu."""
    cfg = load_config(scenario="bennu-equator")
    site = landing_site(cfg, bennu)
    assert site is not None
    gravity = _core.gravity.PolyhedronGravity(bennu.vertices, bennu.faces, 1260.0)
    return cfg, site, ProximityModel(gravity, model_params(cfg, site=site))


def test_moving_site_terminal_state_against_an_independent_rotation(bennu: _core.gravity.Shape) -> None:
    cfg, site, model = _equator(bennu)
    _, xf = boundary_states(cfg, bennu, model, site)
    p = model.params
    rate = p.spin_rate - model.mean_motion  # the body's rate relative to L
    theta = p.spin_angle0 + rate * cfg.mpc.t_f
    r_expected = Rotation.from_rotvec([0.0, 0.0, theta]).apply(site.target_A)
    np.testing.assert_allclose(xf[:3], r_expected, rtol=0, atol=1e-9)
    # velocity: the time derivative of the rotating site (central difference of the rotation)
    h = 1e-3
    r_p = Rotation.from_rotvec([0.0, 0.0, theta + rate * h]).apply(site.target_A)
    r_m = Rotation.from_rotvec([0.0, 0.0, theta - rate * h]).apply(site.target_A)
    np.testing.assert_allclose(xf[3:6], (r_p - r_m) / (2 * h), rtol=1e-7, atol=1e-12)
    # attitude: the boresight looks down the surface normal; the body turns with the asteroid
    C_LB = np.asarray(so3.rotation_matrix(so3.exp_map(xf[6:9])))
    n_L = Rotation.from_rotvec([0.0, 0.0, theta]).apply(site.normal_A)
    np.testing.assert_allclose(C_LB @ np.array([0.0, 0.0, 1.0]), -n_L, atol=1e-9)
    np.testing.assert_allclose(C_LB @ xf[9:12], [0.0, 0.0, rate], atol=1e-15)


def test_terminal_state_turns_the_hint_minimally() -> None:
    hint = np.array([0.0, np.pi - 1e-3, 0.0])  # boresight +z_B nearly along -z_L
    x = terminal_state([0, 0, 250.0], [0, 0, 1.0], np.eye(3), 0.0, [0, 0, 1.0], hint)
    # already pointing down: only the 1e-3 rad tilt is removed
    R_hint = np.asarray(so3.rotation_matrix(so3.exp_map(hint)))
    R = np.asarray(so3.rotation_matrix(so3.exp_map(x[6:9])))
    assert np.degrees(np.arccos((np.trace(R_hint.T @ R) - 1) / 2)) < 0.1


def test_site_cone_at_random_times_matches_its_definition(bennu: _core.gravity.Shape) -> None:
    cfg, site, model = _equator(bennu)
    rng = np.random.default_rng(5)
    cos_gs = np.cos(cfg.constraints.glide_slope_angle)
    for t in rng.uniform(0.0, 2e4, size=25):
        x = np.zeros(12)
        x[:3] = rng.uniform(-600, 600, size=3)
        theta = model.params.spin_angle0 + (model.params.spin_rate - model.mean_motion) * t
        d_A = Rotation.from_rotvec([0.0, 0.0, -theta]).apply(x[:3]) - site.surface_A  # independent: in A
        g_def = np.linalg.norm(d_A) * cos_gs - d_A @ site.normal_A
        assert model.glide_slope(x, t)[0] == pytest.approx(g_def, rel=1e-10, abs=1e-9)


def test_packaged_scenarios_load_and_the_default_is_the_papers() -> None:
    assert list(SCENARIOS) == [
        "bennu-paper",
        "bennu-paper-within-prior",
        "bennu-equator",
        "bennu-tag",
        "bennu-tag-nav",
        "bennu-tag-faults",
        "bennu-tag-osirisrex",
        "bennu-paper-nav",
        "bennu-tag-physical",
        "bennu-paper-physical",
        "itokawa-like",
    ]
    within = load_config(scenario="bennu-paper-within-prior")
    assert within == load_config().with_overrides({"disturbance.growth_r": 1.0})
    assert load_config(scenario="bennu-paper") == load_config()
    for name in SCENARIOS:
        cfg = load_config(scenario=name)
        assert cfg.mpc.horizon == 30
    ito = load_config(scenario="itokawa-like")
    assert ito.asteroid.density == 1900.0 and ito.asteroid.spin_period == pytest.approx(12.13 * 3600)
    with pytest.raises(ConfigError, match=r"unknown scenario 'nope'.*bennu-equator"):
        load_config(scenario="nope")


def test_itokawa_like_body_is_the_generator_output() -> None:
    """The shipped mesh is what its documented make-body command writes (reproducible)."""
    cfg = load_config(scenario="itokawa-like")
    shipped, _ = scenario_shape(cfg)
    made = contact_binary_shape([175, 147, 104], [115, 105, 90], 245, roughness=0.03, seed=1)
    np.testing.assert_allclose(shipped.vertices, made.vertices, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(shipped.faces, made.faces)
    extent = shipped.vertices.max(axis=0) - shipped.vertices.min(axis=0)
    np.testing.assert_allclose(extent, [535, 294, 209], rtol=0.02)
    assert np.linalg.norm(shipped.center_of_mass) < 1e-6


def _with(cfg_text: str, tmp_path: Path) -> Path:
    p = tmp_path / "mission.toml"
    p.write_text(cfg_text, encoding="utf-8")
    return p


def test_user_config_with_relative_obj_in_metres_and_a_lat_lon_site_flies(tmp_path: Path) -> None:
    from tubempc.sim.closed_loop import simulate

    (tmp_path / "bodies").mkdir()
    save_shape(tmp_path / "bodies" / "rock.obj", ellipsoid_shape([260.0, 220.0, 180.0], 10, 0.02, 4), unit="m")
    p = _with(
        '[asteroid]\nshape = "bodies/rock.obj"\nshape_unit = "m"\ndensity = "1500 kg/m^3"\n'
        '[constraints]\nglide_slope_apex = "site"\nglide_slope_axis = "normal"\n'
        '[boundary]\nterminal = "site"\nsite_latitude = "-20 deg"\nsite_longitude = "120 deg"\n'
        'terminal_attitude = "boresight_down"\ninitial = "hover"\nhover_altitude = "400 m"\n',
        tmp_path,
    )
    scn = build_scenario(load_config(p), cache_dir=tmp_path / "cache")
    assert scn.shape_source == str(tmp_path / "bodies" / "rock.obj") and scn.site is not None
    assert scn.reference.converged
    rec = simulate(scn, "ffa", seed=0, max_steps=5)
    assert rec.statuses == ["solved"] * 5 and np.all(rec.excursion <= 1.0) and np.all(rec.g <= 0.0)


def test_validation_errors_name_the_field(tmp_path: Path, bennu: _core.gravity.Shape) -> None:
    base = load_config()
    # a start inside the body
    with pytest.raises(ScenarioError, match=r"boundary\.r0: the initial position .* inside the body"):
        build_scenario(base.with_overrides({"boundary.r0": [0.0, 0.0, 100.0]}), cache_dir=tmp_path)
    # a start outside the glide-slope cone, by how much
    with pytest.raises(
        ScenarioError,
        match=r"boundary\.r0: the initial position is outside the glide-slope cone by "
        r"[0-9.]+ m",
    ):
        build_scenario(base.with_overrides({"boundary.r0": [900.0, 0.0, 100.0]}), cache_dir=tmp_path)
    # a final time too short for the input bounds: the reference is infeasible, said so
    with pytest.raises(ScenarioError, match=r"reference trajectory is infeasible.*mpc\.t_f = 60 s"):
        build_scenario(base.with_overrides({"mpc.t_f": "60 s", "mpc.horizon": 10}), cache_dir=tmp_path)
    # a shape whose centre of mass is not the origin
    moved = _core.gravity.Shape(np.asarray(bennu.vertices) + np.array([150.0, 0.0, 0.0]), bennu.faces)
    save_shape(tmp_path / "moved.obj", moved, unit="m")
    with pytest.raises(ScenarioError, match=r"asteroid\.shape: .*moved\.obj: the centre of mass lies 150 m"):
        build_scenario(
            base.with_overrides({"asteroid.shape": str(tmp_path / "moved.obj"), "asteroid.shape_unit": "m"}),
            cache_dir=tmp_path,
        )
    # inertia not positive definite; a horizon longer than the mission
    with pytest.raises(ConfigError, match=r"spacecraft\.J.*positive definite"):
        base.with_overrides({"spacecraft.J": [[1.0, 0, 0], [0, -1.0, 0], [0, 0, 1.0]]})
    with pytest.raises(ConfigError, match=r"mpc\.horizon: horizon 400 exceeds"):
        base.with_overrides({"mpc.horizon": 400})
    # the site's cone without a site
    with pytest.raises(ConfigError, match=r"constraints\.glide_slope_apex"):
        base.with_overrides({"constraints.glide_slope_apex": "site"})


def test_unconverged_reference_is_an_error_unless_accepted(tmp_path: Path) -> None:
    cfg = load_config()
    scn = build_scenario(cfg, cache_dir=tmp_path)
    bad = dataclasses.replace(scn.reference, converged=False)
    bad.save(next(tmp_path.glob("reference_*.npz")))
    with pytest.raises(ScenarioError, match=r"did not converge.*unconverged_reference = \"warn\""):
        build_scenario(cfg, cache_dir=tmp_path)
    with pytest.warns(RuntimeWarning, match="flown anyway"):
        build_scenario(cfg.with_overrides({"simulation.unconverged_reference": "warn"}), cache_dir=tmp_path)


@pytest.mark.parametrize("name", ["bennu-equator", "itokawa-like"])
def test_every_packaged_scenario_exports_campaigns_and_flies_in_cpp(name: str, tmp_path: Path) -> None:
    """export-scenario carries the moving site (cone records, x0, x_f) to C++; the C++ example (when built)
    flies it; a short campaign runs on it."""
    from tubempc.analysis import montecarlo
    from tubempc.results.export import export_scenario, read_scenario
    from tubempc.testing.examples import find_example

    cfg = load_config(scenario=name)
    path = export_scenario(cfg, tmp_path / "exp", cache_dir=tmp_path / "cache")
    s = read_scenario(str(path))
    scn = build_scenario(cfg, cache_dir=tmp_path / "cache")
    assert scn.site is not None
    np.testing.assert_array_equal(s.model.params.glide_slope_apex_A, scn.site.surface_A)
    np.testing.assert_array_equal(s.model.params.glide_slope_axis_A, scn.site.normal_A)
    np.testing.assert_array_equal(s.xf, scn.xf)
    try:
        example = find_example(None)
    except FileNotFoundError:
        example = None
    if example is not None:
        import subprocess

        r = subprocess.run([str(example), str(path)], capture_output=True, text=True, check=False, timeout=300)
        assert r.returncode == 0, r.stdout + r.stderr
        assert "statuses: solved 300" in r.stdout
    summary = montecarlo(cfg, 2, tmp_path / "mc", workers=1, progress=False, max_steps=3)
    assert summary.runs == 2 and not summary.failed_runs
