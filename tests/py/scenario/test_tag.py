"""The touch-and-go scenario bennu-tag and boundary.touchdown_speed (docs/model.md "Scenario")."""

from __future__ import annotations

import numpy as np
import pytest

from tubempc import _core
from tubempc.config import Config, ConfigError, load_config
from tubempc.models.dynamics import ProximityModel
from tubempc.scenario import Scenario, boundary_states, build_scenario, landing_site, model_params
from tubempc.scenario.shapes import bennu_like_shape
from tubempc.scenario.sites import inside, ray_cast, terminal_state
from tubempc.sim.closed_loop import simulate


@pytest.fixture(scope="module")
def tag(tmp_path_factory: pytest.TempPathFactory) -> Scenario:
    return build_scenario(load_config(scenario="bennu-tag"), cache_dir=tmp_path_factory.mktemp("cache"))


def test_tag_configuration_is_the_documented_one() -> None:
    b = load_config(scenario="bennu-tag").boundary
    assert (b.terminal, b.initial, b.terminal_attitude) == ("site", "hover", "boresight_down")
    assert np.degrees(b.site_latitude) == pytest.approx(56.0)
    assert (b.hover_altitude, b.terminal_altitude, b.touchdown_speed) == (125.0, 3.0, 0.1)


def test_tag_terminal_state_is_above_the_surface_moving_into_it(tag: Scenario) -> None:
    """x_f against an independent construction: the surface point on the site's ray (the inside test
    brackets it), the target 3 m along the normal, and the velocity omega_AL x r_L (the surface's,
    rate = 2 pi / spin_period - n from the configuration's numbers) plus 0.1 m/s along -n_L."""
    cfg, site = tag.config, tag.site
    assert site is not None
    lat, lon = cfg.boundary.site_latitude, cfg.boundary.site_longitude
    d = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    s_A = ray_cast(tag.shape, d)
    np.testing.assert_allclose(site.surface_A, s_A, rtol=0, atol=1e-9)
    assert list(inside(tag.shape, [0.999 * s_A, 1.001 * s_A])) == [True, False]  # s_A is on the surface
    n_A = site.normal_A
    assert np.linalg.norm(n_A) == pytest.approx(1.0) and n_A @ s_A / np.linalg.norm(s_A) > 0.8  # outward, near radial
    assert not inside(tag.shape, s_A + 0.5 * n_A)[0] and inside(tag.shape, s_A - 0.5 * n_A)[0]

    t_f = cfg.mpc.t_f
    C_AL = np.asarray(tag.model.C_AL(t_f))
    r_L, v_L = tag.xf[:3], tag.xf[3:6]
    np.testing.assert_allclose(C_AL @ r_L, s_A + 3.0 * n_A, rtol=0, atol=1e-9)
    n_mean = np.sqrt(cfg.environment.mu_sun / cfg.environment.R**3)
    rate = cfg.asteroid.spin_sign * 2.0 * np.pi / cfg.asteroid.spin_period - n_mean
    v_rel = v_L - np.cross([0.0, 0.0, rate], r_L)  # relative to the turning surface
    n_L = C_AL.T @ n_A
    np.testing.assert_allclose(v_rel, -0.1 * n_L, rtol=0, atol=1e-12)
    assert np.linalg.norm(v_L) > 0.1  # the site itself moves (off the pole): not the relative speed alone

    assert tag.reference.converged
    np.testing.assert_allclose(tag.reference.x[-1], tag.xf, rtol=0, atol=1e-6)
    # the start: hovering 125 m above the site, at rest relative to the surface
    C0 = np.asarray(tag.model.C_AL(0.0))
    np.testing.assert_allclose(C0 @ tag.x0[:3], s_A + 125.0 * n_A, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tag.x0[3:6], np.cross([0.0, 0.0, rate], tag.x0[:3]), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"boundary.touchdown_speed": "-0.1 m/s"}, r"boundary\.touchdown_speed.*\[0, 1\] m/s"),
        ({"boundary.touchdown_speed": "1.5 m/s"}, r"boundary\.touchdown_speed.*\[0, 1\] m/s"),
        ({"boundary.touchdown_speed": "0.1 m/s"}, r"boundary\.touchdown_speed: .*boundary\.terminal = \"site\""),
    ],
)
def test_touchdown_speed_validation_names_the_field(overrides: dict[str, str], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        load_config().with_overrides(overrides)  # the paper scenario: terminal = "paper"


def _equator() -> tuple[Config, ProximityModel, _core.gravity.Shape]:
    cfg = load_config(scenario="bennu-equator")
    shape = bennu_like_shape()
    gravity = _core.gravity.PolyhedronGravity(shape.vertices, shape.faces, cfg.asteroid.density)
    return cfg, ProximityModel(gravity, model_params(cfg, site=landing_site(cfg, shape))), shape


def test_zero_touchdown_speed_leaves_existing_terminal_states_unchanged() -> None:
    """Default 0 m/s: x_f to the bit as before (the site's state at rest), and the paper's as given."""
    assert load_config().boundary.touchdown_speed == 0.0
    cfg, model, shape = _equator()
    assert cfg.boundary.touchdown_speed == 0.0
    site = landing_site(cfg, shape)
    assert site is not None
    _, xf = boundary_states(cfg, shape, model, site)
    rate = model.params.spin_rate - model.mean_motion
    at_rest = terminal_state(
        site.target_A, site.normal_A, model.C_AL(cfg.mpc.t_f), rate, cfg.spacecraft.boresight_B, cfg.boundary.phi_f
    )
    np.testing.assert_array_equal(xf, at_rest)
    # the same site with a touchdown speed differs only in the velocity, by that speed along -n_L
    fast = cfg.with_overrides({"boundary.touchdown_speed": "0.25 m/s"})
    _, xf_fast = boundary_states(fast, shape, model, site)
    np.testing.assert_array_equal(np.delete(xf_fast, [3, 4, 5]), np.delete(xf, [3, 4, 5]))
    n_L = np.asarray(model.C_AL(cfg.mpc.t_f)).T @ site.normal_A
    np.testing.assert_allclose(xf_fast[3:6] - xf[3:6], -0.25 * n_L, rtol=0, atol=1e-15)
    paper = load_config()
    _, xf_paper = boundary_states(paper, shape)
    b = paper.boundary
    np.testing.assert_array_equal(xf_paper, np.concatenate([b.rf, b.vf, b.phi_f, b.wf]))


@pytest.mark.parametrize("method", ["tbmpc", "ffa"])
def test_tag_closed_loop_flies_a_few_steps(tag: Scenario, method: str) -> None:
    rec = simulate(tag, method, seed=0, max_steps=4)
    assert rec.statuses == ["solved"] * 4
    assert np.all(rec.excursion <= 1.0) and np.all(rec.g <= 0.0) and np.all(np.isfinite(rec.u))
