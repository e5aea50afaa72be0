"""Property-based fuzzing of the shape loaders, the config reader and the scenario-file reader (issue #22), and
the oracle itself."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tubempc.testing import fuzz


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31 - 1), index=st.integers(0, 10**6))
def test_mutated_inputs_are_rejected_cleanly_or_accepted_valid(tmp_path: Path, seed: int, index: int) -> None:
    fmt, data = fuzz.make_input(seed, index)
    outcome, detail = fuzz.check_input(fmt, data, tmp_path)
    assert outcome in ("rejected", "accepted"), (fmt, data[:200], detail)


@pytest.mark.parametrize("fmt", fuzz.FORMATS)
def test_seed_files_are_accepted(fmt: str) -> None:
    for data in fuzz.seed_files()[fmt]:  # one OBJ seed has quads: the (C++) reader splits them into fans
        assert fuzz.check_input(fmt, data) == ("accepted", "")


def test_oracle_finds_each_kind_of_broken_mesh() -> None:
    m = trimesh.creation.icosphere(subdivisions=1)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    assert fuzz.mesh_problems(v, f) == []
    assert "not watertight" in fuzz.mesh_problems(v, f[1:])
    flipped = f.copy()
    flipped[0] = flipped[0, ::-1]
    assert "inconsistent winding" in fuzz.mesh_problems(v, flipped)
    assert any("volume" in p for p in fuzz.mesh_problems(v, f[:, ::-1]))
    pushed = v.copy()
    pushed[0] *= -1.5
    assert "self-intersection" in fuzz.mesh_problems(pushed, f)
    lobes_v = np.vstack([v, v + np.array([0.5, 0.0, 0.0])])
    assert "self-intersection" in fuzz.mesh_problems(lobes_v, np.vstack([f, f + len(v)]))
    touch_v = np.vstack([v, -v + 2 * v[0]])
    assert "coincident vertices" in fuzz.mesh_problems(touch_v, np.vstack([f, f[:, ::-1] + len(v)]))


def test_campaign_counts_every_input(tmp_path: Path) -> None:
    n = 4 * len(fuzz.FORMATS)
    result = fuzz.run_campaign(n, seed=3, timeout_s=30.0, folder=tmp_path)
    assert sum(sum(c.values()) for c in result.counts.values()) == n
    assert all(sum(result.counts[f].values()) == 4 for f in fuzz.FORMATS)
    assert f"| all | {n} |" in fuzz.table(result)


@pytest.mark.parametrize(
    ("content", "text"),
    [
        (b"[asteroid]\n# \xff\xfe\n", r":2: not UTF-8"),
        (b'"1260 kg/m**1e400"', "non-finite unit exponent|every power must be"),
        (b'"10**10**10 kg/m^3"', "every power must be"),
        (b'"1260 kg/m**400"', "every power must be"),
    ],
)
def test_config_reader_errors_name_the_file(tmp_path: Path, content: bytes, text: str) -> None:
    from tubempc.config import ConfigError, load_config

    if content.startswith(b'"'):  # the packaged scenario with another density
        density, content = content, fuzz.seed_files()["toml"][0].replace(b'"1260 kg/m^3"', content)
        assert density in content
    path = tmp_path / "bad.toml"
    path.write_bytes(content)
    with pytest.raises(ConfigError, match=text) as info:
        load_config(path)
    assert str(path) in str(info.value)
