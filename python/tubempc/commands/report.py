"""``tubempc report``: the HTML and Markdown report of a results folder."""

from __future__ import annotations

import argparse

DESCRIPTION = "HTML and Markdown report of a results folder"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dir", help="folder with summary.json (run), sweep/ and montecarlo/ sub-folders if present")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..analysis.report import write_report

    html, md = write_report(Path(args.dir))
    print(f"{html}\n{md}")
    return 0
