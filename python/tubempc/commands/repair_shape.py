"""``tubempc repair-shape``: a shape's faces oriented consistently outward, written as an OBJ in metres."""

from __future__ import annotations

import argparse

from . import EXIT_OK

DESCRIPTION = "orient a shape's faces consistently outward and write it as an OBJ in metres"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="shape file (OBJ, PDS v/f table, ICQ, PLY, STL)")
    parser.add_argument("--unit", choices=["km", "m"], required=True, help="unit of the file's coordinates")
    parser.add_argument("--out", required=True, help="OBJ file to write (metres)")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..scenario.shapes import load_shape, save_shape

    before = load_shape(Path(args.file), unit=args.unit, repair=True)
    out = Path(args.out)
    save_shape(out, before, unit="m")
    print(
        f"wrote {out}: {len(before.faces)} faces, {before.n_flipped_faces} flipped to a consistent outward orientation, "
        f'volume {before.volume:.4g} m^3 (OBJ in metres: asteroid.shape_unit = "m")'
    )
    return EXIT_OK
