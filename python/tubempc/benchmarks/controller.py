"""The whole controller step of the closed loop: identification + tube update + MPC step, per step.

Flies the mission of a scenario (default: the paper's) with each method and reports the distribution
(median, p99, max) of the controller's own time per step (the truth propagation excluded: it is the
simulated plant, not the controller), its parts, and the tube update as a ratio to the MPC step in
the same run. The JSON carries the machine and the configuration it ran with.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ..machine import machine_info
from . import write_json

DESCRIPTION = "controller step (identify + tube update + MPC) per step of the closed loop, both methods"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--config", help="scenario TOML (fields left out are the paper scenario's)")
    group.add_argument("--scenario", help="a packaged scenario (default: bennu-paper)")
    parser.add_argument("--method", choices=["tbmpc", "ffa", "both"], default="both")
    parser.add_argument("--seed", type=int, default=0, help="disturbance seed")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")


def _stats(seconds: np.ndarray) -> dict[str, float]:
    ms = 1e3 * np.asarray(seconds, dtype=float)
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}


def run(args: argparse.Namespace) -> int:
    from ..closed_loop import simulate
    from ..config import load_config
    from ..scenario import build_scenario

    cfg = load_config(args.config, scenario=args.scenario)
    scn = build_scenario(cfg)
    methods = ["tbmpc", "ffa"] if args.method == "both" else [args.method]
    out: dict[str, Any] = {"machine": machine_info(), "config": cfg.to_dict(), "seed": args.seed, "methods": {}}
    print(f"controller step per step (ms), {scn.n_steps} steps, seed {args.seed}:")
    for m in methods:
        rec = simulate(scn, m, args.seed)
        controller = rec.time_identify + rec.time_tube + rec.time_mpc
        row: dict[str, Any] = {
            "controller": _stats(controller),
            "identify": _stats(rec.time_identify),
            "tube": _stats(rec.time_tube),
            "mpc": _stats(rec.time_mpc),
            "tube_over_mpc_median": float(np.median(rec.time_tube) / np.median(rec.time_mpc)),
            "steps_outside_tube": int(np.sum(np.any(rec.excursion > 1.0 + 1e-9, axis=1))),
            "tube_statuses": sorted(set(rec.tube_statuses)),
        }
        out["methods"][m] = row
        c, t = row["controller"], row["tube"]
        print(
            f"  {m:6s} controller median {c['median_ms']:.3g}, p99 {c['p99_ms']:.3g}, max {c['max_ms']:.3g}; "
            f"tube median {t['median_ms']:.3g} (x{row['tube_over_mpc_median']:.2f} the MPC step's), p99 "
            f"{t['p99_ms']:.3g}, max {t['max_ms']:.3g}; steps outside the tube {row['steps_outside_tube']}"
        )
    write_json(args.json, out)
    return 0
