"""Actuators in the closed loop (docs/model.md "Actuators in the closed loop"): the configuration field, its
errors, and short runs flying a thruster-and-wheel spacecraft inside their certified tubes."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc import _core
from tubempc.analysis.metrics import nominal_input_fraction, run_metrics
from tubempc.analysis.runner import guarantee_lost
from tubempc.config import ConfigError, load_config
from tubempc.design.library import _prior_P_W, controller_settings, input_error_shapes
from tubempc.scenario import Scenario, ScenarioError, build_scenario, mpc_settings
from tubempc.scenario import actuators as A
from tubempc.sim.closed_loop import simulate
from tubempc.sim.setup import loop_setup

# A spacecraft the short hover-and-descend mission below can fly with a certified tube: the OSIRIS-REx-like
# layout with sized thrusters (the preset itself cannot fly these missions: docs/decisions.md "Actuators in the
# closed loop").
SIZED = Path(__file__).resolve().parents[3] / "examples" / "actuators" / "sized_thrusters.toml"
_OVERRIDES: dict[str, Any] = {
    "boundary.hover_altitude": "15 m",
    "spacecraft.T_max": "10 N*m",
    "identification.S0_p_position": {"value": [1e-4] * 3, "unit": "m^2"},
    "identification.S0_p_velocity": {"value": [1e-6] * 3, "unit": "m^2/s^2"},
    "disturbance.S_p_position": {"value": [1e-6] * 3, "unit": "m^2"},
    "disturbance.S_p_velocity": {"value": [1e-8] * 3, "unit": "m^2/s^2"},
}


def _preset(folder: Path, faults: str = "") -> Path:
    path = folder / "sized.toml"
    path.write_text(SIZED.read_text() + faults)
    return path


def _scenario(folder: Path, preset: Path | str, cache: Path) -> Scenario:
    cfg = load_config(scenario="bennu-tag").with_overrides({**_OVERRIDES, "spacecraft.actuators": str(preset)})
    return build_scenario(cfg, cache_dir=cache)


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("cache")


def test_default_is_ideal_and_a_bad_actuator_field_is_named(tmp_path: Path, cache: Path) -> None:
    cfg = load_config()
    assert cfg.spacecraft.actuators == A.IDEAL
    with pytest.raises(ScenarioError, match=r"spacecraft\.actuators: .*no_such_preset"):
        build_scenario(cfg.with_overrides({"spacecraft.actuators": "no_such_preset"}), cache_dir=cache)
    bad = tmp_path / "bad.toml"
    bad.write_text((A.PRESET_DIR / "osiris_rex_like.toml").read_text().replace('isp = "226.1 s"', 'isp = "226.1 m"'))
    with pytest.raises(ScenarioError, match=r"spacecraft\.actuators: .*thrusters\[0\]\.isp"):
        build_scenario(cfg.with_overrides({"spacecraft.actuators": str(bad)}), cache_dir=cache)
    with pytest.raises(ConfigError, match=r"disturbance\.scale_error_p: must be 0 with spacecraft\.actuators"):
        cfg.with_overrides({"spacecraft.actuators": "osiris_rex_like", "disturbance.scale_error_p": 0.01})


def test_ideal_actuators_leave_every_input_of_the_default_run_as_it_was(cache: Path) -> None:
    """With "ideal", the bounds, the designs' priors, the controller's error sets and the plant's input are the
    configured ones to the bit (the whole default run is compared with the previous version in
    docs/decisions.md "Actuators in the closed loop")."""
    scn = build_scenario(load_config(), cache_dir=cache)
    s = scn.config.spacecraft
    assert scn.actuation is None and loop_setup(scn).actuation is None
    assert scn.input_bounds == (s.u_max, s.T_max)
    assert np.array_equal(np.asarray(mpc_settings(scn).u_max), np.r_[[s.u_max] * 3, [s.T_max] * 3])
    ident = scn.config.identification
    for method in ("tbmpc", "ffa"):
        P_p, P_r = _prior_P_W(scn, method)
        assert np.array_equal(P_p, ident.pw_scale * np.asarray(ident.S0_p))
        assert np.array_equal(P_r, ident.pw_scale * np.asarray(ident.S0_r))
    assert all(not np.asarray(E).any() for E in controller_settings(scn, "ffa").actuation_error)
    rec = simulate(scn, "ffa", 3, max_steps=3, design_worker="none")
    mismatch = loop_setup(scn).actuators(3)
    for u, u_del in zip(rec.u, rec.u_delivered, strict=True):
        assert np.array_equal(u_del, np.r_[mismatch.apply_acceleration(u[:3]), mismatch.apply_torque(u[3:])])
    assert rec.actuation_statuses == ["ideal"] * 3 and not rec.propellant.any()
    assert run_metrics(rec, scn.config.mpc.dt, scn.xf).actuation is None


def test_the_paper_mission_is_beyond_the_osiris_rex_like_thrusters(cache: Path) -> None:
    """The preset's one-failure box gives 1.2e-3 m/s^2 at every attitude; the paper's reference needs 0.44."""
    cfg = load_config().with_overrides({"spacecraft.actuators": "osiris_rex_like"})
    with pytest.raises(ScenarioError, match=r"spacecraft\.u_max = 0\.00121.*achievable box of spacecraft\.actuators"):
        build_scenario(cfg, cache_dir=cache)


def test_short_run_with_thrusters_and_wheels_stays_in_its_certified_tube(tmp_path: Path, cache: Path) -> None:
    scn = _scenario(tmp_path, _preset(tmp_path), cache)
    assert scn.actuation is not None
    u_max, T_max = scn.input_bounds
    assert u_max == pytest.approx(float(np.asarray(scn.actuation.box.input_half_width)[0]))
    assert T_max == 10.0
    assert np.all(np.abs(scn.reference.u[:, :3]) <= u_max)
    rec = simulate(scn, "ffa", 0, max_steps=30, design_worker="none")
    assert np.all(rec.excursion <= 1.0)
    assert set(rec.actuation_statuses) == {"ok"}
    # The nominal inputs stay inside the input bound the tube leaves them (bench actuation's figure), and
    # some step plans against it, so the fraction is the MPC's tightening, not a looser one (to the QPs'
    # tolerance: a few 1e-7 m/s^2 here).
    room = nominal_input_fraction(rec, u_max)
    assert np.all((room > 0.0) & (room < 1.0))
    slack = room * u_max - np.abs(rec.v[:, :3]).max(axis=1)
    assert abs(slack.min()) <= 1e-3 * u_max
    assert all(s.startswith(("initial", "lyapunov", "library")) for s in rec.tube_statuses)  # certified
    assert rec.propellant.sum() > 0.0 and rec.pulses.sum() > 0
    # The delivered input differs from the command by the modulation and the truth's errors, within the
    # certified sets the tube carries.
    E_p, E_T = scn.actuation.error_shapes()
    e = rec.u - rec.u_delivered
    assert np.abs(e).max() > 0.0
    assert np.max(np.einsum("ij,ij->i", e[:, :3], np.linalg.solve(E_p, e[:, :3].T).T)) <= 1.0
    assert np.max(np.einsum("ij,ij->i", e[:, 3:], np.linalg.solve(E_T, e[:, 3:].T).T)) <= 1.0
    acc = rec.applied["actuators"]
    assert acc["propellant"] == pytest.approx(rec.propellant.sum())
    assert acc["pulses"] == int(rec.pulses.sum())
    summary = run_metrics(rec, scn.config.mpc.dt, scn.xf)
    assert summary.actuation is not None
    assert summary.actuation.statuses == {"ok": 30} and summary.actuation.not_delivered_steps == 0
    assert summary.actuation.thruster_delta_v >= summary.actuation.net_delta_v > 0.0
    assert guarantee_lost(summary) == []
    lost = dataclasses.replace(summary, actuation=dataclasses.replace(summary.actuation, not_delivered_steps=3))
    assert guarantee_lost(lost) == ["3 steps the actuators did not deliver"]


def test_a_failed_thruster_is_reported_and_flown_around(tmp_path: Path, cache: Path) -> None:
    fault = '\n[[faults]]\nthruster = 3\nkind = "failed_off"\ntime = "20 s"\n'
    scn = _scenario(tmp_path, _preset(tmp_path, fault), cache)
    rec = simulate(scn, "tbmpc", 0, max_steps=25, design_worker="none")
    assert rec.actuation_statuses[:10] == ["ok"] * 10
    assert set(rec.actuation_statuses[10:]) == {"thruster_failed"}
    assert np.all(rec.excursion <= 1.0)
    assert rec.applied["actuators"]["faults"] == [{"thruster": 3, "kind": "failed_off", "time": 20.0}]


def test_a_preset_over_its_base_changes_only_the_fields_it_gives(tmp_path: Path) -> None:
    base, cal = A.load_actuators("osiris_rex_like", 5.0), A.load_actuators("osiris_rex_like_calibrated", 5.0)
    assert (cal.name, cal.mass, len(cal.cluster)) == ("osiris_rex_like_calibrated", base.mass, len(base.cluster))
    for j in range(len(base.cluster)):
        b, c = base.cluster.thruster(j), cal.cluster.thruster(j)
        assert (b.scale_error_bound, c.scale_error_bound) == (0.05, 0.01)
        assert c.misalignment_bound == pytest.approx(np.radians(0.1), rel=1e-12)
        assert (c.max_thrust, c.min_on_time, c.isp) == (b.max_thrust, b.min_on_time, b.isp)
        assert np.array_equal(c.position_B, b.position_B) and np.array_equal(c.direction_B, b.direction_B)
    assert np.array_equal(cal.wheels.axes_B, base.wheels.axes_B)
    assert np.array_equal(cal.wheels.max_momentum, base.wheels.max_momentum)
    rounding = _core.actuators.PulseRounding
    assert (base.modulation.rounding, cal.modulation.rounding) == (rounding.Carry, rounding.Nearest)
    assert (base.modulation.opposed_pairs, cal.modulation.opposed_pairs) == (False, True)
    # The layout's opposed pairs: +-z and +-t at each corner, on one line of action.
    mod = _core.actuators.PulseModulator(cal.cluster, cal.modulation)
    D = np.asarray(cal.cluster.mapping)
    partners = [mod.partner(j) for j in range(len(cal.cluster))]
    assert partners == [1, 0, 3, 2, 5, 4, 7, 6, 9, 8, 11, 10, 13, 12, 15, 14]
    assert all(np.allclose(D[:, j], -D[:, p], atol=1e-12) for j, p in enumerate(partners))
    assert cal.modulation.on_time_resolution == base.modulation.on_time_resolution  # the field not given is the base's
    (tmp_path / "own.toml").write_text('base = "osiris_rex_like_calibrated"\n[modulation]\non_time_resolution = "2 ms"\n')
    own = A.load_actuators(tmp_path / "own.toml", 5.0)
    assert own.name == "own" and own.modulation.on_time_resolution == 0.002
    assert own.cluster.thruster(0).scale_error_bound == 0.01  # through two bases
    (tmp_path / "a.toml").write_text('base = "b.toml"\n')
    (tmp_path / "b.toml").write_text('base = "a.toml"\n')
    with pytest.raises(A.ActuatorConfigError, match=r"a\.toml\.base.*a\.toml is a base of itself"):
        A.load_actuators(tmp_path / "a.toml", 5.0)
    (tmp_path / "c.toml").write_text('base = "osiris_rex_like"\n[thruster_defaults]\nscale_error_bnd = 0.01\n')
    with pytest.raises(A.ActuatorConfigError, match=r"c\.toml\.thruster_defaults: unknown field.*scale_error_bnd"):
        A.load_actuators(tmp_path / "c.toml", 5.0)
    (tmp_path / "d.toml").write_text('base = "osiris_rex_like"\n[modulation]\nrounding = "round"\n')
    with pytest.raises(A.ActuatorConfigError, match=r"d\.toml\.modulation\.rounding: expected one of \['carry', '"):
        A.load_actuators(tmp_path / "d.toml", 5.0)
    (tmp_path / "e.toml").write_text('base = "osiris_rex_like"\n[modulation]\nopposed_pairs = "yes"\n')
    with pytest.raises(A.ActuatorConfigError, match=r"e\.toml\.modulation\.opposed_pairs: expected true or false"):
        A.load_actuators(tmp_path / "e.toml", 5.0)
    (tmp_path / "f.toml").write_text('base = "osiris_rex_like"\n[modulation]\nopposed_pairs = true\n')  # carry-over
    with pytest.raises(A.ActuatorConfigError, match=r"f\.toml: modulation\.opposed_pairs: needs rounding = \"nearest\""):
        A.load_actuators(tmp_path / "f.toml", 5.0)


def test_the_osiris_rex_like_tag_fits_the_preset_s_authority_with_its_certified_error(cache: Path) -> None:
    """bennu-tag-osirisrex: the 20 min TAG on the calibrated preset at a 5 s period; the reference and the certified
    error set leave the tube a margin of the one-failure box, which the uncalibrated preset's error set takes whole
    (docs/decisions.md "An OSIRIS-REx-like spacecraft in the loop")."""
    cfg = load_config(scenario="bennu-tag-osirisrex")
    assert (cfg.spacecraft.actuators, cfg.mpc.t_f, cfg.mpc.dt) == ("osiris_rex_like_calibrated", 1200.0, 5.0)
    scn = build_scenario(cfg, cache_dir=cache)
    assert scn.actuation is not None
    u_max, T_max = scn.input_bounds
    # the one-failure box in L at every attitude: the B box's force half-width over sqrt(3) m
    force_B = float(np.asarray(scn.actuation.box.half_width_B)[:3].min())
    assert u_max == pytest.approx(force_B / (np.sqrt(3.0) * 1500.0), rel=1e-12) and T_max == 3.0
    # 16 thrusters of 1 lbf on 1500 kg: the box is below what all of them give along one axis
    assert u_max < 8 * 4.4482216152605 / 1500.0
    peak = float(np.abs(scn.reference.u[:, :3]).max())
    assert peak <= 0.2 * u_max * (1.0 + 1e-9)
    E_p, _ = scn.actuation.error_shapes()
    radius = float(np.sqrt(E_p[0, 0]))
    assert peak + radius < 0.7 * u_max
    raw = A.scenario_actuation("osiris_rex_like", A.PRESET_DIR, 5.0, 1.0, 3.0)
    assert float(np.sqrt(raw.error_shapes()[0][0, 0])) > 0.8 * raw.u_max
    # TBMPC-FFA's feed-forward (M43): the controller grows its input-error sets by the feed-forward's box as the
    # set-up designs do (one function), a ball of radius r + sqrt(3) rho for the u_p ball; TBMPC is not grown.
    assert cfg.identification.feedforward
    rho = cfg.identification.feedforward_limit * u_max
    for method in ("ffa", "tbmpc"):
        ctrl = _core.control.Controller(
            _core.mpc.LinearizedProximityModel(scn.model.core), mpc_settings(scn), controller_settings(scn, method)
        )
        want = input_error_shapes(scn, method)
        assert want is not None
        for got, w in zip(ctrl.settings.actuation_error, want, strict=True):
            np.testing.assert_array_equal(got, w)
    E_ffa = input_error_shapes(scn, "ffa")
    assert E_ffa is not None
    np.testing.assert_allclose(E_ffa[0], (radius + np.sqrt(3.0) * rho) ** 2 * np.eye(3), rtol=1e-12)
