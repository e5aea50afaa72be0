"""Actuators in the closed loop against ideal actuators (docs/model.md "Actuators in the closed loop").

Flies a scenario whose ``spacecraft.actuators`` is a thruster-and-wheel model, and the same scenario with
ideal actuators and the same input bounds (``spacecraft.u_max`` and ``T_max`` set to the actuators' bounds,
so that the reference trajectory is the same), each method with the same seed. Reports per method: steps
outside the tube, terminal position error, net delta-v (sum |u_p delivered| dt), the thrusters' delta-v
(sum of impulses / m) and propellant, pulses, the wheels' largest momentum, the share of the input bound the
tube leaves the nominal input and the plan's largest offset from the reference, and the controller step's p99
with and without the actuation call in the same run (and the ideal run's). With ``--seeds N`` each method also
flies the seeds ``seed + 1 .. seed + N - 1`` both ways and reports the terminal-error ratio over all N seeds
(one seed's ratio compares two errors of the environment's noise size). The JSON carries the machine and both
configurations.
"""

from __future__ import annotations

import argparse
import collections
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis.metrics import net_delta_v, nominal_input_fraction
from ..results.machine import machine_info
from . import write_json
from .controller import add_flight_arguments

if TYPE_CHECKING:
    pass

DESCRIPTION = "closed loop with thrusters and wheels against ideal actuators with the same bounds, both methods"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--config", help='scenario TOML with spacecraft.actuators (not "ideal")')
    group.add_argument("--scenario", help="a packaged scenario")
    parser.add_argument("--actuators", help="override spacecraft.actuators (a preset name or a TOML path)")
    parser.add_argument("--seeds", type=int, default=1, help="seeds flown per method for the terminal-error ratio")
    add_flight_arguments(parser)


def _p99_ms(seconds: np.ndarray) -> float:
    return float(np.percentile(1e3 * np.asarray(seconds, dtype=float), 99))


def _figures(rec: Any, xf: np.ndarray, dt: float, u_max: float) -> dict[str, Any]:
    room = nominal_input_fraction(rec, u_max)
    return {
        "steps_outside_tube": int(np.sum(np.any(rec.excursion > 1.0 + 1e-9, axis=1))),
        "max_tube_excursion": rec.excursion.max(axis=0).tolist(),
        "terminal_position_error_m": float(np.linalg.norm(rec.x[-1, :3] - xf[:3])),
        "terminal_velocity_error_m_s": float(np.linalg.norm(rec.x[-1, 3:6] - xf[3:6])),
        "net_delta_v_m_s": net_delta_v(rec, dt),
        "thruster_delta_v_m_s": float(rec.delta_v.sum()),
        "propellant_kg": float(rec.propellant.sum()),
        "pulses": int(rec.pulses.sum()),
        "max_wheel_momentum_N_m_s": float(np.linalg.norm(rec.wheel_momentum, axis=1).max()),
        "nominal_input_fraction_min": float(room.min()),
        "nominal_input_fraction_median": float(np.median(room)),
        "max_plan_offset_m": float(np.linalg.norm(rec.z[:, :3] - rec.zbar[:-1, :3], axis=1).max()),
        "actuation_statuses": dict(collections.Counter(rec.actuation_statuses)),
        "mpc_statuses": dict(collections.Counter(rec.statuses)),
        "controller_p99_ms": _p99_ms(rec.time_step),
        "controller_and_actuation_p99_ms": _p99_ms(rec.time_step + rec.time_actuation),
        "actuation_p99_ms": _p99_ms(rec.time_actuation),
    }


def seed_statistics(actuated: list[float], ideal: list[float]) -> dict[str, Any]:
    """The terminal position errors (m) of the same seeds with actuators and with ideal actuators: each seed's
    ratio, their median, the share of seeds within 2x, and the ratios of the errors' median and RMS."""
    a, i = np.asarray(actuated, dtype=float), np.asarray(ideal, dtype=float)
    ratio = a / i
    return {
        "terminal_position_error_m": a.tolist(),
        "ideal_terminal_position_error_m": i.tolist(),
        "terminal_error_ratio": ratio.tolist(),
        "terminal_error_ratio_median": float(np.median(ratio)),
        "share_within_2x": float(np.mean(ratio <= 2.0)),
        "median_error_ratio": float(np.median(a) / np.median(i)),
        "rms_error_ratio": float(np.sqrt(np.mean(a**2) / np.mean(i**2))),
    }


def run(args: argparse.Namespace) -> int:
    from ..config import load_config
    from ..scenario.build import build_scenario, ideal_counterpart
    from ..sim.closed_loop import simulate

    cfg = load_config(args.config, scenario=args.scenario)
    if args.actuators:
        cfg = cfg.with_overrides({"spacecraft.actuators": args.actuators})
    if cfg.spacecraft.actuators == "ideal":
        raise SystemExit('bench actuation: spacecraft.actuators is "ideal"; give --actuators or a configuration with one')
    scn = build_scenario(cfg)
    u_max, T_max = scn.input_bounds
    try:
        ideal_cfg, ideal = ideal_counterpart(cfg, scn)
    except ValueError as exc:
        raise SystemExit(f"bench actuation: {exc}") from exc
    if args.seeds < 1:
        raise SystemExit("bench actuation: --seeds must be >= 1")
    methods = ["tbmpc", "ffa"] if args.method == "both" else [args.method]
    dt = cfg.mpc.dt
    out: dict[str, Any] = {
        "machine": machine_info(),
        "config": cfg.to_dict(),
        "ideal_config": ideal_cfg.to_dict(),
        "actuators": cfg.spacecraft.actuators,
        "u_max": u_max,
        "T_max": T_max,
        "seed": args.seed,
        "seeds": args.seeds,
        "design_worker": args.design_worker or cfg.tube.design_worker,
        "methods": {},
    }
    print(f"{cfg.spacecraft.actuators} against ideal actuators (u_max {u_max:.4g} m/s^2, T_max {T_max:.4g} N m):")
    for m in methods:
        act = _figures(simulate(scn, m, args.seed, design_worker=args.design_worker), scn.xf, dt, u_max)
        base = _figures(simulate(ideal, m, args.seed, design_worker=args.design_worker), ideal.xf, dt, u_max)
        row = {
            "actuators": act,
            "ideal": base,
            "terminal_error_ratio": act["terminal_position_error_m"] / base["terminal_position_error_m"],
            "net_delta_v_ratio": act["net_delta_v_m_s"] / base["net_delta_v_m_s"],
            "thruster_delta_v_over_ideal": act["thruster_delta_v_m_s"] / base["net_delta_v_m_s"],
            "p99_growth_ms": act["controller_and_actuation_p99_ms"] - act["controller_p99_ms"],
        }
        if args.seeds > 1:
            errors = ([act["terminal_position_error_m"]], [base["terminal_position_error_m"]])
            for seed in range(args.seed + 1, args.seed + args.seeds):
                for e, sc in zip(errors, (scn, ideal), strict=True):
                    rec = simulate(sc, m, seed, design_worker=args.design_worker)
                    e.append(float(np.linalg.norm(rec.x[-1, :3] - sc.xf[:3])))
            row["over_seeds"] = seed_statistics(*errors)
        out["methods"][m] = row
        print(
            f"  {m:6s} outside {act['steps_outside_tube']} (ideal {base['steps_outside_tube']}); terminal "
            f"{act['terminal_position_error_m']:.3g} m = {row['terminal_error_ratio']:.3g}x ideal; net delta-v "
            f"{act['net_delta_v_m_s']:.4g} m/s = {row['net_delta_v_ratio']:.4g}x ideal, thrusters "
            f"{act['thruster_delta_v_m_s']:.4g} m/s, propellant {act['propellant_kg']:.4g} kg, {act['pulses']} pulses; "
            f"p99 {act['controller_p99_ms']:.3g} ms -> {act['controller_and_actuation_p99_ms']:.3g} ms with the "
            f"actuation (+{row['p99_growth_ms']:.3g} ms); the tube leaves the nominal input "
            f"{act['nominal_input_fraction_median']:.2f} of u_max (median; ideal "
            f"{base['nominal_input_fraction_median']:.2f}), "
            f"plan off the reference by up to {act['max_plan_offset_m']:.3g} m (ideal {base['max_plan_offset_m']:.3g} m)"
        )
        if "over_seeds" in row:
            o = row["over_seeds"]
            print(
                f"         over {args.seeds} seeds: terminal error {o['terminal_error_ratio_median']:.3g}x ideal (median "
                f"ratio), within 2x in {o['share_within_2x']:.0%}; median errors {o['median_error_ratio']:.3g}x, "
                f"RMS {o['rms_error_ratio']:.3g}x"
            )
    write_json(args.json, out)
    return 0
