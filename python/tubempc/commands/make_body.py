"""``tubempc make-body``: a generated small-body shape (OBJ in metres) for an own mission."""

from __future__ import annotations

import argparse

from . import parse_floats

DESCRIPTION = "generate a small-body shape (OBJ in metres) for your own mission"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("kind", choices=["ellipsoid", "contact-binary"])
    parser.add_argument("--axes", type=parse_floats, help="ellipsoid: semi-axes a,b,c (m)")
    parser.add_argument("--body-axes", type=parse_floats, help="contact binary: the larger lobe's semi-axes (m)")
    parser.add_argument("--head-axes", type=parse_floats, help="contact binary: the smaller lobe's semi-axes (m)")
    parser.add_argument("--separation", type=float, help="contact binary: distance of the lobes' centres (m)")
    parser.add_argument("--subdivisions", type=int, default=12, help="geodesic resolution n (20 n^2 faces)")
    parser.add_argument("--roughness", type=float, default=0.0, help="relative surface roughness in [0, 0.5)")
    parser.add_argument("--seed", type=int, default=0, help="roughness seed")
    parser.add_argument("--out", required=True, help="OBJ file to write")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..scenario.bodies import contact_binary_shape, ellipsoid_shape
    from ..scenario.shapes import save_shape

    if args.kind == "ellipsoid":
        if args.axes is None:
            raise ValueError("make-body ellipsoid: --axes a,b,c (semi-axes, m) is required")
        shape = ellipsoid_shape(args.axes, args.subdivisions, args.roughness, args.seed)
    else:
        if args.body_axes is None or args.head_axes is None or args.separation is None:
            raise ValueError("make-body contact-binary: --body-axes, --head-axes and --separation are required")
        shape = contact_binary_shape(
            args.body_axes, args.head_axes, args.separation, args.subdivisions, args.roughness, args.seed
        )
    out = Path(args.out)
    save_shape(out, shape, unit="m")
    extent = shape.vertices.max(axis=0) - shape.vertices.min(axis=0)
    print(
        f"wrote {out}: {len(shape.faces)} faces, extent {extent[0]:.1f} x {extent[1]:.1f} x {extent[2]:.1f} m, "
        f'volume {shape.volume:.4g} m^3 (OBJ in metres: asteroid.shape_unit = "m")'
    )
    return 0
