"""``tubempc campaign``: what a campaign folder's store needs besides flying it (``convert``: a folder of
the layout before the store, ``runs/run_<i>.json`` and ``.npz``, into the store)."""

from __future__ import annotations

import argparse

DESCRIPTION = "campaign folders: convert one written before the columnar store"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", required=True)
    convert = sub.add_parser("convert", help="runs/run_<i>.json and .npz into the Parquet store (the old files removed)")
    convert.add_argument("dir", help="the campaign folder (holding runs/)")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..results.campaign_store import STORE_DIR, convert_legacy_campaign

    n = convert_legacy_campaign(Path(args.dir))
    print(f"{n} runs of {args.dir} converted into {Path(args.dir) / STORE_DIR}; runs/ removed")
    return 0
