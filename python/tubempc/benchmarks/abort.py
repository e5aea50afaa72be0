"""The safe abort's cost in the control step (issue #43's goal: controller step p99 growth <= 0.2 ms).

Flies a scenario with ``[abort]`` (default ``bennu-tag-faults``, fault-free) three times with the same seed: without
the abort, with it armed (the supervision runs every step, no abort entered) and with an abort commanded at
``--command-time``. Reports the controller step's median and p99 of each flight (the C++ call's own clock,
``ControlStep.timings.total``), the p99 growth of the armed flight over the flight without the abort, the
commanded flight's p99 over its descent steps and over its abort steps (a ratio inside one run: timings on a
shared machine drift between runs), and the supervision's call (``SafeAbort.monitor``) timed over many calls
through the binding (an upper bound of its cost in C++). The abort's set-up (the library) is timed too. The JSON
carries the machine and the configuration.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from .. import _core
from ..results.machine import machine_info
from . import write_json
from .controller import add_flight_arguments

DESCRIPTION = "the safe abort's cost: controller step p99 with and without the abort, the supervision's call"

_MONITOR_CALLS = 100_000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--config", help="scenario TOML with a landing site")
    group.add_argument("--scenario", default="bennu-tag-faults", help="a packaged scenario (default: bennu-tag-faults)")
    parser.add_argument("--command-time", type=float, default=100.0, help="the commanded abort's time (s)")
    add_flight_arguments(parser)


def _stats(seconds: np.ndarray) -> dict[str, float]:
    ms = 1e3 * np.asarray(seconds, dtype=float)
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)), "steps": int(ms.size)}


def _monitor_seconds(abort: Any) -> float:
    """One SafeAbort.monitor call's time through the binding (s), over many calls of an armed, untriggered step."""
    triggers = _core.control.AbortTriggers()
    t0 = time.perf_counter()
    for _ in range(_MONITOR_CALLS):
        abort.monitor(0, triggers)
    return (time.perf_counter() - t0) / _MONITOR_CALLS


def run(args: argparse.Namespace) -> int:
    from ..config import load_config
    from ..design.abort import abort_library, new_abort
    from ..scenario.build import build_scenario
    from ..sim.closed_loop import simulate

    base = load_config(args.config, scenario=None if args.config else args.scenario)
    cfg = base.with_overrides({"faults.random": False, "faults.kind": "none", "abort.enabled": True})
    method = "ffa" if args.method == "both" else args.method
    scn = build_scenario(cfg)
    t0 = time.perf_counter()
    library = abort_library(scn)
    setup_s = time.perf_counter() - t0
    if not 0.0 < args.command_time <= library.commit_step * cfg.mpc.dt:
        raise SystemExit(
            f"bench abort: --command-time must lie in (0, {library.commit_step * cfg.mpc.dt:g}] s (the commit time)"
        )
    variants = {
        "without_abort": scn.config.with_overrides({"abort.enabled": False}),
        "armed": scn.config,
        "commanded": scn.config.with_overrides({"abort.command_time": args.command_time}),
    }
    out: dict[str, Any] = {
        "machine": machine_info(),
        "config": cfg.to_dict(),
        "method": method,
        "seed": args.seed,
        "library_setup_s": setup_s,
        "commit_step": library.commit_step,
        "flights": {},
    }
    entry = None
    for name, c in variants.items():
        flown = build_scenario(c)
        flown.tube_designs.update(scn.tube_designs)  # the same designs and abort library
        rec = simulate(flown, method, args.seed, design_worker=args.design_worker)
        out["flights"][name] = _stats(rec.time_step)
        if name == "commanded":
            entry = rec.applied["abort"]["entered_at_step"]
            out["flights"]["commanded_descent_steps"] = _stats(rec.time_step[:entry])
            out["flights"]["commanded_abort_steps"] = _stats(rec.time_step[entry:])
    f = out["flights"]
    out["armed_p99_growth_ms"] = f["armed"]["p99_ms"] - f["without_abort"]["p99_ms"]
    out["abort_over_descent_p99"] = f["commanded_abort_steps"]["p99_ms"] / f["commanded_descent_steps"]["p99_ms"]
    out["monitor_us_binding_included"] = 1e6 * _monitor_seconds(new_abort(scn, library))
    print(f"{cfg.source} ({method}, seed {args.seed}); abort library {setup_s:.1f} s, commit step {library.commit_step}")
    for name, s in f.items():
        print(f"  {name:26s} controller step median {s['median_ms']:.3f} ms, p99 {s['p99_ms']:.3f} ms ({s['steps']} steps)")
    print(
        f"  p99 growth armed - without: {out['armed_p99_growth_ms']:+.3f} ms; abort steps' p99 / descent steps' p99 in "
        f"the commanded run (entered at step {entry}): {out['abort_over_descent_p99']:.2f}; SafeAbort.monitor "
        f"{out['monitor_us_binding_included']:.2f} us per call through the binding"
    )
    write_json(args.json, out)
    return 0
