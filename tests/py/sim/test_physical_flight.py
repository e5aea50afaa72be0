"""The closed loop in the physical environment (disturbance.model = "physical"; docs/model.md "Physical
environment"): no additive draw, the C++ environment in the truth's propagation; the drawn model unchanged."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc.config import load_config
from tubempc.models.disturbances import AdditiveDisturbance
from tubempc.scenario import build_scenario
from tubempc.sim.closed_loop import simulate


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("cache")


@pytest.mark.parametrize("name", ["bennu-tag-physical", "bennu-paper-physical"])
def test_a_short_physical_flight_is_finite_and_draws_nothing(name: str, cache: Path, monkeypatch: Any) -> None:
    scn = build_scenario(load_config(scenario=name), cache_dir=cache)
    draws = []
    original = AdditiveDisturbance.sample
    monkeypatch.setattr(AdditiveDisturbance, "sample", lambda self, k=0: draws.append(k) or original(self, k))
    for method in ("tbmpc", "ffa"):
        rec = simulate(scn, method, seed=0, max_steps=20)
        assert rec.x.shape == (21, 12)
        for field in ("x", "u", "u_delivered", "w", "excursion", "Pe_p", "Pe_r"):
            assert np.all(np.isfinite(getattr(rec, field))), field
        assert np.all(rec.w_true == 0.0)
        assert draws == []  # the additive draw is the drawn model's only
        assert np.max(np.abs(rec.x[:, :3] - rec.zbar[:21, :3])) < 1.0
        # the truth receives the command through its mass: (m_model / m_true) u_p in L (ideal actuators)
        np.testing.assert_allclose(rec.u_delivered[:, :3], rec.u[:, :3] / 1.02, rtol=1e-12, atol=1e-18)
        np.testing.assert_array_equal(rec.u_delivered[:, 3:], rec.u[:, 3:])
        # what the plant felt is the model's residual: not zero, since the truth is not the model
        assert np.abs(rec.w[:-1, :6]).max() > 0.0
        applied = rec.applied
        assert applied["disturbance"]["model"] == "physical"
        assert applied["truth"]["physical"]["mass_true"] == pytest.approx(2152.2)
        assert applied["actuators"]["frame"] == "B"


def test_the_additive_draw_flies_in_the_drawn_model_and_ignores_the_physical_section(cache: Path, monkeypatch: Any) -> None:
    cfg = load_config(scenario="bennu-tag")
    other = cfg.with_overrides(
        {
            "physical.mass_error": -0.3,
            "physical.core_density": "500 kg/m^3",
            "physical.inertia_scale": [1.5, 0.7, 1.2],
            "physical.gravity_gradient": False,
            "physical.plate_area": {"value": [1.0], "unit": "m^2"},
            "physical.plate_normal_B": [[0.0, 0.0, 1.0]],
            "physical.plate_center_B": {"value": [[1.0, 2.0, 3.0]], "unit": "m"},
            "physical.plate_specular": [0.5],
            "physical.plate_diffuse": [0.5],
        }
    )
    draws = []
    original = AdditiveDisturbance.sample
    monkeypatch.setattr(AdditiveDisturbance, "sample", lambda self, k=0: draws.append(k) or original(self, k))
    runs = []
    for c in (cfg, other):
        scn = build_scenario(c, cache_dir=cache)
        assert scn.physical is None
        runs.append(simulate(scn, "ffa", seed=5, max_steps=6))
    assert draws == list(range(6)) * 2  # one draw per step
    a, b = runs
    assert a.x.tobytes() == b.x.tobytes() and a.u.tobytes() == b.u.tobytes()
    assert np.all(np.abs(a.w_true[:, 3:6]) > 0.0)
    assert a.applied["disturbance"]["model"] == "additive_ellipsoid_uniform"


def test_the_physical_environment_on_navigation(cache: Path) -> None:
    """The sensors sample the truth in the physical environment: the accelerometer's non-gravitational
    acceleration is the thrust and the plates' SRP at each sub-step."""
    cfg = load_config(scenario="bennu-tag-nav").with_overrides({"disturbance.model": "physical"})
    scn = build_scenario(cfg, cache_dir=cache)
    rec = simulate(scn, "ffa", seed=1, max_steps=3)
    assert np.all(np.isfinite(rec.x)) and np.all(rec.w_true == 0.0)
    assert rec.navigation is not None and np.all(np.isfinite(rec.navigation.x_hat))


def test_states_inside_the_body_are_counted_on_the_truths_surface(cache: Path) -> None:
    """In a physical environment the surface is the truth's, displaced by its centre of mass from the
    controller's: a state just inside the truth's surface but outside the controller's counts."""
    from tubempc.analysis.runner import states_inside_body
    from tubempc.results import RunRecord
    from tubempc.scenario.sites import inside, ray_cast

    scn = build_scenario(load_config(scenario="bennu-tag-physical"), cache_dir=cache)
    body = scn.physical.parts[0]
    direction = np.array([1.0, 0.0, 0.0])  # the offset's axis: the truth lies 0.96 m further out along +x_A
    np.testing.assert_allclose(body.offset_A, -scn.physical.center_of_mass_offset_A)
    truth_surface = ray_cast(body.shape, direction) + body.offset_A
    assert np.linalg.norm(truth_surface) - np.linalg.norm(ray_cast(body.shape, direction)) == pytest.approx(0.96, abs=0.01)
    rec = RunRecord.allocate("tbmpc", 0, 1, scn.config.mpc.horizon)
    rec.x[:, :3] = truth_surface - 0.1 * direction  # at t = 0, where C_AL = I (theta_0 = 0)
    assert not inside(scn.shape, rec.x[:1, :3])[0]  # outside the controller's body ...
    assert states_inside_body(scn, rec) == 2  # ... inside the truth's
    rec.x[:, :3] = truth_surface + 0.1 * direction
    assert states_inside_body(scn, rec) == 0


def test_a_physical_scenario_is_not_exported(tmp_path: Path) -> None:
    from tubempc.results.export import export_scenario
    from tubempc.scenario import ScenarioError

    with pytest.raises(ScenarioError, match=r"disturbance\.model: \"physical\" is not part of the scenario file"):
        export_scenario(load_config(scenario="bennu-tag-physical"), tmp_path)
