"""Scenario configuration (docs/model.md "Scenario")."""

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc.config import Config, ConfigDeprecationWarning, ConfigError, load_config


@pytest.fixture(scope="module")
def default() -> Config:
    return load_config()


def _default_text() -> str:
    import importlib.resources

    return importlib.resources.files("tubempc").joinpath("data", "bennu_paper.toml").read_text()


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "scenario.toml"
    p.write_text(text)
    return p


def _edit(text: str, pattern: str, repl: str) -> str:
    new, n = re.subn(pattern, repl, text, count=1, flags=re.MULTILINE)
    assert n == 1, pattern
    return new


def test_default_matches_the_paper(default: Config) -> None:
    c = default
    assert c.mpc.t_f == 600.0 and c.mpc.dt == 2.0 and c.mpc.horizon == 30 and c.mpc.n_steps == 300
    # Project defaults where the paper's literal choice is kept selectable (README, "Readings").
    assert c.mpc.scp_eps == 1e-3 and c.mpc.kinematics == "exact" and c.mpc.input_cost == "deviation"
    assert c.with_overrides({"mpc.kinematics": "first_order", "mpc.input_cost": "absolute"}).mpc.kinematics == "first_order"
    assert c.mpc.linearization == "reuse"
    assert c.environment.R == 1.685e11 and c.environment.beta_srp == 1.7744e15
    assert c.environment.mu_sun == 1.32712440018e20
    assert c.asteroid.density == 1260.0
    assert c.asteroid.spin_period == pytest.approx(4.296 * 3600.0, rel=1e-15)
    assert c.spacecraft.u_max == 0.55 and c.spacecraft.T_max == 3.0
    np.testing.assert_array_equal(c.spacecraft.J, np.diag([2750.0, 2750.0, 2030.0]))
    assert c.constraints.glide_slope_angle == pytest.approx(math.radians(70.0), rel=1e-15)
    assert c.constraints.los_angle == pytest.approx(math.radians(80.0), rel=1e-15)
    np.testing.assert_array_equal(c.mpc.Q_p, np.ones(6))
    np.testing.assert_array_equal(c.mpc.R_p, np.full(3, 1e3))
    np.testing.assert_array_equal(c.mpc.R_r, np.full(3, 1e4))
    assert c.identification.lambda_p == 0.96 and c.identification.lambda_r == 0.98
    assert c.identification.pw_scale == 9.0
    assert c.identification.measured_input == "residual"
    np.testing.assert_array_equal(np.diag(c.identification.S0_p), [4e-2] * 3 + [2.5e-3] * 3)
    np.testing.assert_array_equal(np.diag(c.identification.S0_r), [1e-6] * 3 + [1e-8] * 3)
    np.testing.assert_array_equal(c.identification.w0_p, np.zeros(6))
    np.testing.assert_array_equal(c.boundary.r0, [959.2404, 162.4966, 752.7547])
    np.testing.assert_array_equal(c.boundary.v0, [7.7649e-4, 0.0844, -0.0192])
    np.testing.assert_array_equal(c.boundary.phi0, [0.3142, 2.925, 0.3142])
    np.testing.assert_array_equal(c.boundary.w0, [1e-3, 0.0, 3e-3])
    np.testing.assert_array_equal(c.boundary.rf, [0.0, 0.0, 246.5])
    np.testing.assert_array_equal(c.boundary.phi_f, [0.0, 3.1416, 0.0])
    assert c.boundary.terminal == "paper"
    with pytest.raises(ValueError):
        c.boundary.r0[0] = 0.0  # read-only arrays


def test_round_trip_and_hash(default: Config, tmp_path: Path) -> None:
    p = tmp_path / "saved.toml"
    default.save(p)
    again = load_config(p)
    assert again == default
    assert again.to_dict() == default.to_dict()
    assert again.hash() == default.hash() == load_config().hash()
    assert len(default.hash()) == 64
    assert again.source == str(p) and default.source != again.source
    changed = default.with_overrides({"identification.lambda_p": 0.97})
    assert changed.identification.lambda_p == 0.97 and changed != default
    assert changed.hash() != default.hash()


def test_overrides(default: Config) -> None:
    c = default.with_overrides(
        {
            "spacecraft.u_max": "500 mm/s^2",
            "mpc.dt": 1.0,
            "boundary.rf": [0.0, 0.0, 260.0],
        }
    )
    assert c.spacecraft.u_max == pytest.approx(0.5)
    assert c.mpc.dt == 1.0 and c.mpc.n_steps == 600
    np.testing.assert_array_equal(c.boundary.rf, [0.0, 0.0, 260.0])
    with pytest.raises(ConfigError, match=r"identification\.lambda_r"):
        default.with_overrides({"identification.lambda_r": 1.2})
    with pytest.raises(ConfigError, match=r"mpc\.nope: unknown"):
        default.with_overrides({"mpc.nope": 1})


@pytest.mark.parametrize(
    ("pattern", "repl", "field", "message"),
    [
        (
            r'^u_max = "0.55 m/s\^2"',
            'u_max = "0.55 m/s"',
            "spacecraft.u_max",
            "expected acceleration [m/s^2], got '0.55 m/s' [velocity]",
        ),
        (r'^T_max = "3 N m"', 'T_max = "3 N"', "spacecraft.T_max", "torque"),
        (
            r'^glide_slope_angle = "70 deg"',
            'glide_slope_angle = "70"',
            "glide_slope_angle",
            "angle",
        ),
        (r'^dt = "2 s"', 'dt = "2 m"', "mpc.dt", "time"),
        (
            r"^lambda_p = 0.96",
            "lambda_p = 0.96\nlambda_q = 0.9",
            "identification.lambda_q",
            "unknown field",
        ),
        (
            r"^r0 = \{ value = \[959.2404, 162.4966, 752.7547\]",
            "r0 = { value = [959.2404, 162.4966]",
            "boundary.r0",
            "shape",
        ),
        (r"^Q_p = \[1.0, ", "Q_p = [", "mpc.Q_p", "shape"),
        (r"^lambda_p = 0.96", "lambda_p = 1.0", "identification.lambda_p", "(0, 1)"),
        (r"^horizon = 30", "horizon = 0", "mpc.horizon", ">= 1"),
        (r'^t_f = "600 s"', 't_f = "601 s"', "mpc.t_f", "multiple"),
        (r"^scp_eps = 1e-3", "scp_eps = nan", "mpc.scp_eps", "non-finite"),
        (
            r'^kinematics = "exact"',
            'kinematics = "second"',
            "mpc.kinematics",
            "one of",
        ),
        (r'^linearization = "reuse"', 'linearization = "always"', "mpc.linearization", "one of"),
        (r'^qp_solver = "active_set"', 'qp_solver = "osqp"', "mpc.qp_solver", "one of"),
        (r'^u_max = "0.55 m/s\^2"', "u_max = 0.55", "spacecraft.u_max", "unit"),
        (r"^\[disturbance\]", "[disturbanc]", "disturbanc", "unknown section"),
    ],
)
def test_errors_name_file_and_field(tmp_path: Path, pattern: str, repl: str, field: str, message: str) -> None:
    p = _write(tmp_path, _edit(_default_text(), pattern, repl))
    with pytest.raises(ConfigError) as info:
        load_config(p)
    text = str(info.value)
    assert str(p) in text and field in text and message in text, text


def test_invalid_toml_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="invalid TOML"):
        load_config(_write(tmp_path, "a = = 1"))
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "missing.toml")


@pytest.mark.parametrize(
    ("pattern", "repl", "message", "check"),
    [
        (r"^horizon = 30", "N = 30", "mpc.N: renamed to horizon", lambda c: c.mpc.horizon == 30),
        (r"^scp_eps = 1e-3", "eps = 2e-3", "mpc.eps: renamed to scp_eps", lambda c: c.mpc.scp_eps == 2e-3),
        (
            r'^input_cost = "deviation"',
            'input_cost = "paper"',
            "value 'paper' renamed to 'absolute'",
            lambda c: c.mpc.input_cost == "absolute",
        ),
        (
            r'^integrator = "rk4"',
            'integrator = "dopri"',
            "value 'dopri' renamed to 'dopri5'",
            lambda c: c.simulation.integrator == "dopri5",
        ),
        (
            r"^\[asteroid\]",
            '[asteroid]\nG = "6.67430e-11 m^3/(kg s^2)"',
            "asteroid.G: the field is no longer used",
            lambda c: not hasattr(c.asteroid, "G"),
        ),
        (
            r'^model = "drawn"',
            'model = "ellipsoid_uniform"',
            "value 'ellipsoid_uniform' renamed to 'drawn'",
            lambda c: c.disturbance.model == "drawn",
        ),
    ],
)
def test_old_spellings_are_read_with_a_warning(tmp_path: Path, pattern: str, repl: str, message: str, check: Any) -> None:

    p = _write(tmp_path, _edit(_default_text(), pattern, repl))
    with pytest.warns(ConfigDeprecationWarning, match=re.escape(message)) as caught:
        c = load_config(p)
    assert all(str(p) in str(w.message) for w in caught)
    assert check(c)


def test_old_and_new_name_together_is_an_error(tmp_path: Path) -> None:
    p = _write(tmp_path, _edit(_default_text(), r"^horizon = 30", "horizon = 30\nN = 20"))
    with pytest.raises(ConfigError, match=r"mpc\.N: old name of horizon, which is also given"):
        load_config(p)


def test_a_field_whose_meaning_changed_is_an_error_saying_what_to_write(tmp_path: Path) -> None:
    p = _write(tmp_path, _edit(_default_text(), r"^prior_memory = 1.0", "prior_weight = 5.0"))
    with pytest.raises(ConfigError, match=r"identification\.prior_weight: replaced by prior_memory") as info:
        load_config(p)
    assert str(p) in str(info.value)


def test_partial_file_takes_the_packaged_defaults_and_says_which(tmp_path: Path) -> None:
    p = _write(tmp_path, '[mpc]\nhorizon = 20\n\n[spacecraft]\nu_max = "0.4 m/s^2"\n')
    c = load_config(p)
    default = load_config()
    assert c.mpc.horizon == 20 and c.spacecraft.u_max == 0.4 and c.spacecraft.T_max == default.spacecraft.T_max
    assert "spacecraft.T_max" in c.defaulted and "mpc.dt" in c.defaulted and "boundary.r0" in c.defaulted
    assert "mpc.horizon" not in c.defaulted and "spacecraft.u_max" not in c.defaulted
    assert default.defaulted == ()  # the packaged file is complete
    assert c.with_overrides({"mpc.horizon": 25}).defaulted == c.defaulted
