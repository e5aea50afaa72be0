"""Mesh integrity (issue #22): broken meshes that both loaders must reject with the file and line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from tubempc import Shape, ShapeError, _core, load_shape


def _icosahedron(radius: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    m = trimesh.creation.icosahedron()
    return np.asarray(m.vertices) * radius, np.asarray(m.faces, dtype=np.int64)


def _obj(path: Path, v: np.ndarray, f: np.ndarray) -> Path:
    path.write_text(
        "".join(f"v {float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in v)
        + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)
    )
    return path


def _both_reject(path: Path, pattern: str) -> None:
    with pytest.raises(ShapeError, match=pattern) as info:
        load_shape(path, unit="m")
    assert str(path) in str(info.value)
    with pytest.raises(ValueError, match=pattern) as core_info:
        _core.gravity.load_shape(str(path), 1.0)
    assert str(core_info.value).startswith(f"{path}:")


def test_valid_icosahedron_is_accepted(tmp_path: Path) -> None:
    v, f = _icosahedron()
    shape = load_shape(_obj(tmp_path / "ico.obj", v, f), unit="m")
    assert shape.volume == pytest.approx(trimesh.Trimesh(v, f).volume, rel=1e-12)


def test_swapped_vertex_lines_self_intersect(tmp_path: Path) -> None:
    v, f = _icosahedron()
    v[[0, 5]] = v[[5, 0]]
    _both_reject(_obj(tmp_path / "swap.obj", v, f), "intersects itself")


def test_vertex_pushed_through_the_body(tmp_path: Path) -> None:
    v, f = _icosahedron()
    v[0] = -1.5 * v[0]
    _both_reject(_obj(tmp_path / "pushed.obj", v, f), "intersects itself")


def test_two_overlapping_lobes_are_rejected(tmp_path: Path) -> None:
    v, f = _icosahedron()
    v2 = np.vstack([v, v + np.array([0.8, 0.0, 0.0])])
    f2 = np.vstack([f, f + len(v)])
    _both_reject(_obj(tmp_path / "lobes.obj", v2, f2), "intersects itself")
    # Disjoint lobes are a valid (two-component) body.
    v3 = np.vstack([v, v + np.array([3.0, 0.0, 0.0])])
    assert load_shape(_obj(tmp_path / "apart.obj", v3, f2), unit="m").volume == pytest.approx(
        2 * trimesh.Trimesh(v, f).volume, rel=1e-12
    )


def test_coincident_vertices_are_rejected(tmp_path: Path) -> None:
    # Two icosahedra touching at one point through distinct vertex indices.
    v, f = _icosahedron()
    shift = v[0] - (-v[0])
    v2 = np.vstack([v, -v + shift])
    _both_reject(_obj(tmp_path / "touch.obj", v2, np.vstack([f, f[:, ::-1] + len(v)])), "coincides with vertex")


def test_flat_body_encloses_no_volume(tmp_path: Path) -> None:
    # Two nearly coincident sheets: volume 1e-14 of the bounding box's diagonal cubed.
    v, f = _icosahedron()
    v[:, 2] *= 1e-14
    with pytest.raises(ValueError, match=r"encloses no volume|intersects itself"):
        Shape(v, f)


def test_folded_neighbours_are_rejected() -> None:
    # A tetrahedron's apex moved into the plane of the base, folding two faces onto the base.
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0.2, 0.2, 0.0]])
    f = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
    with pytest.raises(ValueError, match=r"encloses no volume|intersects itself"):
        Shape(v, f)


def test_non_utf8_bytes_in_errors_are_escaped(tmp_path: Path) -> None:
    path = tmp_path / "bytes.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 \xff\xfe 0\n")
    with pytest.raises(ValueError, match=r"\\xff\\xfe") as info:
        _core.gravity.load_shape(str(path), 1.0)
    assert f"{path}:2:" in str(info.value)
    with pytest.raises(ShapeError, match=":2:"):
        load_shape(path)


@pytest.mark.parametrize(
    ("name", "content", "line"),
    [
        ("huge.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 9223372036854775808\n", 6),
        ("digit.icq", "\u0663\n1 2 3\n", 1),
        ("super.icq", "\u00b2\n1 2 3\n", 1),
        ("zero.icq", "0\n", 1),
    ],
)
def test_malformed_integers_raise_shape_error_with_line(tmp_path: Path, name: str, content: str, line: int) -> None:
    path = tmp_path / name
    path.write_text(content, encoding="utf-8")
    with pytest.raises(ShapeError) as info:
        load_shape(path)
    assert info.value.line == line and str(info.value).startswith(f"{path}:{line}:")
