"""Command-line interface: ``tubempc --version``, ``tubempc info``, ``tubempc bench NAME``."""

from __future__ import annotations

import argparse
import importlib.metadata
import platform
import sys
from collections.abc import Sequence

import numpy as np

from . import __version__, benchmarks, build_info, so3

_PYTHON_PACKAGES = ("numpy", "scipy", "cvxpy", "clarabel", "osqp", "piqp")


def _so3_selfcheck(n: int = 1000, seed: int = 0) -> float:
    """Largest |log(exp(phi)) - phi| over random rotation vectors with |phi| < pi (rad)."""
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        axis = rng.normal(size=3)
        phi = axis / np.linalg.norm(axis) * rng.uniform(0.0, np.pi * 0.999)
        worst = max(worst, float(np.max(np.abs(so3.log_map(so3.exp_map(phi)) - phi))))
    return worst


def _cmd_info(_: argparse.Namespace) -> int:
    info = build_info()
    print(f"tubempc {__version__}")
    print("C++ core:")
    for key in ("compiler", "build_type", "cxx_flags", "eigen_version", "eigen_simd",
                "piqp_version", "osqp_backend", "hardware_threads"):
        print(f"  {key:17s} {info[key]}")
    print(f"Python {platform.python_version()} on {platform.machine()}")
    for name in _PYTHON_PACKAGES:
        try:
            version = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            version = "not installed"
        print(f"  {name:17s} {version}")
    print(f"so3 self-check: max |log(exp(phi)) - phi| = {_so3_selfcheck():.2e} rad over 1000 rotations")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tubempc", description=__doc__)
    parser.add_argument("--version", action="version", version=f"tubempc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p_info = sub.add_parser("info", help="report the core's build and the Python dependencies")
    p_info.set_defaults(func=_cmd_info)
    p_bench = sub.add_parser("bench", help="run a benchmark (see 'tubempc bench -h')")
    bench_sub = p_bench.add_subparsers(dest="benchmark", required=True)
    for name in benchmarks.available():
        module = benchmarks.load(name)
        p = bench_sub.add_parser(name, help=module.DESCRIPTION, description=module.DESCRIPTION)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
