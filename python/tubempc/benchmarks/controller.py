"""The whole controller step of the closed loop (the C++ ``_core.control.Controller``): identification +
tube update + MPC step until the command, then the one-step prediction for the next identification.

Flies the mission of a scenario (default: the paper's) with each method and reports the distribution
(median, p99, max) of the controller's own time per step, as the controller measures it (the truth
propagation excluded: it is the simulated plant, not the controller), its parts, and identification +
tube update as a ratio to the MPC step in the same run, and the steps whose tube is not certified. A
scenario flown on navigation also reports the navigation call (sensors + filter, one per step), its onboard
estimator's part (the filter: propagation, updates, the controller's state; the sensors' simulation is the
truth side, which flight hardware replaces) and the controller plus the estimator against the full-state
controller's p99 (the same scenario with navigation off, flown in the same command), issue #30's goal.
``--repeats R`` flies each mission R times (the same seed, so the same steps; the flights on navigation and on the
true state alternate), pools the step times of the R flights into each distribution (a p99 over 300 steps is their
third largest) and reports each pair's ratio too.
The LMI designs run at set-up or in the background, never inside the C++ step. The JSON carries the
machine and the configuration it ran with.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
from typing import Any

import numpy as np

from .. import _core
from ..results.machine import machine_info
from . import write_json

DESCRIPTION = "controller step (identify + tube update + MPC) per step of the closed loop, both methods"


def add_flight_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of a benchmark that flies the closed loop: --method, --seed, --design-worker, --json."""
    parser.add_argument("--method", choices=[*_core.control.Method.names(), "both"], default="both")
    parser.add_argument("--seed", type=int, default=0, help="disturbance seed")
    parser.add_argument(
        "--design-worker",
        choices=["process", "thread", "inline", "none"],  # tube.design_worker's values
        help="where due LMI designs run (default: the configuration's tube.design_worker)",
    )
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--config", help="scenario TOML (fields left out are the paper scenario's)")
    group.add_argument("--scenario", help="a packaged scenario (default: bennu-paper)")
    parser.add_argument("--repeats", type=int, default=1, help="flights per method, their step times pooled")
    add_flight_arguments(parser)


def _stats(seconds: np.ndarray) -> dict[str, float]:
    ms = 1e3 * np.asarray(seconds, dtype=float)
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}


def run(args: argparse.Namespace) -> int:
    from ..analysis.metrics import tube_status_certified
    from ..config import load_config
    from ..scenario.build import build_scenario
    from ..sim.closed_loop import simulate

    if args.repeats < 1:
        raise SystemExit("bench controller: --repeats must be >= 1")
    cfg = load_config(args.config, scenario=args.scenario)
    scn = build_scenario(cfg)
    methods = _core.control.Method.names() if args.method == "both" else [args.method]
    out: dict[str, Any] = {
        "machine": machine_info(),
        "config": cfg.to_dict(),
        "seed": args.seed,
        "repeats": args.repeats,
        "design_worker": args.design_worker or cfg.tube.design_worker,
        "methods": {},
    }
    print(f"controller step per step (ms), {scn.n_steps} steps x {args.repeats} flights, seed {args.seed}:")
    full_state = None
    if cfg.navigation.enabled:  # the baseline: the same scenario on the true state
        full_state = build_scenario(dataclasses.replace(cfg, navigation=dataclasses.replace(cfg.navigation, enabled=False)))
    for m in methods:
        recs, bases = [], []
        for _ in range(args.repeats):  # alternating, so that the machine's drift meets both alike
            recs.append(simulate(scn, m, args.seed, design_worker=args.design_worker))
            if full_state is not None and recs[-1].navigation is not None:
                bases.append(simulate(full_state, m, args.seed, design_worker=args.design_worker))
        rec = recs[0]  # the flights differ in their times only

        def pooled(get: Any, runs: list[Any] = recs) -> np.ndarray:
            return np.concatenate([np.asarray(get(r), dtype=float) for r in runs])

        command = pooled(lambda r: r.time_identify + r.time_tube + r.time_mpc)
        row: dict[str, Any] = {
            "command": _stats(command),
            "controller": _stats(pooled(lambda r: r.time_step)),
            "identify": _stats(pooled(lambda r: r.time_identify)),
            "tube": _stats(pooled(lambda r: r.time_tube)),
            "predict": _stats(pooled(lambda r: r.time_predict)),
            "mpc": _stats(pooled(lambda r: r.time_mpc)),
            "identify_tube_over_mpc_median": float(
                np.median(pooled(lambda r: r.time_identify + r.time_tube)) / np.median(pooled(lambda r: r.time_mpc))
            ),
            "steps_outside_tube": int(np.sum(np.any(rec.excursion > 1.0 + 1e-9, axis=1))),
            "uncertified_steps": int(sum(not tube_status_certified(s) for s in rec.tube_statuses)),
            "tube_statuses": dict(collections.Counter(rec.tube_statuses)),
        }
        if bases:
            row["navigation"] = _stats(pooled(lambda r: r.navigation.time_step))
            row["estimator"] = _stats(pooled(lambda r: r.navigation.time_filter))
            row["controller_and_navigation"] = _stats(pooled(lambda r: r.time_step + r.navigation.time_step))
            row["controller_and_estimator"] = _stats(pooled(lambda r: r.time_step + r.navigation.time_filter))
            row["full_state_controller"] = _stats(pooled(lambda r: r.time_step, bases))
            full_p99 = row["full_state_controller"]["p99_ms"]
            row["navigation_p99_ratio"] = row["controller_and_navigation"]["p99_ms"] / full_p99
            row["estimator_p99_ratio"] = row["controller_and_estimator"]["p99_ms"] / full_p99
            row["estimator_p99_ratio_per_flight"] = [
                float(np.percentile(r.time_step + r.navigation.time_filter, 99) / np.percentile(b.time_step, 99))
                for r, b in zip(recs, bases, strict=True)
            ]
        out["methods"][m] = row
        c, cmd, t = row["controller"], row["command"], row["tube"]
        print(
            f"  {m:6s} controller median {c['median_ms']:.3g}, p99 {c['p99_ms']:.3g}, max {c['max_ms']:.3g} "
            f"(to the command: median {cmd['median_ms']:.3g}, p99 {cmd['p99_ms']:.3g}, max {cmd['max_ms']:.3g}); "
            f"identify + tube x{row['identify_tube_over_mpc_median']:.3f} the MPC step's median (tube median "
            f"{t['median_ms']:.3g}, max {t['max_ms']:.3g}; predict median {row['predict']['median_ms']:.3g}); "
            f"steps outside the tube {row['steps_outside_tube']}, uncertified {row['uncertified_steps']}"
        )
        if "navigation" in row:
            n, e, b = row["navigation"], row["estimator"], row["full_state_controller"]
            ce, cn = row["controller_and_estimator"], row["controller_and_navigation"]
            print(
                f"         navigation call median {n['median_ms']:.3g}, p99 {n['p99_ms']:.3g} (estimator median "
                f"{e['median_ms']:.3g}, p99 {e['p99_ms']:.3g}); controller + estimator p99 {ce['p99_ms']:.3g} = "
                f"{row['estimator_p99_ratio']:.3g}x the full-state controller's p99 {b['p99_ms']:.3g} (with the "
                f"sensors' simulation: {cn['p99_ms']:.3g} = {row['navigation_p99_ratio']:.3g}x)"
            )
            if args.repeats > 1:
                each = ", ".join(f"{x:.3g}" for x in row["estimator_p99_ratio_per_flight"])
                print(f"         per flight: controller + estimator p99 / the full-state controller's: {each}")
    write_json(args.json, out)
    return 0
