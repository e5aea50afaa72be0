"""HDF5 result files round-trip arrays, units, configuration and seed; bad files get clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tubempc.results import load_result, save_result


def test_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(301, 12))
    status = np.array(["Solved", "FallbackShiftedPlan"])
    cfg = {"scenario": {"dt": 2.0, "N": 30}, "method": "ffa"}
    path = save_result(
        tmp_path / "r.h5",
        {"x": x, "status": status},
        config=cfg,
        seed=42,
        method="ffa",
        units={"x": "SI (m, m/s, rad, rad/s)"},
        metadata={"J_p": 1.5},
    )
    back = load_result(path)
    np.testing.assert_array_equal(back["x"], x)
    assert list(back["status"]) == list(status)
    assert back["config"] == cfg and back["seed"] == 42 and back["method"] == "ffa"
    assert back["metadata"] == {"J_p": 1.5} and back["units"]["x"].startswith("SI")


def test_not_a_result_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x00garbage")
    with pytest.raises(ValueError, match=r"bad\.h5"):
        load_result(bad)
