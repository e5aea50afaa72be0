"""Cost of the proximity model's kernels: f, f + Jacobians, one-node discretisation and the
linearisation + exact discretisation of an N-node horizon (N gravity evaluations included), timed
in C++ loops on one thread. Gravity: the Bennu radar polyhedron when ``tubempc.PolyhedronGravity``
and the shape file are available, otherwise a point mass (said in the output)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from ..models.dynamics import PointMassGravity, ProximityModel
from ..results.machine import machine_info

DESCRIPTION = "proximity dynamics: f + Jacobians and 30-node horizon discretisation (goal <= 3 ms)"

GOAL_HORIZON_S = 3e-3
DENSITY = 1260.0  # kg/m^3 (Table 1)
GM_BENNU = 6.67430e-11 * DENSITY * 6.2266e7  # point-mass fallback with the radar model's mass


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--nodes", type=int, default=30, help="horizon length N (default 30)")
    parser.add_argument("--dt", type=float, default=2.0, help="node length (s)")
    parser.add_argument("--repeats", type=int, default=300, help="calls per timing batch")
    parser.add_argument("--batches", type=int, default=5, help="batches (the minimum is reported)")
    parser.add_argument("--shape", type=Path, default=None, help="Bennu shape file (PDS .tab, km)")
    parser.add_argument("--point-mass", action="store_true", help="force the point-mass field")
    parser.add_argument("--json", type=Path, default=None, help="write the figures to this JSON file")


def _default_shape() -> Path | None:
    here = Path(__file__).resolve()
    for root in (Path.cwd(), *here.parents):
        p = root.parent / "shared" / "data" / "101955bennu.tab"
        if p.is_file():
            return p
    return None


def _read_tab(path: Path) -> tuple[np.ndarray, np.ndarray]:
    verts, faces = [], []
    with path.open(encoding="utf-8") as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] == "v":
                verts.append([float(v) * 1e3 for v in parts[1:4]])
            elif parts and parts[0] == "f":
                faces.append([int(i) - 1 for i in parts[1:4]])
    return np.asarray(verts, dtype=float), np.asarray(faces, dtype=np.int64)


def _gravity(args: argparse.Namespace) -> tuple[Any, str]:
    import tubempc

    poly = getattr(tubempc, "PolyhedronGravity", None) or getattr(_core, "PolyhedronGravity", None)
    if args.point_mass:
        return PointMassGravity(GM_BENNU), "point mass (forced by --point-mass)"
    if poly is None:
        return PointMassGravity(GM_BENNU), "point mass (tubempc.PolyhedronGravity is not built on this branch)"
    shape = args.shape or _default_shape()
    if shape is None or not shape.is_file():
        return PointMassGravity(GM_BENNU), "point mass (Bennu shape file not found; pass --shape)"
    vertices, faces = _read_tab(shape)
    g = poly(vertices, faces, DENSITY)
    return g, f"Bennu radar polyhedron ({len(vertices)} vertices, {len(faces)} faces, rho = {DENSITY})"


def _reference(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A horizon from the paper's initial state towards the landing point (Table 2)."""
    x0 = np.array([959.2404, 162.4966, 752.7547, 7.7649e-4, 0.0844, -0.0192, 0.3142, 2.925, 0.3142, 1e-3, 0.0, 3e-3])
    xf = np.array([0, 0, 246.5, 0, 0, 0, 0, 3.1416, 0, 0, 0, 0], dtype=float)
    s = np.linspace(0.0, 1.0, n)[:, None]
    X = (1 - s) * x0 + s * xf
    U = np.tile(np.array([1e-4, -1e-4, 2e-4, 0.01, -0.02, 0.01]), (n, 1))
    return X, U


def run(args: argparse.Namespace) -> int:
    gravity, label = _gravity(args)
    X, U = _reference(args.nodes)
    info = machine_info()
    print(f"machine: {info['cpu']} ({info['cores']} cores), Python {info['python']}")
    print(f"gravity: {label}")
    print(f"horizon: N = {args.nodes}, dt = {args.dt} s; min over {args.batches} batches of {args.repeats} calls")
    results: dict[str, Any] = {"machine": info, "gravity": label, "nodes": args.nodes, "dt": args.dt}
    for kin in ("first_order", "exact"):
        model = ProximityModel(gravity, {"kinematics": kin})
        t = _core.dynamics.time_kernels(model._impl, 0.0, args.dt, X, U, args.repeats, args.batches)
        t.pop("checksum")
        results[kin] = t
        hor = t["horizon_s"]
        meets = hor <= GOAL_HORIZON_S
        print(
            f"[{kin:5s}] gravity {t['gravity_s'] * 1e6:8.2f} us | f {t['f_s'] * 1e6:8.2f} us | "
            f"f + Jacobians {t['f_and_jacobians_s'] * 1e6:8.2f} us | discretise node "
            f"{t['discretize_node_s'] * 1e6:8.2f} us | {args.nodes}-node horizon {hor * 1e3:7.3f} ms "
            f"({'meets' if meets else 'MISSES'} the {GOAL_HORIZON_S * 1e3:.0f} ms goal)"
        )
    results["goal_horizon_s"] = GOAL_HORIZON_S
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2, default=str), encoding="utf-8")
        print(f"wrote {args.json}")
    return 0
