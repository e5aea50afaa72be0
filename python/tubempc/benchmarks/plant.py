"""The Basilisk plant against the project's (issue #40): agreement and cost per control step.

Flies a scenario's reference inputs open loop through both truths from x0 (ideal actuators without
mismatch, no additive disturbance; :func:`tubempc.sim.basilisk.cross_check`) and reports the largest
differences of position, velocity, attitude and rate over the mission, the position difference as a
fraction of TBMPC's smallest position semi-axis (the issue's goal: below 1 %), and each plant's median
wall time per control step with their ratio (the goal: Basilisk within 3x with ideal actuation). The
ratio compares the two inside one run, so the machine's drift cancels.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from ..results.machine import machine_info
from . import write_json

DESCRIPTION = "the Basilisk plant against the project's: open-loop agreement and time per control step"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--config", help="scenario TOML (fields left out are the paper scenario's)")
    group.add_argument("--scenario", help="a packaged scenario (default: bennu-paper)")
    parser.add_argument("--steps", type=int, help="only the first this many control steps (default: all)")
    parser.add_argument("--repeats", type=int, default=3, help="flights of the whole sequence (timing: the fastest)")
    parser.add_argument("--cache-dir", default="results/cache", help="reference-trajectory cache")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..config import load_config
    from ..design.library import initial_tube
    from ..scenario.build import build_scenario
    from ..sim.basilisk import basilisk_version, cross_check

    cfg = load_config(args.config, scenario=args.scenario).with_overrides({"simulation.plant": "basilisk"})
    scn = build_scenario(cfg, cache_dir=Path(args.cache_dir))
    _, Pe = initial_tube(scn)
    semi_axis = math.sqrt(float(np.linalg.eigvalsh(Pe[0:3, 0:3]).min()))
    checks = [cross_check(scn, steps=args.steps) for _ in range(max(1, args.repeats))]
    c = checks[0]
    seconds = {name: min(ch.seconds_per_step[name] for ch in checks) for name in c.seconds_per_step}
    max_difference = {
        "position_m": float(c.position_m.max()),
        "velocity_m_s": float(c.velocity_m_s.max()),
        "attitude_rad": float(c.attitude_rad.max()),
        "rate_rad_s": float(c.rate_rad_s.max()),
    }
    ms = {name: 1e3 * s for name, s in seconds.items()}
    ratio = seconds["basilisk"] / seconds["project"]
    machine = machine_info()
    data = {
        "scenario": cfg.source,
        "steps": len(c.position_m),
        "bsk": basilisk_version(),
        "basilisk_step_s": scn.config.mpc.dt / scn.config.simulation.substeps,
        "max_difference": max_difference,
        "final_position_difference_m": float(c.position_m[-1]),
        "tube_semi_axis_m": semi_axis,
        "position_over_semi_axis": float(c.position_m.max()) / semi_axis,
        "ms_per_step": ms,
        "basilisk_over_project": ratio,
        "repeats": len(checks),
        "machine": machine,
    }
    d = max_difference
    print(
        f"{len(c.position_m)} steps open loop, Basilisk {basilisk_version()} against the project's plant: position <= "
        f"{d['position_m']:.3g} m ({100 * d['position_m'] / semi_axis:.2g} % of TBMPC's position semi-axis "
        f"{semi_axis:.3g} m), velocity <= {d['velocity_m_s']:.3g} m/s, attitude <= {d['attitude_rad']:.3g} rad, "
        f"rate <= {d['rate_rad_s']:.3g} rad/s"
    )
    print(
        f"time per control step: project {ms['project']:.3g} ms, Basilisk {ms['basilisk']:.3g} ms "
        f"({ratio:.2f}x); machine {machine['cpu']}, {machine['cores']} cores"
    )
    write_json(args.json, data)
    return 0
