"""Per-point cost of (U, a, Hess U) of tubempc.PolyhedronGravity next to the polyhedral-gravity package
and Basilisk's PolyhedralGravityModel (optional extra ``basilisk``), with their agreement."""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import PolyhedronGravity, bennu_like_shape, load_shape
from ..results.machine import machine_info

DESCRIPTION = (
    "polyhedron gravity (U, acceleration, Hessian): microseconds per point on one and all threads, "
    "side by side with polyhedral-gravity and Basilisk on the same points, with their largest differences"
)

_DEFAULT_SHAPE = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "101955bennu.tab"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--shape",
        type=Path,
        default=None,
        help=f"shape file (default {_DEFAULT_SHAPE} if present, else bennu_like_shape())",
    )
    parser.add_argument("--unit", default="km", help="length unit of the shape file (km or m)")
    parser.add_argument("--density", type=float, default=1260.0, help="kg/m^3 (default 1260, Table 1)")
    parser.add_argument("--points", type=int, default=300, help="points: a third near, far and inside")
    parser.add_argument("--repeat", type=int, default=3, help="timed repetitions; the fastest is reported")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-reference", action="store_true", help="skip polyhedral-gravity and Basilisk")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures to this JSON file")


def _points(n: int, radius: float, seed: int) -> npt.NDArray[np.float64]:
    """Directions uniform on the sphere; radii near (1-1.3 R), far (2-20 R) and inside (0-0.6 R)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    k = n // 3
    r = np.concatenate([rng.uniform(1.0, 1.3, k), rng.uniform(2.0, 20.0, k), rng.uniform(0.0, 0.6, n - 2 * k)])
    return d * (r * radius)[:, None]


def _best(fn: Any, repeat: int) -> float:
    best = float("inf")
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _reference(vertices: Any, faces: Any, density: float, pts: Any, repeat: int) -> dict[str, Any] | None:
    try:
        import polyhedral_gravity as pg
    except ImportError:
        return None
    poly = pg.Polyhedron((vertices, faces), density, integrity_check=pg.PolyhedronIntegrity.DISABLE)
    plist = pts.tolist()
    t1 = _best(lambda: pg.evaluate(poly, plist, parallel=False), repeat)
    tn = _best(lambda: pg.evaluate(poly, plist, parallel=True), repeat)
    out = pg.evaluate(poly, plist, parallel=False)
    # polyhedral-gravity (metres, kg/m^3): the same convention, U > 0 and a = grad U; second
    # derivatives ordered xx, yy, zz, xy, xz, yz.
    U = np.array([o[0] for o in out])
    a = np.array([o[1] for o in out])
    h = np.array([o[2] for o in out])
    H = np.stack([h[:, 0], h[:, 3], h[:, 4], h[:, 3], h[:, 1], h[:, 5], h[:, 4], h[:, 5], h[:, 2]], 1).reshape(-1, 3, 3)
    return {
        "version": getattr(pg, "__version__", "?"),
        "parallelization": getattr(pg, "__parallelization__", "?"),
        "t1": t1,
        "tn": tn,
        "U": U,
        "a": a,
        "H": H,
    }


def _basilisk(vertices: Any, faces: Any, gm: float, pts: Any, repeat: int) -> dict[str, Any] | None:
    """Basilisk's PolyhedralGravityModel (optional extra ``basilisk``: PyPI ``bsk``) on the same mesh.

    Conventions: vertices in metres, facets 1-based (Basilisk's), muBody = G M (m^3/s^2) from which it
    derives the density; computeField gives a = grad U (m/s^2) in the body frame and
    computePotentialEnergy U > 0 (m^2/s^2): the same conventions as ours. It evaluates one point per
    call (the per-call Python overhead, ~1 us, is in its time)."""
    try:
        import Basilisk
        from Basilisk.simulation import polyhedralGravityModel
    except ImportError:
        return None
    poly = polyhedralGravityModel.PolyhedralGravityModel()
    poly.xyzVertex = np.asarray(vertices, dtype=float).tolist()
    poly.orderFacet = (np.asarray(faces, dtype=np.int64) + 1).tolist()
    poly.muBody = float(gm)
    poly.initializeParameters()
    plist = [np.asarray(p, dtype=float) for p in pts]

    def field() -> list[Any]:
        return [poly.computeField(p) for p in plist]

    t1 = _best(field, repeat)
    return {
        "version": getattr(Basilisk, "__version__", "?"),
        "t1": t1,
        "U": np.array([poly.computePotentialEnergy(p) for p in plist]),
        "a": np.array([np.asarray(a, dtype=float).ravel() for a in field()]),
    }


def run(args: argparse.Namespace) -> int:
    if args.shape is not None:
        shape, source = load_shape(args.shape, unit=args.unit), str(args.shape)
    elif _DEFAULT_SHAPE.exists():
        shape, source = load_shape(_DEFAULT_SHAPE, unit="km"), f"{_DEFAULT_SHAPE} (radar model)"
    else:
        shape, source = bennu_like_shape(), "bennu_like_shape() (generated: the radar model was not found)"
    model = PolyhedronGravity(shape, args.density)
    pts = _points(args.points, shape.mean_radius, args.seed)
    n = len(pts)
    hw = os.cpu_count() or 1

    model.evaluate(pts[:4], threads=1)  # warm-up
    t1 = _best(lambda: model.evaluate(pts, threads=1), args.repeat)
    tn = _best(lambda: model.evaluate(pts, threads=0), args.repeat)
    U, a, H = model.evaluate(pts, threads=1)
    ref = None if args.no_reference else _reference(shape.vertices, shape.faces, args.density, pts, args.repeat)

    info = machine_info()
    result: dict[str, Any] = {
        "benchmark": "gravity",
        "machine": info,
        "shape": source,
        "n_vertices": int(shape.n_vertices),
        "n_faces": int(shape.n_faces),
        "points": n,
        "hardware_threads": hw,
        "tubempc_us_per_point_1_thread": 1e6 * t1 / n,
        "tubempc_us_per_point_all_threads": 1e6 * tn / n,
    }
    print(f"machine: {info['cpu']}, {info['cores']} cores; core built with {info['core_build']['cxx_flags']!r}")
    print(f"shape: {source}: {shape.n_vertices} vertices, {shape.n_faces} faces")
    print(f"{n} points (near, far, inside); fastest of {args.repeat} runs; (U, a, Hess U) per point")
    print(f"{'':24s}{'1 thread':>14s}{f'{hw} threads':>14s}")
    print(f"{'tubempc':24s}{1e6 * t1 / n:11.1f} us{1e6 * tn / n:11.1f} us")
    if ref is not None:
        rel_u = float(np.max(np.abs(U - ref["U"]) / np.abs(ref["U"])))
        rel_a = float(np.max(np.linalg.norm(a - ref["a"], axis=1) / np.linalg.norm(ref["a"], axis=1)))
        rel_h = float(np.max(np.linalg.norm(H - ref["H"], axis=(1, 2)) / np.linalg.norm(ref["H"], axis=(1, 2))))
        print(
            f"{'polyhedral-gravity ' + ref['version']:24s}"
            f"{1e6 * ref['t1'] / n:11.1f} us{1e6 * ref['tn'] / n:11.1f} us"
            f"   ({ref['parallelization']})"
        )
        print(f"{'ratio (theirs / ours)':24s}{ref['t1'] / t1:13.1f}x{ref['tn'] / tn:13.1f}x")
        print(f"max relative difference: U {rel_u:.2e}, a {rel_a:.2e}, Hess U {rel_h:.2e}")
        print("(largest at the far points, where polyhedral-gravity's cancellation error dominates: see")
        print(" cpp/include/tubempc/gravity/polyhedron_gravity.hpp for both against an 80-bit evaluation)")
        result.update(
            {
                "polyhedral_gravity_version": ref["version"],
                "polyhedral_gravity_us_per_point_1_thread": 1e6 * ref["t1"] / n,
                "polyhedral_gravity_us_per_point_all_threads": 1e6 * ref["tn"] / n,
                "ratio_1_thread": ref["t1"] / t1,
                "ratio_all_threads": ref["tn"] / tn,
                "max_rel_diff_potential": rel_u,
                "max_rel_diff_acceleration": rel_a,
                "max_rel_diff_gradient": rel_h,
            }
        )
    bsk = None if args.no_reference else _basilisk(shape.vertices, shape.faces, model.gm, pts, args.repeat)
    if bsk is not None:
        # Relative to the largest acceleration of the point set: the interior points include the centre
        # of mass, where a = 0 and a pointwise relative difference means nothing.
        rel_a = float(np.max(np.linalg.norm(a - bsk["a"], axis=1)) / np.max(np.linalg.norm(a, axis=1)))
        rel_u = float(np.max(np.abs(U - bsk["U"]) / np.abs(U)))
        name = "Basilisk " + bsk["version"]
        print(f"{name:24s}{1e6 * bsk['t1'] / n:11.1f} us   (PolyhedralGravityModel, one point per call)")
        print(f"{'ratio (theirs / ours)':24s}{bsk['t1'] / t1:13.1f}x")
        print(f"max difference: U {rel_u:.2e} (relative), a {rel_a:.2e} (relative to the largest |a|)")
        result.update(
            {
                "basilisk_version": bsk["version"],
                "basilisk_us_per_point_1_thread": 1e6 * bsk["t1"] / n,
                "basilisk_ratio_1_thread": bsk["t1"] / t1,
                "basilisk_max_rel_diff_potential": rel_u,
                "basilisk_max_rel_diff_acceleration": rel_a,
            }
        )
    elif not args.no_reference:
        print("Basilisk not installed (pip install 'tubempc[basilisk]'): no Basilisk row")
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    return 0
