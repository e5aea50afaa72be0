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


def _nominal(cfg: Any) -> Any:
    """The configuration with every dispersion of the physical environment and every actuator error at 0."""
    from dataclasses import fields

    zero: dict[str, Any] = {
        f"physical.{f.name}": np.zeros_like(np.asarray(getattr(cfg.physical, f.name), dtype=float))
        if np.ndim(getattr(cfg.physical, f.name))
        else 0.0
        for f in fields(cfg.physical)
        if "_dispersion" in f.name
    }
    zero.update({f"disturbance.{n}": 0.0 for n in ("scale_error_p", "misalignment_p", "scale_error_r", "misalignment_r")})
    return cfg.with_overrides(zero)


def test_a_single_run_flies_the_nominal_truth_whatever_the_dispersions_and_seed(cache: Path) -> None:
    """`tubempc run` (simulate without ``dispersed``) flies the [physical] values with error-free actuators: the
    same to the bit as the scenario without dispersions, for any seed (the environment draws nothing)."""
    cfg = load_config(scenario="bennu-tag-physical")
    a = simulate(build_scenario(cfg, cache_dir=cache), "ffa", seed=3, max_steps=5)
    b = simulate(build_scenario(_nominal(cfg), cache_dir=cache), "ffa", seed=11, max_steps=5)
    assert a.x.tobytes() == b.x.tobytes() and a.u_delivered.tobytes() == b.u_delivered.tobytes()
    assert a.applied["disturbance"]["dispersed"] is False and a.applied["truth"]["physical"]["drawn"] is None
    assert a.applied["actuators"]["model"] == "nominal"


def test_a_dispersed_run_delivers_the_command_with_its_drawn_mass_and_actuator_errors(cache: Path) -> None:
    """A campaign's run (``dispersed``) flies the truth drawn from its seed: each period's delivered input is
    C_LB E_F C_BL u_p m / m_true and E_T T with the drawn E_F, E_T and m_true (M47, computed here apart from the
    C++ environment), the record keeps what was drawn, and two seeds fly two truths."""
    from tubempc import _core

    scn = build_scenario(load_config(scenario="bennu-tag-physical"), cache_dir=cache)
    recs = [simulate(scn, "ffa", seed=s, max_steps=6, dispersed=True) for s in (21, 22)]
    for seed, rec in zip((21, 22), recs, strict=True):
        truth = scn.physical.dispersed(seed)
        drawn = rec.applied["truth"]["physical"]
        assert drawn == truth.describe() and drawn["drawn"]["seed"] == seed
        assert rec.applied["disturbance"]["dispersed"] is True
        E_F, E_T = np.asarray(truth.thrust_error_B), np.asarray(truth.torque_error_B)
        assert rec.applied["actuators"]["scale_p"] == truth.actuators["scale_p"]
        ratio = truth.mass_model / truth.mass_true
        for k in range(6):
            C_LB = np.asarray(_core.so3.rotation_matrix(_core.so3.exp_map(rec.x[k, 6:9])))
            np.testing.assert_allclose(
                rec.u_delivered[k, :3], C_LB @ E_F @ C_LB.T @ rec.u[k, :3] * ratio, rtol=1e-9, atol=1e-16
            )
            np.testing.assert_allclose(rec.u_delivered[k, 3:], E_T @ rec.u[k, 3:], rtol=1e-12, atol=1e-18)
        assert np.all(rec.w_true == 0.0)
    assert recs[0].x.tobytes() != recs[1].x.tobytes()


def test_a_physical_campaign_disperses_its_runs_and_a_run_reflies_to_the_bit(tmp_path: Path) -> None:
    """A Monte Carlo campaign of bennu-tag-physical: its runs fly different truths (no longer one run flown again),
    each record keeps the truth it drew, and `tubempc run --from-campaign` flies one again to the bit."""
    import json

    from tubempc.analysis import montecarlo
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK
    from tubempc.results.campaign_store import CampaignStore

    out = tmp_path / "mc"
    s = montecarlo(load_config(scenario="bennu-tag-physical"), 2, out, master_seed=0, workers=1, progress=False, max_steps=4)
    applied = [CampaignStore(out).result(i)["applied"] for i in range(2)]
    drawn = [a["truth"]["physical"]["drawn"] for a in applied]
    assert drawn[0]["mass_error"] != drawn[1]["mass_error"]
    assert applied[0]["truth"]["physical"]["mass_true"] != applied[1]["truth"]["physical"]["mass_true"]
    assert s.methods["ffa"].J_p.three_sigma > 0.0  # the runs differ
    assert main(["run", "--from-campaign", str(out), "--index", "1", "--out", str(tmp_path / "again")]) == EXIT_OK
    assert json.loads((tmp_path / "again" / "refly.json").read_text())["equal"]


def test_states_inside_the_body_are_counted_on_the_dispersed_runs_surface(cache: Path) -> None:
    """A dispersed run's body has its own centre of mass: a state inside the nominal truth's surface lies
    outside the dispersed one's when the drawn contrasts move the body back."""
    from tubempc.analysis.runner import states_inside_body
    from tubempc.results import RunRecord
    from tubempc.scenario.sites import ray_cast

    scn = build_scenario(load_config(scenario="bennu-tag-physical"), cache_dir=cache)
    nominal = scn.physical
    drawn = next(
        t for t in (nominal.dispersed(s) for s in range(20)) if t.parts[0].offset_A[0] < nominal.parts[0].offset_A[0] - 0.1
    )
    body = nominal.parts[0]
    direction = np.array([1.0, 0.0, 0.0])
    point = ray_cast(body.shape, direction) + body.offset_A - 0.05 * direction  # inside the nominal truth
    rec = RunRecord.allocate("tbmpc", 0, 1, scn.config.mpc.horizon)
    rec.x[:, :3] = point  # at t = 0, where C_AL = I
    assert states_inside_body(scn, rec) == 2
    rec.applied = {"truth": {"physical": drawn.describe()}}
    assert states_inside_body(scn, rec) == 0
