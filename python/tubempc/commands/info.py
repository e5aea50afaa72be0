"""``tubempc info``: the core's build, the Python dependencies and an so3 self-check."""

from __future__ import annotations

import argparse
import importlib.metadata
import platform

from .. import __version__

DESCRIPTION = "report the core's build and the Python dependencies"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    del parser  # no options


_PYTHON_PACKAGES = ("numpy", "scipy", "cvxpy", "clarabel", "piqp", "plotly")


def _so3_selfcheck(n: int = 1000, seed: int = 0) -> float:
    """Largest |log(exp(phi)) - phi| over random rotation vectors with |phi| < pi (rad)."""
    import numpy as np

    from .._core import so3

    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        axis = rng.normal(size=3)
        phi = axis / np.linalg.norm(axis) * rng.uniform(0.0, np.pi * 0.999)
        worst = max(worst, float(np.max(np.abs(so3.log_map(so3.exp_map(phi)) - phi))))
    return worst


def run(_: argparse.Namespace) -> int:
    from .._core import build_info

    info = build_info()
    print(f"tubempc {__version__}")
    print("C++ core:")
    for key in (
        "compiler",
        "build_type",
        "cxx_flags",
        "eigen_version",
        "eigen_simd",
        "piqp_version",
        "hardware_threads",
    ):
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
