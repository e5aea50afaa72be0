"""Shape models: file loaders and writers, and the project's default Bennu-like body.

Every loader returns a validated :class:`tubempc.Shape` in metres (closed, outward-oriented
triangle mesh; see docs/model.md, "Gravity"). Malformed input raises :class:`ShapeError`, a
``ValueError`` whose message starts with ``"<path>:<line>: "`` (the line of the offending vertex
or face; for binary PLY/STL files, which have no lines, the face index is named instead).

Formats (chosen from the extension, or ``fmt=``):

- ``obj``: Wavefront OBJ (``v x y z`` and ``f`` lines, 1-based or negative relative indices, ``i/t/n``
  tokens, polygons split into fans; other line kinds ignored) and
- ``tab``: the PDS "v/f" table of the Bennu radar model (``101955bennu.tab``), both read by the C++
  core's reader (``tubempc._core.gravity.load_shape``, ``cpp/include/tubempc/gravity/shape_io.hpp``),
  so Python and C++ programs read these files identically.
- ``icq``: Gaskell's implicitly connected quadrilateral format: ``q``, then 6 (q+1)^2 vertex lines
  ``x y z``, cube face f = 0..5, row j = 0..q, column i = 0..q (i fastest). Each grid cell is split
  into two triangles; the vertices the six grids share along the cube's edges are merged, and the
  generated triangles are oriented outward (their winding is ours, not the file's).
- ``ply``, ``stl``: read with ``trimesh`` (a dependency of the package); STL's per-triangle
  vertices are merged (exactly equal coordinates).

``unit`` is the length unit of the file's coordinates, ``"km"`` (default: PDS and ICQ models) or
``"m"``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from .._core.gravity import Shape, ShapeRepair
from .._core.gravity import load_shape as _core_load_shape

__all__ = [
    "FORMATS",
    "Shape",
    "ShapeError",
    "ShapeRepair",
    "bennu_like_shape",
    "geodesic_sphere",
    "load_shape",
    "save_icq",
    "save_shape",
]

FORMATS = ("obj", "tab", "icq", "ply", "stl")
_UNITS = {"km": 1000.0, "m": 1.0}
_EXTENSIONS = {".obj": "obj", ".tab": "tab", ".txt": "tab", ".icq": "icq", ".ply": "ply", ".stl": "stl"}


class ShapeError(ValueError):
    """A malformed shape file or mesh; ``path`` and ``line`` (1-based, or None) locate the problem."""

    def __init__(self, path: str | Path, line: int | None, message: str) -> None:
        self.path = str(path)
        self.line = line
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {message}")

    @classmethod
    def from_message(cls, path: str | Path, message: str) -> ShapeError:
        """The error of a message "<path>:<line>: <what>" or "<path>: <what>" (the C++ reader's)."""
        prefix = f"{path}:"
        rest = message[len(prefix) :] if message.startswith(prefix) else f" {message}"
        head, sep, tail = rest.partition(": ")
        if sep and head.isdigit():
            return cls(path, int(head), tail)
        return cls(path, None, rest.removeprefix(" "))


def _repair_hint(message: str) -> str:
    """The core's orientation advice ("use ShapeRepair::Orient") in terms a user can act on."""
    hint = "repair it with `tubempc repair-shape FILE --unit km|m --out FIXED.obj` (load_shape(..., repair=True))"
    return message.replace("use ShapeRepair::Orient to repair", hint).replace("use ShapeRepair::Orient", hint)


def _unit_scale(path: str | Path, unit: str) -> float:
    if unit not in _UNITS:
        raise ShapeError(path, None, f"unit must be 'km' or 'm', got {unit!r}")
    return _UNITS[unit]


def _format_of(path: Path, fmt: str | None) -> str:
    if fmt is not None:
        if fmt not in FORMATS:
            raise ShapeError(path, None, f"format must be one of {FORMATS}, got {fmt!r}")
        return fmt
    ext = path.suffix.lower()
    if ext not in _EXTENSIONS:
        raise ShapeError(path, None, f"cannot tell the format from the extension {ext!r}; pass fmt= one of {FORMATS}")
    return _EXTENSIONS[ext]


def _read_nonempty(path: Path) -> bytes:
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ShapeError(path, None, f"cannot read the file ({exc.strerror})") from exc
    if not data.strip():
        raise ShapeError(path, 1, "the file is empty")
    return data


def _text_lines(path: Path) -> list[str]:
    data = _read_nonempty(path)
    lines = data.split(b"\n")
    out = []
    for number, raw in enumerate(lines, start=1):
        if b"\x00" in raw:
            raise ShapeError(path, number, "binary data in a text shape file")
        try:
            out.append(raw.decode("utf-8"))
        except UnicodeDecodeError as exc:
            raise ShapeError(path, number, "binary data in a text shape file (not UTF-8 text)") from exc
    return out


_ASCII_INT = re.compile(r"[+-]?[0-9]{1,18}")


def _int_token(path: Path, number: int, token: str, what: str) -> int:
    """An ASCII decimal integer of at most 18 digits (so that it fits an int64), else ShapeError."""
    if _ASCII_INT.fullmatch(token) is None:
        raise ShapeError(path, number, f"{what}: {token[:40]!r} is not an integer of at most 18 ASCII digits")
    return int(token)


def _finite_floats(path: Path, number: int, tokens: Sequence[str], what: str) -> list[float]:
    try:
        values = [float(t) for t in tokens]
    except ValueError as exc:
        raise ShapeError(path, number, f"{what}: cannot read numbers from {' '.join(tokens)!r}") from exc
    if not all(math.isfinite(x) for x in values):
        raise ShapeError(path, number, f"{what}: non-finite coordinate in {' '.join(tokens)!r}")
    return values


def _validated(
    path: Path,
    vertices: npt.NDArray[np.float64],
    faces: npt.NDArray[np.int64],
    vertex_lines: Sequence[int | None],
    face_lines: Sequence[int | None],
    repair: ShapeRepair,
) -> Shape:
    """Builds the Shape, translating its error into a ShapeError at the offending line."""
    try:
        return Shape(vertices, faces, repair)
    except ValueError as exc:
        message = _repair_hint(str(exc))
        message += " [vertex and face numbers 0-based, in file order]"
        line: int | None = None
        where = ""
        match = re.search(r"\bface (\d+)", message)
        if match and int(match.group(1)) < len(face_lines):
            line = face_lines[int(match.group(1))]
            where = "" if line is not None else f" (face {match.group(1)})"
        else:
            match = re.search(r"\bvertex (\d+)", message)
            if match and int(match.group(1)) < len(vertex_lines):
                line = vertex_lines[int(match.group(1))]
        raise ShapeError(path, line, message + where) from exc


def _icq_faces(q: int) -> npt.NDArray[np.int64]:
    """Two triangles per grid cell of the six (q+1) x (q+1) grids (raw vertex numbering)."""
    j, i = np.meshgrid(np.arange(q), np.arange(q), indexing="ij")
    out = []
    for face in range(6):
        base = face * (q + 1) ** 2
        a = base + j * (q + 1) + i
        b, c, d = a + 1, a + (q + 1) + 1, a + (q + 1)
        out.append(np.stack([a, b, c], axis=-1).reshape(-1, 3))
        out.append(np.stack([a, c, d], axis=-1).reshape(-1, 3))
    return np.concatenate(out).astype(np.int64)


def _load_icq(path: Path, scale: float, repair: ShapeRepair) -> Shape:
    lines = _text_lines(path)
    content = [(n, line.split()) for n, line in enumerate(lines, start=1) if line.strip()]
    if not content:
        raise ShapeError(path, 1, "the file is empty")
    first_line, first = content[0]
    if len(first) != 1:
        raise ShapeError(path, first_line, f"expected the grid size q alone on the line, got {len(first)} tokens")
    q = _int_token(path, first_line, first[0], "grid size q")
    if q < 1:
        raise ShapeError(path, first_line, f"the grid size q must be >= 1, got {q}")
    expected = 6 * (q + 1) ** 2
    rows = content[1:]
    if len(rows) != expected:
        last = rows[-1][0] if rows else first_line
        raise ShapeError(path, last, f"q = {q} needs {expected} vertex lines, the file has {len(rows)}")
    raw = np.empty((expected, 3))
    raw_lines = []
    for k, (number, tokens) in enumerate(rows):
        if len(tokens) != 3:
            raise ShapeError(path, number, f"vertex line needs 3 coordinates, got {len(tokens)}")
        raw[k] = _finite_floats(path, number, tokens, "vertex")
        raw_lines.append(number)
    # Merge the copies of the vertices on the cube's edges (written identically by the grids).
    unique, index = np.unique(raw, axis=0, return_inverse=True)
    index = index.reshape(-1)
    first_of = np.full(len(unique), expected, dtype=np.int64)
    np.minimum.at(first_of, index, np.arange(expected))
    raw_faces = _icq_faces(q)
    faces = index[raw_faces]
    vertex_lines = [raw_lines[k] for k in first_of]
    face_lines = [raw_lines[k] for k in raw_faces[:, 0]]
    orient = ShapeRepair.ORIENT  # the triangles' winding is ours: orient it outward
    return _validated(path, unique * scale, faces, vertex_lines, face_lines, orient)


def _load_trimesh(path: Path, scale: float, fmt: str, repair: ShapeRepair) -> Shape:
    import trimesh  # a dependency; imported here because it is slow to import and rarely needed

    _read_nonempty(path)
    try:
        mesh = trimesh.load(path, file_type=fmt, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many exception types for unreadable files
        raise ShapeError(path, None, f"not a readable {fmt.upper()} file ({type(exc).__name__}: {exc})") from exc
    vertices = np.asarray(getattr(mesh, "vertices", np.empty((0, 3))), dtype=np.float64)
    faces = np.asarray(getattr(mesh, "faces", np.empty((0, 3))), dtype=np.int64)
    if vertices.size == 0 or faces.size == 0:
        raise ShapeError(path, None, f"no triangles in the {fmt.upper()} file")
    if not np.isfinite(vertices).all():
        k = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
        raise ShapeError(path, None, f"vertex {k} has a non-finite coordinate")
    if fmt == "stl":  # STL stores three separate vertices per triangle
        vertices, index = np.unique(vertices, axis=0, return_inverse=True)
        faces = index.reshape(-1)[faces]
    no_lines: list[int | None] = [None] * max(len(vertices), len(faces))
    return _validated(path, vertices * scale, faces, no_lines, no_lines, repair)


def load_shape(path: str | Path, unit: str = "km", fmt: str | None = None, repair: bool = False) -> Shape:
    """Reads a shape model into a validated :class:`tubempc.Shape` in metres.

    Args:
        path: OBJ, PDS v/f table, Gaskell ICQ, PLY or STL file (see the module docstring).
        unit: length unit of the file's coordinates, ``"km"`` or ``"m"``.
        fmt: one of :data:`FORMATS`; by default taken from the extension (``.txt`` = v/f table).
        repair: flip inconsistently oriented or inward faces instead of rejecting them.

    Raises:
        ShapeError: malformed file or mesh, naming the file and the line.
    """
    p = Path(path)
    scale = _unit_scale(p, unit)
    kind = _format_of(p, fmt)
    mode = ShapeRepair.ORIENT if repair else ShapeRepair.NONE
    if kind in ("obj", "tab"):  # the C++ core's reader (gravity/shape_io.hpp), the one reader of these formats
        try:
            return _core_load_shape(str(p), scale, mode)
        except ValueError as exc:
            raise ShapeError.from_message(p, _repair_hint(str(exc))) from exc
    if kind == "icq":
        return _load_icq(p, scale, mode)
    return _load_trimesh(p, scale, kind, mode)


def save_shape(
    path: str | Path,
    vertices: npt.ArrayLike,
    faces: npt.ArrayLike | None = None,
    unit: str = "km",
    fmt: str | None = None,
) -> None:
    """Writes a mesh as OBJ or a PDS v/f table (1-based faces), coordinates in ``unit``.

    ``vertices`` may be a :class:`tubempc.Shape` (then ``faces`` is omitted) or an (n, 3) array
    in metres with ``faces`` (m, 3) 0-based. Coordinates are written with 17 significant digits,
    so that :func:`load_shape` reads back the same numbers (up to the unit conversion).
    """
    p = Path(path)
    scale = _unit_scale(p, unit)
    kind = _format_of(p, fmt)
    if kind not in ("obj", "tab"):
        raise ShapeError(p, None, f"save_shape writes 'obj' and 'tab' files, not {kind!r}")
    if faces is None:
        v = np.asarray(vertices.vertices)  # type: ignore[union-attr]
        f = np.asarray(vertices.faces)  # type: ignore[union-attr]
    else:
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError("vertices must be (n, 3) and faces (m, 3)")
    out = [f"# written by tubempc.save_shape: {len(v)} vertices, {len(f)} faces, unit {unit}\n"] if kind == "obj" else []
    out += [f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in v / scale]
    out += [f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f]
    p.write_text("".join(out), encoding="utf-8")


def save_icq(path: str | Path, grid: npt.ArrayLike, unit: str = "km") -> None:
    """Writes Gaskell's ICQ format from a grid (6, q+1, q+1, 3) in metres indexed [face, j, i].

    The grids of neighbouring cube faces must repeat the vertices they share (as ICQ files do);
    :func:`load_shape` merges them. Coordinates are written with 17 significant digits.
    """
    p = Path(path)
    scale = _unit_scale(p, unit)
    g = np.asarray(grid, dtype=np.float64)
    if g.ndim != 4 or g.shape[0] != 6 or g.shape[1] != g.shape[2] or g.shape[1] < 2 or g.shape[3] != 3:
        raise ValueError(f"grid must have shape (6, q+1, q+1, 3) with q >= 1, got {g.shape}")
    q = g.shape[1] - 1
    rows = (g / scale).reshape(-1, 3)
    p.write_text(f"{q}\n" + "".join(f"{x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in rows), encoding="utf-8")


def geodesic_sphere(frequency: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Unit geodesic sphere: every icosahedron face split into frequency^2 triangles, outward."""
    if int(frequency) != frequency or frequency < 1:
        raise ValueError(f"subdivisions must be a positive integer, got {frequency!r}")
    frequency = int(frequency)
    t = (1.0 + math.sqrt(5.0)) / 2.0
    ico_v = np.array(
        [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
         [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]],
        dtype=np.float64,
    )  # fmt: skip
    ico_f = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
         [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
         [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]], dtype=np.int64)  # fmt: skip
    n = frequency
    points: list[npt.NDArray[np.float64]] = []
    tris: list[list[int]] = []
    for a, b, c in ico_f:
        A, B, C = ico_v[a], ico_v[b], ico_v[c]
        index = {}
        for i in range(n + 1):
            for j in range(n + 1 - i):
                index[(i, j)] = len(points)
                points.append(A + (B - A) * (i / n) + (C - A) * (j / n))
        for i in range(n):
            for j in range(n - i):
                tris.append([index[(i, j)], index[(i + 1, j)], index[(i, j + 1)]])
                if i + j < n - 1:
                    tris.append([index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)]])
    p = np.asarray(points)
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    # Points on shared icosahedron edges are computed from different faces: merge them.
    _, first, inverse = np.unique(np.round(p, 9), axis=0, return_index=True, return_inverse=True)
    return p[first], inverse.reshape(-1)[np.asarray(tris, dtype=np.int64)]


def bennu_like_shape(
    n_subdivisions: int = 12,
    volume: float = 6.2266e7,
    polar_ratio: float = 0.93,
    diamond_exponent: float = 1.6,
    ridge_height: float = 0.03,
    ridge_width: float = 0.15,
    longitude_bulge: float = 0.02,
) -> Shape:
    """The project's default asteroid: a deterministic, watertight "spinning-top" body like Bennu.

    A geodesic sphere (each icosahedron edge cut into ``n_subdivisions`` segments: 20 n^2 faces,
    10 n^2 + 2 vertices; the default 12 gives 2880 faces, like the radar model's 2692) whose radius
    in the direction of latitude phi and longitude lam is::

        r = s (1 + h exp(-(phi / w)^2)) (1 + b cos(2 lam) cos(phi)^2)
              / ((cos phi)^p + (|sin phi| / c)^p)^(1/p)

    (p = ``diamond_exponent``: the double-cone "diamond" profile; c = ``polar_ratio``; h, w =
    ``ridge_height``, ``ridge_width`` (rad): the equatorial ridge; b = ``longitude_bulge``), then
    translated so that its centre of mass is the origin and scaled so that its volume is exactly
    ``volume`` (m^3; default the radar model's 6.2266e7, docs/model.md "Gravity"). The body is
    symmetric under x -> -x, y -> -y, z -> -z up to the mesh, so its principal axes are close to
    the frame's, z the axis of maximum inertia (the spin axis).
    """
    if int(n_subdivisions) != n_subdivisions or n_subdivisions < 1:
        raise ValueError(f"n_subdivisions must be a positive integer, got {n_subdivisions!r}")
    if not (math.isfinite(volume) and volume > 0):
        raise ValueError(f"volume must be finite and > 0 (m^3), got {volume!r}")
    if not (0 < polar_ratio and 1 <= diamond_exponent and ridge_width > 0 and abs(longitude_bulge) < 0.5):
        raise ValueError("bennu_like_shape: polar_ratio > 0, diamond_exponent >= 1, ridge_width > 0, |bulge| < 0.5")
    u, faces = geodesic_sphere(int(n_subdivisions))
    phi = np.arcsin(np.clip(u[:, 2], -1.0, 1.0))
    lam = np.arctan2(u[:, 1], u[:, 0])
    p = diamond_exponent
    r = (np.cos(phi) ** p + (np.abs(np.sin(phi)) / polar_ratio) ** p) ** (-1.0 / p)
    r *= 1.0 + ridge_height * np.exp(-((phi / ridge_width) ** 2))
    r *= 1.0 + longitude_bulge * np.cos(2.0 * lam) * np.cos(phi) ** 2
    vertices = u * r[:, None]
    raw = Shape(vertices, faces)
    vertices = (vertices - raw.center_of_mass) * (volume / raw.volume) ** (1.0 / 3.0)
    return Shape(vertices, faces)
