"""Actuator allocation and sets on a preset (docs/model.md "Actuators"): the C++ allocation's time per
solve and iterations on random commands inside and beyond the achievable box, its agreement with scipy's
BVLS on the same problems (and scipy's time), the achievable box (healthy and with one thruster failed),
and the certified actuation-error box against the errors of a modulated closed chain with sampled truth
errors."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._core import actuators as act
from ..results.machine import machine_info
from ..scenario.actuators import load_actuators, preset_names, sample_truth_errors
from . import write_json

DESCRIPTION = "actuators: allocation time and agreement with scipy BVLS, achievable box, actuation-error box"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--preset", default="osiris_rex_like", help=f"preset name or TOML path ({preset_names()})")
    parser.add_argument("--period", type=float, default=2.0, help="control period (s)")
    parser.add_argument("--commands", type=int, default=2000, help="random commands (default 2000)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the commands and the truth errors")
    parser.add_argument("--json", type=Path, default=None, help="write the figures to this JSON file")


def _stats(values: list[float]) -> dict[str, float]:
    a = np.asarray(values, dtype=float)
    return {"median": float(np.median(a)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


def run(args: argparse.Namespace) -> int:
    from scipy.optimize import lsq_linear

    suite = load_actuators(args.preset, args.period)
    rng = np.random.default_rng(args.seed)
    info = machine_info()
    print(
        f"machine: {info['cpu']} ({info['cores']} cores); preset {suite.name}: {len(suite.cluster)} thrusters, "
        f"{len(suite.wheels)} wheels, {suite.mass:g} kg, period {args.period:g} s"
    )

    t0 = time.perf_counter()
    healthy_settings = act.AchievableBoxSettings()
    healthy_settings.tolerate_one_failure = False
    healthy = act.achievable_box(suite.cluster, suite.wheels, suite.allocation, suite.mass, healthy_settings)
    t_healthy = time.perf_counter() - t0
    t0 = time.perf_counter()
    box = act.achievable_box(suite.cluster, suite.wheels, suite.allocation, suite.mass)
    t_box = time.perf_counter() - t0

    alloc = suite.allocator()
    solve_s, iterations, scipy_s, dx, dobj = [], [], [], [], []
    statuses: dict[str, int] = {}
    for k in range(args.commands):
        w = rng.uniform(-1.0, 1.0, size=6) * healthy.half_width_B * (1.0 if k % 2 else 1.5)
        r = alloc.solve(suite.cluster, suite.wheels, 0.0, w)
        solve_s.append(r.info.solve_time)
        iterations.append(r.info.iterations)
        statuses[str(r.info.status)] = statuses.get(str(r.info.status), 0) + 1
        A, b, lo, hi = alloc.last_problem()
        free = lo < hi
        t0 = time.perf_counter()
        ref = lsq_linear(A[:, free], b - A[:, ~free] @ lo[~free], bounds=(lo[free], hi[free]), method="bvls", tol=1e-14)
        scipy_s.append(time.perf_counter() - t0)
        x = np.concatenate([r.thrust, r.wheel_torque])
        x_ref = lo.copy()
        x_ref[free] = ref.x
        dx.append(float(np.abs(x - x_ref).max() / np.abs(hi).max()))
        f, f_ref = float(np.sum((A @ x - b) ** 2)), float(np.sum((A @ x_ref - b) ** 2))
        dobj.append((f - f_ref) / max(f_ref, 1e-300))

    truth = sample_truth_errors(suite.cluster, rng)
    mod = suite.modulator()
    bound = act.actuation_error_bound(truth, mod, suite.mass)
    t0 = time.perf_counter()
    in_box = act.actuation_error_bound(truth, mod, suite.mass, suite.wheels, suite.allocation, box.half_width_B)
    t_in_box = time.perf_counter() - t0
    alloc_t = act.Allocator(truth, suite.wheels, suite.allocation)
    worst, worst_in_box = np.zeros(6), np.zeros(6)
    for k in range(args.commands):
        w = rng.uniform(-1.0, 1.0, size=6) * box.half_width_B * (0.01 if k % 3 == 0 else 1.0)
        r = alloc_t.solve(truth, suite.wheels, k * args.period, w)
        fire = mod.modulate(truth, k * args.period, r.thrust)
        e = np.asarray(fire.commanded_B) - np.asarray(fire.delivered_B)
        worst = np.maximum(worst, np.abs(e) / np.asarray(bound.wrench_B))
        worst_in_box = np.maximum(worst_in_box, np.abs(e) / np.asarray(in_box.wrench_B))

    out: dict[str, Any] = {
        "machine": info,
        "preset": suite.name,
        "thrusters": len(suite.cluster),
        "wheels": len(suite.wheels),
        "period_s": args.period,
        "commands": args.commands,
        "seed": args.seed,
        "allocation": {
            "solve_us": {key: 1e6 * v for key, v in _stats(solve_s).items()},
            "iterations": _stats([float(i) for i in iterations]),
            "statuses": statuses,
            "scipy_bvls_us": {key: 1e6 * v for key, v in _stats(scipy_s).items()},
            "max_x_difference_over_bounds": float(max(dx)),
            "max_objective_excess": float(max(dobj)),
        },
        "achievable_box": {
            "healthy_half_width_B": np.asarray(healthy.half_width_B).tolist(),
            "one_failure_half_width_B": np.asarray(box.half_width_B).tolist(),
            "one_failure_input_half_width": np.asarray(box.input_half_width).tolist(),
            "limiting_failure": box.limiting_failure,
            "seconds": {"healthy": t_healthy, "one_failure": t_box},
        },
        "actuation_error": {
            "wrench_B": np.asarray(bound.wrench_B).tolist(),
            "modulation_B": np.asarray(bound.modulation_B).tolist(),
            "input": np.asarray(bound.input).tolist(),
            "worst_sampled_over_bound": worst.tolist(),
            "in_box": {
                "wrench_B": np.asarray(in_box.wrench_B).tolist(),
                "input": np.asarray(in_box.input).tolist(),
                "thrust_norm": in_box.thrust_norm,
                "thrust_norm_any_command": bound.thrust_norm,
                "worst_sampled_over_bound": worst_in_box.tolist(),
                "seconds": t_in_box,
            },
        },
    }
    a = out["allocation"]
    print(
        f"allocation: median {a['solve_us']['median']:.3g} us, p99 {a['solve_us']['p99']:.3g} us, max "
        f"{a['solve_us']['max']:.3g} us; iterations median {a['iterations']['median']:.0f}, max "
        f"{a['iterations']['max']:.0f}; statuses {statuses}"
    )
    print(
        f"scipy BVLS: median {a['scipy_bvls_us']['median']:.3g} us; largest difference "
        f"{a['max_x_difference_over_bounds']:.1e} of the bounds, objective excess {a['max_objective_excess']:.1e}"
    )
    print(f"achievable box: healthy {np.round(healthy.half_width_B, 3)}, one failure {np.round(box.half_width_B, 3)}")
    print(f"actuation-error box {np.round(bound.wrench_B, 3)}; sampled worst / box {np.round(worst, 3)}")
    print(
        f"for commands in the achievable box: {np.round(in_box.wrench_B, 3)} (thrust norm <= {in_box.thrust_norm:.3g} N); "
        f"sampled worst / box {np.round(worst_in_box, 3)}"
    )
    write_json(args.json, out)
    return 0
