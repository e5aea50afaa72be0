"""Fuzz harness of the shape loaders, the config reader and the scenario-file reader (issue #22, "no
silent wrong answers").

Inputs are seed files of every format (OBJ, PDS v/f table, ICQ, ASCII and binary PLY and STL, the
scenario TOML, the C++ scenario file with navigation and actuators) with 1-3 random mutations: byte
flips, insertions and deletions, truncation, duplicated, deleted or swapped lines, number tokens
replaced by edge cases (0, -1, 2^63, 1e308, nan, non-ASCII digits), a vertex moved (possibly through
the body) and a shifted copy of the mesh appended (two overlapping lobes). Every input is read by
``tubempc.scenario.shapes.load_shape`` (and, for OBJ and v/f tables, also by the C++ loader
``_core.gravity.load_shape``), by ``tubempc.config.load_config`` or by ``_core.io.read_scenario``, and
classified by :func:`check_input`:

- ``rejected``: a ``ValueError`` (``ShapeError``, ``ConfigError``, the C++ ``invalid_argument``)
  whose message names the file;
- ``accepted``: a mesh that the independent check :func:`mesh_problems` finds valid (or a config, or a
  scenario file);
- ``broken_accepted``: an accepted mesh that :func:`mesh_problems` finds broken;
- ``no_location``: a ``ValueError`` whose message does not name the file;
- ``crash``: any other exception (or, in :func:`run_campaign`, a dead worker process);
- ``hang``: (:func:`run_campaign` only) no answer within the per-input time limit.

:func:`mesh_problems` uses trimesh (watertight, consistent winding, volume of every component), a
k-d tree for coincident vertices and a brute-force face-pair intersection test written here
independently of the C++ one (segment-plane crossing and barycentric coordinates), so it is meant
for the small seed meshes (hundreds of faces).
"""

from __future__ import annotations

import io
import logging
import math
import multiprocessing as mp
import random
import re
import tempfile
import time
import warnings
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = [
    "FORMATS",
    "OUTCOMES",
    "CampaignResult",
    "check_input",
    "make_input",
    "mesh_problems",
    "run_campaign",
    "seed_files",
    "table",
]

#: Formats of the fuzzed inputs (file extension without the dot; "toml" is the scenario config, "txt" the
#: C++ scenario file of ``tubempc export-scenario``).
FORMATS = ("obj", "tab", "icq", "ply", "stl", "toml", "txt")
#: Outcome classes of one input (see the module docstring).
OUTCOMES = ("rejected", "accepted", "broken_accepted", "no_location", "crash", "hang")

_Array = npt.NDArray[np.float64]
_IArray = npt.NDArray[np.int64]


def _icosphere() -> tuple[_Array, _IArray]:
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def _vf_text(v: _Array, f: _IArray) -> bytes:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f.tolist()]
    return ("\n".join(lines) + "\n").encode()


def _icq_text(q: int) -> bytes:
    """A cube sphere in ICQ layout: 6 grids of (q+1)^2 points, edge points written identically."""
    g = [-1.0 + 2.0 * k / q for k in range(q + 1)]
    rows = [str(q)]
    for face in range(6):
        a, s = face % 3, (1.0 if face < 3 else -1.0)
        for j in range(q + 1):
            for i in range(q + 1):
                p = [0.0, 0.0, 0.0]
                p[a], p[(a + 1) % 3], p[(a + 2) % 3] = s, g[i], g[j]
                n = math.sqrt(sum(c * c for c in p))
                rows.append(" ".join(repr(c / n) for c in p))
    return ("\n".join(rows) + "\n").encode()


def _bytes(exported: Any) -> bytes:
    return exported.encode() if isinstance(exported, str) else bytes(exported)


def _scenario_file() -> bytes:
    """A small valid scenario file (format ``_core.io.FORMAT_VERSION``) with every section: a 2-step
    mission, both methods' designs and a library, navigation (one landmark) and actuators (six thrusters,
    one failed, one wheel). Its shape file is not read."""
    from .. import _core

    io, act, nav = _core.io, _core.actuators, _core.nav
    s = io.ScenarioFile()
    for body in (s.model, s.truth):
        body.shape = "shape.obj"
    st = _core.mpc.Settings()
    st.horizon, st.dt = 3, 2.0
    st.Q, st.R, st.u_max = np.eye(12), np.eye(6), np.full(6, 0.5)
    s.settings = st
    s.reference = _core.mpc.Reference(np.zeros((12, 3)), np.zeros((6, 2)), 0.0)
    s.has_controller = True
    c = _core.control.ControllerSettings()
    for ident in (c.identification_p, c.identification_r):
        ident.w0, ident.S0 = np.zeros(6), 1e-4 * np.eye(6)
    s.controller = c
    d = _core.control.SubsystemDesign(-0.1 * np.hstack([np.eye(3), np.eye(3)]), 0.5, 1e-4 * np.eye(6), np.eye(6))
    designs = _core.control.ControllerDesigns()
    designs.initial_p = designs.initial_r = d
    designs.library_p = [d]
    s.tbmpc_designs = s.ffa_designs = designs
    s.x0, s.xf = np.ones(12), np.zeros(12)
    n = io.NavigationScenario()
    landmark = nav.Landmark()
    landmark.p_A, landmark.normal_A, landmark.face = np.array([250.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), 3
    n.enabled, n.landmarks, n.seed, n.error_set_scale = True, [landmark], 1_000_003, 26.2
    s.navigation = n
    a = io.ActuatorScenario()
    thrusters = []
    for axis in np.vstack([np.eye(3), -np.eye(3)]):
        t = act.ThrusterSpec()
        t.position_B, t.direction_B = np.roll(axis, 1), axis
        thrusters.append(t)
    thrusters[1].fault, thrusters[1].fault_time = act.FaultKind.from_string("failed_off"), 10.0
    settings = act.ActuationSettings()
    settings.modulation.period = settings.allocation.period = st.dt
    a.enabled, a.thrusters, a.wheels, a.wheel_momentum = True, thrusters, [act.ReactionWheelSpec()], np.zeros(1)
    a.settings = settings
    s.actuators = a
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scenario.txt"
        io.write_scenario(str(path), s, "fuzz seed")
        return path.read_bytes()


def seed_files() -> dict[str, list[bytes]]:
    """The valid seed inputs of every format."""
    import trimesh

    v, f = _icosphere()
    mesh = trimesh.Trimesh(v, f, process=False)
    obj_quads = (
        b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
        b"f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n"
    )
    toml = resources.files("tubempc").joinpath("data", "bennu_paper.toml").read_bytes()
    return {
        "obj": [_vf_text(v, f), b"# a comment\nvn 0 0 1\n" + _vf_text(v, f), obj_quads],
        "tab": [_vf_text(v, f)],
        "icq": [_icq_text(3)],
        "ply": [
            _bytes(mesh.export(file_type="ply", encoding="ascii")),
            _bytes(mesh.export(file_type="ply", encoding="binary")),
        ],
        "stl": [_bytes(mesh.export(file_type="stl_ascii")), _bytes(mesh.export(file_type="stl"))],
        "toml": [toml],
        "txt": [_scenario_file()],
    }


_SPECIAL_TOKENS = (
    "0",
    "-1",
    "1",
    "9223372036854775808",
    "-9223372036854775809",
    "99999999999999999999",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "1e-320",
    "\u0663",
    "\u00b2",
    "0x10",
    "1_0",
    "",
    "\xff",
    "1.5",
    "-0",
    "+2",
    "1e400",
    "10**10**10",
    "9^9^9",
    "2**-1",
)
_NUMBER = re.compile(rb"[-+]?\d+(\.\d*)?([eE][-+]?\d+)?")


def _mutate_once(data: bytes, fmt: str, rng: random.Random) -> bytes:
    kind = rng.randrange(10)
    lines = data.split(b"\n")
    if kind == 0 and data:  # flip a byte
        k = rng.randrange(len(data))
        return data[:k] + bytes([data[k] ^ (1 << rng.randrange(8))]) + data[k + 1 :]
    if kind == 1:  # insert random bytes
        k = rng.randrange(len(data) + 1)
        return data[:k] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 8))) + data[k:]
    if kind == 2 and data:  # delete a span or truncate
        k = rng.randrange(len(data))
        return data[:k] if rng.random() < 0.3 else data[:k] + data[k + rng.randint(1, 16) :]
    if kind == 3 and len(lines) > 1:  # duplicate a line
        k = rng.randrange(len(lines))
        return b"\n".join([*lines[: k + 1], lines[k], *lines[k + 1 :]])
    if kind == 4 and len(lines) > 1:  # delete a line
        k = rng.randrange(len(lines))
        return b"\n".join(lines[:k] + lines[k + 1 :])
    if kind == 5 and len(lines) > 2:  # swap two lines (e.g. two vertex lines)
        a, b = rng.randrange(len(lines)), rng.randrange(len(lines))
        lines[a], lines[b] = lines[b], lines[a]
        return b"\n".join(lines)
    if kind == 6:  # replace a number by an edge case
        numbers = list(_NUMBER.finditer(data))
        if numbers:
            m = rng.choice(numbers)
            return data[: m.start()] + rng.choice(_SPECIAL_TOKENS).encode() + data[m.end() :]
    if kind == 7 and fmt in ("obj", "tab", "icq"):  # move a vertex, possibly through the body
        rows = [k for k, line in enumerate(lines) if len(line.split()) == (3 if fmt == "icq" else 4)]
        if rows:
            k = rng.choice(rows)
            tokens = lines[k].split()
            try:
                xyz = [float(t) for t in tokens[-3:]]
            except ValueError:
                return data
            factor = rng.choice((-1.5, -0.5, 0.0, 0.5, 0.99, 1.01, 2.0))
            lines[k] = b" ".join(tokens[:-3] + [repr(c * factor).encode() for c in xyz])
            return b"\n".join(lines)
    if kind == 8 and fmt in ("obj", "tab"):  # append a shifted copy: two lobes, overlapping or not
        v = [line for line in lines if line.startswith(b"v ")]
        shift = rng.choice((0.0, 0.5, 1.0, 1.9, 3.0))
        out = list(lines)
        for line in v:
            t = line.split()
            try:
                out.append(
                    b"v " + b" ".join(repr(float(c) + (shift if i == 0 else 0.0)).encode() for i, c in enumerate(t[1:4]))
                )
            except ValueError:
                return data
        for line in lines:
            if line.startswith(b"f "):
                try:
                    out.append(b"f " + b" ".join(str(int(t.split(b"/")[0]) + len(v)).encode() for t in line.split()[1:]))
                except ValueError:
                    return data
        return b"\n".join(out)
    if kind == 9 and fmt == "toml":  # drop or duplicate a key, or change a value's type
        k = rng.randrange(len(lines))
        lines[k] = rng.choice(
            (
                b"",
                lines[k] + b"\n" + lines[k],
                lines[k].replace(b"=", b"= [", 1),
                lines[k].replace(b'"', b"", 1),
                b"[" + lines[k] + b"]",
            )
        )
        return b"\n".join(lines)
    return data


def make_input(seed: int, index: int) -> tuple[str, bytes]:
    """Input number ``index`` of the campaign ``seed``: (format, content), deterministic."""
    rng = random.Random(seed * 1_000_003 + index)
    fmt = FORMATS[index % len(FORMATS)]
    data = rng.choice(_SEEDS()[fmt])
    for _ in range(rng.randint(1, 3)):
        data = _mutate_once(data, fmt, rng)
    return fmt, data


_seed_cache: dict[str, list[bytes]] = {}


def _SEEDS() -> dict[str, list[bytes]]:
    if not _seed_cache:
        _seed_cache.update(seed_files())
    return _seed_cache


def _point_in_triangle(p: _Array, a: _Array, b: _Array, c: _Array, tol: float) -> npt.NDArray[np.bool_]:
    """Barycentric test, vectorised over rows; p is on the triangle's plane."""
    v0, v1, v2 = b - a, c - a, p - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    den = d00 * d11 - d01 * d01
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (d11 * d20 - d01 * d21) / den
        t = (d00 * d21 - d01 * d20) / den
    return np.asarray((s >= -tol) & (t >= -tol) & (s + t <= 1 + tol))


def _self_intersections(v: _Array, f: _IArray) -> int:
    """Face pairs that meet other than at the vertices they share (brute force over all pairs): an
    edge of one crossing the other's plane inside it, or two faces sharing an edge folded flat onto
    each other. (Overlaps of coplanar faces sharing no edge are not looked for.)"""
    with np.errstate(all="ignore"):
        return _self_intersections_unchecked(v, f)


def _self_intersections_unchecked(v: _Array, f: _IArray) -> int:
    m = len(f)
    jj, ll = np.triu_indices(m, 1)
    lo, hi = v[f].min(axis=1), v[f].max(axis=1)
    diag = float(np.linalg.norm(v.max(0) - v.min(0)))
    eps = 1e-9 * diag
    keep = np.all((lo[jj] <= hi[ll] + eps) & (lo[ll] <= hi[jj] + eps), axis=1)
    jj, ll = jj[keep], ll[keep]
    hits = np.zeros(len(jj), dtype=bool)
    for first, second in ((jj, ll), (ll, jj)):
        a, b, c = v[f[second, 0]], v[f[second, 1]], v[f[second, 2]]
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        shared_idx = f[first]
        for k in range(3):
            i0, i1 = shared_idx[:, k], shared_idx[:, (k + 1) % 3]
            p, q = v[i0], v[i1]
            dp, dq = ((p - a) * n).sum(1), ((q - a) * n).sum(1)
            crosses = (dp * dq <= 0) & (np.abs(dp - dq) > eps)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = dp / (dp - dq)
            x = p + t[:, None] * (q - p)
            inside = crosses & _point_in_triangle(x, a, b, c, 1e-9)
            # A crossing at a vertex of the other face that is also an end of this edge is shared.
            at_shared = np.zeros(len(x), dtype=bool)
            for corner in range(3):
                w = f[second, corner]
                at_shared |= ((w == i0) | (w == i1)) & (np.linalg.norm(x - v[w], axis=1) <= 1e3 * eps)
            hits |= inside & ~at_shared
    # Faces sharing an edge that are folded flat onto each other (opposite normals).
    shared_count = (f[jj][:, :, None] == f[ll][:, None, :]).sum(axis=(1, 2))
    nj = np.cross(v[f[jj, 1]] - v[f[jj, 0]], v[f[jj, 2]] - v[f[jj, 0]])
    nl = np.cross(v[f[ll, 1]] - v[f[ll, 0]], v[f[ll, 2]] - v[f[ll, 0]])
    cos = (nj * nl).sum(1) / (np.linalg.norm(nj, axis=1) * np.linalg.norm(nl, axis=1))
    hits |= (shared_count == 2) & (cos < -1 + 1e-9)
    hits &= shared_count < 3
    return int(hits.sum())


def mesh_problems(vertices: npt.ArrayLike, faces: npt.ArrayLike) -> list[str]:
    """Independent integrity check of an accepted mesh: an empty list when it is valid."""
    import trimesh
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    problems = []
    mesh = trimesh.Trimesh(v, f, process=False, validate=False)
    if not mesh.is_watertight:
        problems.append("not watertight")
    if not mesh.is_winding_consistent:
        problems.append("inconsistent winding")
    used = np.unique(f)
    diag = float(np.linalg.norm(v[used].max(0) - v[used].min(0)))
    # Components (faces connected through shared vertices) and their signed volumes.
    n_f = len(f)
    incidence = coo_matrix((np.ones(3 * n_f), (np.repeat(np.arange(n_f), 3), f.reshape(-1))), shape=(n_f, len(v))).tocsr()
    n_parts, label = connected_components(incidence @ incidence.T, directed=False)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    volume = np.bincount(label, (a * np.cross(b, c)).sum(1), minlength=n_parts) / 6.0
    for part_volume in volume:
        if not part_volume > 1e-12 * diag**3:
            problems.append(f"component volume {part_volume:g} m^3 not positive")
    if len(cKDTree(v[used]).query_pairs(1e-9 * diag)):
        problems.append("coincident vertices")
    if len(f) <= 5000 and _self_intersections(v, f):
        problems.append("self-intersection")
    return problems


def _names_file(message: str, path: Path) -> bool:
    return str(path) in message


def check_input(fmt: str, data: bytes, folder: Path | None = None) -> tuple[str, str]:
    """Reads one input with every loader of its format: (outcome, detail); see the module docstring."""
    from .. import _core
    from ..config import load_config
    from ..scenario.shapes import load_shape

    logging.getLogger("trimesh").setLevel(logging.CRITICAL)  # it logs every parse failure
    with tempfile.TemporaryDirectory(dir=folder) as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpy casts in trimesh's parsers; only the outcome counts
        path = Path(tmp) / f"fuzz.{fmt}"
        path.write_bytes(data)
        readers: list[tuple[str, Callable[[], Any]]]
        if fmt == "toml":
            readers = [("load_config", lambda: load_config(path))]
        elif fmt == "txt":
            readers = [("read_scenario", lambda: _core.io.read_scenario(str(path)))]
        else:
            readers = [("load_shape", lambda: load_shape(path, unit="m"))]
            if fmt in ("obj", "tab"):
                readers.append(("core.load_shape", lambda: _core.gravity.load_shape(str(path), 1.0)))
        outcome, detail = "accepted", ""
        for name, read in readers:
            try:
                result = read()
            except ValueError as exc:
                if not _names_file(str(exc), path):
                    return "no_location", f"{name}: {type(exc).__name__}: {exc}"[:300]
                outcome, detail = ("rejected", detail) if outcome != "broken_accepted" else (outcome, detail)
                continue
            except Exception as exc:  # the harness's purpose: anything else is a crash
                return "crash", f"{name}: {type(exc).__name__}: {exc}"[:300]
            if fmt not in ("toml", "txt"):
                problems = mesh_problems(result.vertices, result.faces)
                if problems:
                    return "broken_accepted", f"{name}: {', '.join(problems)}"
        return outcome, detail


def _worker(conn: Connection, folder: str) -> None:
    while True:
        job = conn.recv()
        if job is None:
            return
        fmt, data = job
        conn.send(check_input(fmt, data, Path(folder)))


@dataclass
class CampaignResult:
    """Counts per (format, outcome), examples of every non-clean outcome and the wall time."""

    counts: dict[str, Counter[str]]
    examples: list[dict[str, Any]]
    wall_time_s: float


def run_campaign(
    n_inputs: int,
    seed: int = 0,
    timeout_s: float = 10.0,
    folder: Path | None = None,
    progress: Callable[[int], None] | None = None,
) -> CampaignResult:
    """Checks inputs 0..n_inputs-1 of campaign ``seed`` in a worker process, one at a time, with a
    time limit per input (a worker that takes longer is killed: ``hang``; one that dies: ``crash``)."""
    ctx = mp.get_context("spawn")
    tmp = tempfile.TemporaryDirectory(dir=folder)
    counts: dict[str, Counter[str]] = {fmt: Counter() for fmt in FORMATS}
    examples: list[dict[str, Any]] = []
    start = time.perf_counter()

    def spawn() -> tuple[Any, Connection]:
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=_worker, args=(child, tmp.name), daemon=True)
        proc.start()
        return proc, parent

    proc, conn = spawn()
    try:
        for index in range(n_inputs):
            fmt, data = make_input(seed, index)
            conn.send((fmt, data))
            if conn.poll(timeout_s):
                try:
                    outcome, detail = conn.recv()
                except (EOFError, OSError):
                    outcome, detail = "crash", f"worker died (exit code {proc.join(1) or proc.exitcode})"
            elif not proc.is_alive():
                outcome, detail = "crash", f"worker died (exit code {proc.exitcode})"
            else:
                outcome, detail = "hang", f"no answer in {timeout_s} s"
            if outcome == "hang" or not proc.is_alive():
                proc.kill()
                proc.join()
                proc, conn = spawn()
            counts[fmt][outcome] += 1
            if outcome not in ("rejected", "accepted") and len(examples) < 50:
                examples.append({"index": index, "format": fmt, "outcome": outcome, "detail": detail})
            if progress is not None:
                progress(index + 1)
        conn.send(None)
        proc.join(5)
    finally:
        if proc.is_alive():
            proc.kill()
            proc.join()
        tmp.cleanup()
    return CampaignResult(counts, examples, time.perf_counter() - start)


def table(result: CampaignResult) -> str:
    """The counts as a Markdown table, one row per format and a total."""
    out = io.StringIO()
    out.write("| format | inputs | " + " | ".join(OUTCOMES) + " |\n")
    out.write("|---" * (len(OUTCOMES) + 2) + "|\n")
    total: Counter[str] = Counter()
    for fmt in FORMATS:
        c = result.counts[fmt]
        total.update(c)
        out.write(f"| {fmt} | {sum(c.values())} | " + " | ".join(str(c[o]) for o in OUTCOMES) + " |\n")
    out.write(f"| all | {sum(total.values())} | " + " | ".join(str(total[o]) for o in OUTCOMES) + " |\n")
    return out.getvalue()
