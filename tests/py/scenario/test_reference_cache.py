"""The reference cache (issue #22): atomic writes, corrupt files regenerated, key includes the mesh."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tubempc import _core
from tubempc.scenario import reference
from tubempc.scenario.reference import ReferenceTrajectory, load_or_generate_reference

CUBE_V = np.array([[(k >> 0) & 1, (k >> 1) & 1, (k >> 2) & 1] for k in range(8)], dtype=float) * 100.0
CUBE_F = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                   [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])  # fmt: skip


class _Model:
    def __init__(self, vertices: np.ndarray) -> None:
        self.gravity = _core.gravity.PolyhedronGravity(vertices, CUBE_F, 1000.0)


@pytest.fixture
def calls(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """Replaces the SCP by a stub whose trajectory records the call number."""
    made: list[float] = []

    def fake(model: Any, x0: Any, xf: Any, **kwargs: Any) -> ReferenceTrajectory:
        made.append(float(len(made) + 1))
        return ReferenceTrajectory(
            t=np.arange(3.0),
            x=np.full((3, 12), made[-1]),
            u=np.zeros((2, 6)),
            cost=1.0,
            iterations=1,
            converged=True,
            max_step=0.0,
            max_defect=0.0,
            solve_time_s=0.0,
        )

    monkeypatch.setattr(reference, "generate_reference", fake)
    return made


def _get(model: _Model, cache: Path) -> ReferenceTrajectory:
    return load_or_generate_reference(
        model, np.zeros(12), np.ones(12), cache_dir=cache, key_extra={"shape": "s"}, dt=1.0, n_steps=2
    )


def test_cache_hit_and_truncated_file_regenerated(tmp_path: Path, calls: list[float]) -> None:
    model = _Model(CUBE_V)
    assert _get(model, tmp_path).x[0, 0] == 1.0
    assert _get(model, tmp_path).x[0, 0] == 1.0 and len(calls) == 1
    (path,) = tmp_path.glob("reference_*.npz")
    path.write_bytes(path.read_bytes()[:100])  # an interrupted write of an older version
    with pytest.warns(RuntimeWarning, match=str(path)):
        assert _get(model, tmp_path).x[0, 0] == 2.0
    assert _get(model, tmp_path).x[0, 0] == 2.0 and len(calls) == 2  # the regenerated file is valid


def test_edited_mesh_misses_the_cache(tmp_path: Path, calls: list[float]) -> None:
    _get(_Model(CUBE_V), tmp_path)
    edited = CUBE_V.copy()
    edited[7] *= 1.01  # same key_extra (file name, face count) but another mesh
    assert _get(_Model(edited), tmp_path).x[0, 0] == 2.0
    assert len(list(tmp_path.glob("reference_*.npz"))) == 2


def test_interrupted_write_leaves_no_file(tmp_path: Path, calls: list[float], monkeypatch: pytest.MonkeyPatch) -> None:
    def broken_savez(f: Any, **arrays: Any) -> None:
        f.write(b"PK\x03\x04 partial")
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", broken_savez)
    with pytest.raises(KeyboardInterrupt):
        _get(_Model(CUBE_V), tmp_path)
    assert list(tmp_path.iterdir()) == []
