"""``tubempc export-scenario``: the closed loop's scenario file for C++ programs."""

from __future__ import annotations

import argparse

from . import config_from_args, parse_seed, scenario_arguments

DESCRIPTION = "write the closed loop's scenario file for C++ programs (examples/cpp/closed_loop)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    scenario_arguments(parser, plant=False)
    parser.add_argument("--out", required=True, help="output folder (scenario.txt, shape.obj, config.toml)")
    parser.add_argument("--cache-dir", help="reference-trajectory cache (default: none)")
    parser.add_argument(
        "--seed",
        type=parse_seed,
        help="the run whose navigation (sensor noise) and actuators (thruster errors, random faults) the file "
        "carries, as 'tubempc run --seed' flies them (default: the config's disturbance.seed)",
    )


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..results.export import export_scenario, read_scenario

    path = export_scenario(
        config_from_args(args),
        Path(args.out),
        cache_dir=Path(args.cache_dir) if args.cache_dir else None,
        seed=args.seed,
    )
    scn = read_scenario(str(path))  # the C++ reader validates what was written
    print(
        f"wrote {path} (T = {scn.mission_steps} steps, N = {scn.settings.horizon}) with "
        f"{', '.join(sorted({scn.model.shape, scn.truth.shape}))} and config.toml"
        + (f"; navigation ({len(scn.navigation.landmarks)} landmarks)" if scn.navigation.enabled else "")
        + (f"; actuators ({len(scn.actuators.thrusters)} thrusters)" if scn.actuators.enabled else "")
    )
    return 0
