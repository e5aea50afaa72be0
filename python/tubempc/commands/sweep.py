"""``tubempc sweep``: the forgetting-factor sweep (paper Table 3, Figures 15-16)."""

from __future__ import annotations

import argparse

from . import config_from_args, guarantee_status, parse_floats, parse_seed, scenario_arguments

DESCRIPTION = "forgetting-factor sweep (paper Table 3, Figures 15-16)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--lambda-p", type=parse_floats, default=[0.96, 0.97, 0.98])
    parser.add_argument("--lambda-r", type=parse_floats, help="one per --lambda-p value (default: the config's)")
    parser.add_argument("--out", default="results/sweep")
    scenario_arguments(parser)
    parser.add_argument("--seed", type=parse_seed, default=0, help="disturbance seed >= 0")
    parser.add_argument("--quiet", action="store_true")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..analysis.claims import holding_floor
    from ..analysis.runner import guarantee_lost
    from ..analysis.studies import sweep

    s = sweep(config_from_args(args), args.lambda_p, args.lambda_r, Path(args.out), seed=args.seed, progress=not args.quiet)
    print(f"{'':40s} {'J_p':>8s} {'J_r':>8s} {'|dr(T)| m':>10s} {'RMS r m':>9s} {'outside':>8s} {'tube feasible':>14s}")
    for name, row in s.rows.items():
        feasible = (
            "every step"
            if row.tube_feasible_every_step
            else f"no: {row.tube_design_failures} designs failed, {row.tube_uncertified_steps} steps uncertified"
        )
        print(
            f"{name:40s} {row.J_p:8.4g} {row.J_r:8.4g} {row.terminal_error.position:10.3g} "
            f"{row.rms_error.position:9.3g} {row.steps_outside_tube:8d} {feasible:>14s}"
        )
    smallest = s.smallest_feasible_lambda_p
    print(f"smallest lambda_p with a feasible tube at every step: {smallest if smallest is not None else 'none'}")
    floor = holding_floor(s.ffa_rows)
    print(f"the tube holds (feasible, never left) for every lambda_p swept >= {floor if floor is not None else 'none'}")
    print(f"{args.out}/sweep.json and figures")
    return guarantee_status({name: reasons for name, row in s.rows.items() if (reasons := guarantee_lost(row))})
