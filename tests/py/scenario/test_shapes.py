"""Shape loaders and writers, the malformed-file corpus, Shape validation and bennu_like_shape."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tubempc import Shape, ShapeError, ShapeRepair, bennu_like_shape, load_shape, save_icq, save_shape

SHARED_DATA = Path(__file__).parents[3].parent / "shared" / "data"
RADAR = SHARED_DATA / "101955bennu.tab"

# Unit cube [0, 1]^3 (vertex k has coordinates of its bits), outward faces (0-based).
CUBE_V = np.array([[(k >> 0) & 1, (k >> 1) & 1, (k >> 2) & 1] for k in range(8)], dtype=float)
CUBE_F = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                   [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])  # fmt: skip


def _vf_text(v: np.ndarray, f: np.ndarray, base: int = 1) -> str:
    return "".join(f"v {x} {y} {z}\n" for x, y, z in v) + "".join(f"f {a + base} {b + base} {c + base}\n" for a, b, c in f)


def _same_mesh(shape: Shape, v: np.ndarray, f: np.ndarray, atol: float) -> None:
    np.testing.assert_allclose(shape.vertices, v, rtol=0, atol=atol)
    np.testing.assert_array_equal(shape.faces, f)


@pytest.mark.skipif(not RADAR.exists(), reason="no radar model in ../shared/data")
def test_radar_model_loads_with_documented_figures() -> None:
    s = load_shape(RADAR)
    assert (s.n_vertices, s.n_faces) == (1348, 2692)
    assert s.volume == pytest.approx(6.2266e7, rel=1e-4)
    assert s.mean_radius == pytest.approx(245.9, abs=0.1)
    assert np.linalg.norm(s.center_of_mass) < 1.0


@pytest.mark.parametrize("fmt", ["obj", "tab"])
@pytest.mark.parametrize("unit", ["km", "m"])
def test_obj_and_vf_round_trip(tmp_path: Path, fmt: str, unit: str) -> None:
    body = bennu_like_shape(n_subdivisions=4)
    path = tmp_path / f"body.{fmt}"
    save_shape(path, body, unit=unit)
    back = load_shape(path, unit=unit)
    _same_mesh(back, body.vertices, body.faces, atol=1e-12)
    save_shape(path, body.vertices, body.faces, unit=unit)
    assert load_shape(path, unit=unit).volume == pytest.approx(body.volume, rel=1e-14)


def test_obj_indices_are_one_based_and_tokens_read(tmp_path: Path) -> None:
    """OBJ and v/f files go through the C++ reader: index 0 is refused (OBJ is 1-based), naming the line."""
    path = tmp_path / "cube.obj"
    path.write_text(_vf_text(CUBE_V, CUBE_F, base=0))
    with pytest.raises(ShapeError, match=r"cube\.obj:9: face: vertex index 0 \(indices are 1-based\)") as info:
        load_shape(path, unit="m")
    assert info.value.line == 9 and info.value.path == str(path)
    path.write_text("# comment\nmtllib x.mtl\n" + _vf_text(CUBE_V, CUBE_F).replace("f 1 3 2", "f 1/1/1 3//2 2"))
    _same_mesh(load_shape(path, unit="m"), CUBE_V, CUBE_F, atol=0)


def _icq_cube_text(q: int) -> str:
    """ICQ file of the cube [-1, 1]^3 km: six (q+1)^2 grids written face by face, i fastest."""
    t = np.linspace(-1.0, 1.0, q + 1)
    lines = [f"{q:10d}"]
    for axis in range(3):
        for sign in (-1.0, 1.0):
            for b in t:
                for a in t:
                    p = np.empty(3)
                    p[axis] = sign
                    p[(axis + 1) % 3] = a
                    p[(axis + 2) % 3] = b
                    lines.append(" ".join(f"{x:.5f}" for x in p))
    return "\n".join(lines) + "\n"


def test_icq_grid_is_merged_into_a_closed_outward_mesh(tmp_path: Path) -> None:
    q = 4
    path = tmp_path / "cube.icq"
    path.write_text(_icq_cube_text(q))
    s = load_shape(path)
    assert s.n_vertices == 6 * q * q + 2
    assert s.n_faces == 12 * q * q
    assert s.volume == pytest.approx(8e9, rel=1e-14)
    np.testing.assert_allclose(s.center_of_mass, 0.0, atol=1e-6)
    np.testing.assert_allclose(s.inertia_per_unit_density, np.eye(3) * 8e9 * (2000.0**2) / 6, rtol=1e-12)


def test_icq_round_trip_of_a_cube_sphere(tmp_path: Path) -> None:
    q = 6
    path = tmp_path / "ball.icq"
    path.write_text(_icq_cube_text(q))
    grid = np.loadtxt(path, skiprows=1).reshape(6, q + 1, q + 1, 3)
    grid *= (1000.0 * (1.0 + 0.1 * grid[..., :1])) / np.linalg.norm(grid, axis=-1, keepdims=True)  # km -> m
    save_icq(path, grid)
    s = load_shape(path)
    assert s.n_vertices == 6 * q * q + 2 and s.n_faces == 12 * q * q
    # the saved grid's distinct points are exactly the shape's vertices
    np.testing.assert_allclose(np.unique(grid.reshape(-1, 3), axis=0), np.unique(s.vertices, axis=0), rtol=1e-15)
    with pytest.raises(ValueError, match="grid must have shape"):
        save_icq(path, grid[:5])


@pytest.mark.parametrize("fmt", ["ply", "stl"])
def test_ply_and_stl_round_trip_through_trimesh(tmp_path: Path, fmt: str) -> None:
    trimesh = pytest.importorskip("trimesh")
    body = bennu_like_shape(n_subdivisions=3)
    path = tmp_path / f"body.{fmt}"
    trimesh.Trimesh(body.vertices / 1000.0, body.faces, process=False).export(path)
    back = load_shape(path)
    assert back.n_faces == body.n_faces and back.n_vertices == body.n_vertices
    assert back.volume == pytest.approx(body.volume, rel=1e-6)  # STL stores float32
    np.testing.assert_allclose(back.center_of_mass, body.center_of_mass, atol=1e-3)


def _cube_lines(base: int = 1) -> list[str]:
    return _vf_text(CUBE_V, CUBE_F, base).splitlines()


def _with(lines: list[str], index: int, new: str | None) -> str:
    out = list(lines)
    if new is None:
        del out[index]
    else:
        out[index] = new
    return "\n".join(out) + "\n"


CUBE = _cube_lines()
# (file name, content, line the error must name, text the message must contain)
MALFORMED = [
    (
        "missing_vertex.obj",
        _with(CUBE, 7, None),
        11,
        "vertex index 8 out of range",
    ),  # vertex 8 gone: face 3 (line 11) uses it
    ("out_of_range.tab", _with(CUBE, 12, "f 1 2 99"), 13, "vertex index 99 out of range"),
    ("quad.obj", _with(CUBE, 9, "f 1 2 3 4"), 10, "duplicates face 0"),  # a polygon, split into a fan
    ("open.obj", _with(CUBE, 19, None), 19, "not closed"),  # face 11 gone: edge (3, 5) of face 10 is open
    ("flipped.obj", _with(CUBE, 14, "f 3 4 7"), 15, "oriented inconsistently"),  # face 6 was "f 3 7 4"
    ("nan.tab", _with(CUBE, 3, "v 1 1 nan"), 4, "non-finite"),
    ("text_in_number.obj", _with(CUBE, 2, "v 0 1 zero"), 3, "bad number 'zero'"),
    ("bad_index.obj", _with(CUBE, 10, "f 1 two 3"), 11, "bad vertex index 'two'"),
    ("two_coords.tab", _with(CUBE, 1, "v 1 0"), 2, "3 coordinates"),
    ("garbage_line.tab", _with(CUBE, 5, "hello world"), 6, "unknown record 'hello'"),
    ("degenerate.obj", _with(CUBE, 8, "f 1 1 2"), 9, "degenerate"),
    ("duplicate.obj", _with(CUBE, 19, "f 1 3 2"), 20, "duplicates face 0"),
    ("empty.obj", "", None, "no vertex records"),
    ("blank.tab", "\n  \n", None, "no vertex records"),
    ("binary.obj", "v 0 0 0\n\x00\x01\x02\n", 2, "binary"),
    ("bad_q.icq", "x\n1 2 3\n", 1, "grid size q"),
    ("short.icq", "2\n" + "0 0 0\n" * 10, 11, "needs 54 vertex lines"),
    ("nan.icq", _icq_cube_text(2).replace("-1.00000 -1.00000 -1.00000", "nan 0 0", 1), 2, "non-finite"),
]


@pytest.mark.parametrize(("name", "content", "line", "text"), MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_files_name_file_and_line(tmp_path: Path, name: str, content: str, line: int | None, text: str) -> None:
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(ShapeError, match=text) as info:
        load_shape(path, unit="m")
    assert str(info.value).startswith(f"{path}:{line}: " if line is not None else f"{path}: ")
    assert info.value.line == line and isinstance(info.value, ValueError)


def test_binary_garbage_and_bad_arguments(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    for name in ("garbage.obj", "garbage.tab", "garbage.icq", "garbage.ply", "garbage.stl"):
        path = tmp_path / name
        path.write_bytes(bytes(rng.integers(0, 256, 600, dtype=np.uint8)))
        with pytest.raises(ShapeError) as info:
            load_shape(path)
        assert str(path) in str(info.value)
    good = tmp_path / "cube.obj"
    good.write_text("\n".join(CUBE) + "\n")
    with pytest.raises(ShapeError, match="unit must be 'km' or 'm'") as info:
        load_shape(good, unit="mm")
    assert str(good) in str(info.value)
    with pytest.raises(ShapeError, match="extension"):
        load_shape(tmp_path / "cube.xyz")
    with pytest.raises(ShapeError, match="cannot open the file"):
        load_shape(tmp_path / "absent.obj")


def test_flipped_face_is_repaired_on_request(tmp_path: Path) -> None:
    path = tmp_path / "flipped.obj"
    path.write_text(_with(CUBE, 14, "f 3 4 7"))
    s = load_shape(path, unit="m", repair=True)
    assert s.n_flipped_faces == 1 and s.volume == pytest.approx(1.0)
    inverted = CUBE_F[:, [0, 2, 1]]
    with pytest.raises(ValueError, match="oriented inward"):
        Shape(CUBE_V, inverted)
    assert Shape(CUBE_V, inverted, ShapeRepair.ORIENT).volume == pytest.approx(1.0)


def test_bennu_like_shape_is_watertight_outward_spinning_top() -> None:
    s = bennu_like_shape()
    assert 2000 < s.n_faces < 4000
    assert 2 * s.n_edges == 3 * s.n_faces  # closed: every edge has two faces
    assert s.n_flipped_faces == 0
    assert Shape(s.vertices, s.faces).volume == pytest.approx(6.2266e7, rel=1e-9)  # validated, outward
    np.testing.assert_allclose(s.center_of_mass, 0.0, atol=1e-9)
    v = s.vertices
    rho = np.hypot(v[:, 0], v[:, 1])
    equatorial = rho[np.abs(v[:, 2]) < 10.0].max()
    polar = np.abs(v[np.hypot(v[:, 0], v[:, 1]) < 10.0, 2]).max()
    assert equatorial > 1.05 * polar  # the equatorial ridge
    I = s.inertia_per_unit_density
    assert I[2, 2] > max(I[0, 0], I[1, 1])  # spins about z, the axis of maximum inertia
    again = bennu_like_shape()
    np.testing.assert_array_equal(again.vertices, s.vertices)
    small = bennu_like_shape(n_subdivisions=5, volume=1e6)
    assert small.n_faces == 500 and small.volume == pytest.approx(1e6, rel=1e-9)
    with pytest.raises(ValueError, match="n_subdivisions"):
        bennu_like_shape(n_subdivisions=0)


def test_a_badly_oriented_mesh_points_to_a_command_a_user_can_run(tmp_path: Path) -> None:
    """The core's advice (ShapeRepair::Orient) is offered as `tubempc repair-shape`, which writes a mesh
    that loads without repair (issue #28)."""
    from tubempc.cli import main
    from tubempc.commands import EXIT_OK

    path = tmp_path / "flipped.obj"
    path.write_text(_with(CUBE, 14, "f 3 4 7"))
    with pytest.raises(ShapeError, match=r"tubempc repair-shape") as info:
        load_shape(path, unit="m")
    assert "ShapeRepair::" not in str(info.value)
    fixed = tmp_path / "fixed.obj"
    assert main(["repair-shape", str(path), "--unit", "m", "--out", str(fixed)]) == EXIT_OK
    s = load_shape(fixed, unit="m")
    assert s.n_flipped_faces == 0 and s.volume == pytest.approx(1.0)
