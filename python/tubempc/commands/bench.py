"""``tubempc bench NAME``: one of the benchmarks (:mod:`tubempc.benchmarks`)."""

from __future__ import annotations

import argparse

from .. import benchmarks

DESCRIPTION = "run a benchmark ('tubempc bench NAME -h' for its options)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("benchmark", choices=benchmarks.available())
    parser.add_argument("options", nargs=argparse.REMAINDER, help="the benchmark's options")


def run(args: argparse.Namespace) -> int:
    """Imports the benchmark only when it runs (so that the command line starts at once)."""
    module = benchmarks.load(args.benchmark)
    parser = argparse.ArgumentParser(prog=f"tubempc bench {args.benchmark}", description=module.DESCRIPTION)
    module.add_arguments(parser)
    return int(module.run(parser.parse_args(args.options)))
