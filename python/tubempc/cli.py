"""Command-line interface: ``tubempc --version``, ``info``, ``run``, ``bench NAME``."""

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


def _cmd_run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .config import load_config
    from .runner import run_methods

    cfg = load_config(args.config)
    methods = ["tbmpc", "ffa"] if args.method == "both" else [args.method]
    seed = cfg.disturbance.seed if args.seed is None else args.seed
    out = Path(args.out)
    summary = run_methods(cfg, methods, seed, out, shape=args.shape, progress=not args.quiet,
                          cache_dir=Path(args.cache_dir) if args.cache_dir else out / "cache",
                          make_figures=not args.no_figures)
    for m, s in summary["methods"].items():
        st = s["step_time"]
        print(f"{m:6s} J_p={s['J_p']:.4g} J_r={s['J_r']:.4g} terminal |dr|={s['terminal_error']['position']:.3g} m "
              f"max excursion p/r={s['max_tube_excursion']['translation']:.3g}/{s['max_tube_excursion']['rotation']:.3g} "
              f"cone violations gs/los={s['constraint_violations']['glide_slope_steps']}/"
              f"{s['constraint_violations']['los_steps']} step median {st['step']['median_ms']:.2f} ms "
              f"(tube {st['tube']['median_ms']:.2f}, mpc {st['mpc']['median_ms']:.2f}) run {s['run_time_s']:.1f} s")
    if "comparison" in summary:
        print(f"TBMPC-FFA J_p is {summary['comparison']['J_p_reduction_percent']:.1f} % below TBMPC's")
    print(f"results in {out}/ (summary.json, <method>.h5, figures)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tubempc", description=__doc__)
    parser.add_argument("--version", action="version", version=f"tubempc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    p_info = sub.add_parser("info", help="report the core's build and the Python dependencies")
    p_info.set_defaults(func=_cmd_info)
    p_run = sub.add_parser("run", help="closed-loop TBMPC and/or TBMPC-FFA on the paper's Bennu scenario")
    p_run.add_argument("--config", help="scenario TOML (default: the packaged paper scenario)")
    p_run.add_argument("--method", choices=["tbmpc", "ffa", "both"], default="both")
    p_run.add_argument("--shape", help="shape file (OBJ, PDS v/f table, ICQ, PLY, STL) instead of the config's")
    p_run.add_argument("--seed", type=int, help="disturbance seed (default: the config's)")
    p_run.add_argument("--out", default="results/run", help="output folder")
    p_run.add_argument("--cache-dir", help="reference-trajectory cache (default: OUT/cache)")
    p_run.add_argument("--no-figures", action="store_true")
    p_run.add_argument("--quiet", action="store_true", help="no progress bar")
    p_run.set_defaults(func=_cmd_run)
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
