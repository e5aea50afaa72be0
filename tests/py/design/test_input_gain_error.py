"""spacecraft.input_gain_error: ideal actuators whose input is known to a relative error eps carry the ball
|e| <= eps sqrt(3) u_max (and T_max) as the tube's input-error set (M38), in both methods."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tubempc.config import ConfigError, load_config
from tubempc.design.library import actuation_error_shapes, controller_settings, input_error_shapes
from tubempc.scenario import build_scenario


@pytest.fixture(scope="module")
def paper(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return build_scenario(load_config(), cache_dir=tmp_path_factory.mktemp("cache"))


def test_exact_input_carries_no_set(paper) -> None:  # type: ignore[no-untyped-def]
    assert paper.config.spacecraft.input_gain_error == 0.0
    assert actuation_error_shapes(paper) is None
    assert input_error_shapes(paper, "tbmpc") is None


def test_a_gain_bound_is_a_ball_of_the_largest_error(paper) -> None:  # type: ignore[no-untyped-def]
    scn = build_scenario(paper.config.with_overrides({"spacecraft.input_gain_error": 0.02}))
    E_p, E_r = actuation_error_shapes(scn)  # type: ignore[misc]
    u_max, T_max = scn.input_bounds
    # the worst input of the box, every axis at its bound, scaled by eps lies on the ball's surface
    u = np.full(3, u_max)
    assert float((0.02 * u) @ np.linalg.solve(E_p, 0.02 * u)) == pytest.approx(1.0, rel=1e-12)
    assert math.sqrt(E_r[0, 0]) == pytest.approx(0.02 * math.sqrt(3.0) * T_max, rel=1e-12)
    for method in ("tbmpc", "ffa"):
        s = controller_settings(scn, method)
        np.testing.assert_allclose(np.asarray(s.actuation_error[0]), E_p)


def test_the_bound_is_checked() -> None:
    with pytest.raises(ConfigError, match=r"spacecraft\.input_gain_error"):
        load_config().with_overrides({"spacecraft.input_gain_error": 1.5})
