"""Accuracy and cost of the truth propagation's integrators (issue #20: choose by measured accuracy).

Flies the mission once with TBMPC to obtain its applied input sequence, then propagates the truth
open loop through the same 300 zero-order-hold intervals, without disturbance, with each candidate
integrator of the core (classical RK4 with n substeps, adaptive Dormand-Prince 5(4)) and with a tight
reference: scipy's DOP853 (rtol 1e-13, atol 1e-15) on the core's ``truth_derivative``, interval by
interval. The configured integrator is also tried with the truth's gravity held as its first-order expansion
(``--gravity-tolerance``, PropagatorSettings.gravity_expansion_tolerance; docs/model.md M42), the run's hold
carried from interval to interval, against the same reference on the exact field. Reported per candidate:
the largest one-interval error (each interval started from the reference's state: the error a closed-loop
step sees), also as a fraction of the simulated
disturbance's standard deviation per step (the largest over position, velocity, attitude and rate),
the final-state difference after the whole mission, the derivative evaluations (and, held, the field's
evaluations and the largest error the hold found) and the wall time per interval.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..results.machine import machine_info
from . import write_json

DESCRIPTION = "truth integrators (RK4 substeps, DOPRI5) against a tight DOP853 reference: error and cost"

Array = npt.NDArray[np.float64]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--config", help="scenario TOML (fields left out are the paper scenario's)")
    group.add_argument("--scenario", help="a packaged scenario (default: bennu-paper)")
    parser.add_argument("--substeps", default="1,2,4,8", help="RK4 substeps per control interval to try")
    parser.add_argument("--dopri-rtol", default="1e-8,1e-10", help="DOPRI5 relative tolerances to try")
    parser.add_argument(
        "--gravity-tolerance",
        default="1e-9,1e-10,1e-11",
        help="tolerances (m/s^2) of the held gravity expansion to try with the configured integrator",
    )
    parser.add_argument("--repeats", type=int, default=3, help="timing repeats (the fastest is kept)")
    parser.add_argument("--intervals", type=int, help="only the first this many control intervals (default: all)")
    parser.add_argument("--json", metavar="PATH", help="write the figures as JSON")


def _errors(a: Array, b: Array) -> dict[str, float]:
    """Differences of two truth states [r_L, v_L, q_B/L, omega_BL_B]: m, m/s, rad, rad/s."""
    sign = 1.0 if float(a[6:10] @ b[6:10]) >= 0.0 else -1.0
    chord = float(np.linalg.norm(a[6:10] - sign * b[6:10]))  # = 2 sin(angle / 4) for unit quaternions
    return {
        "position_m": float(np.linalg.norm(a[:3] - b[:3])),
        "velocity_m_s": float(np.linalg.norm(a[3:6] - b[3:6])),
        "attitude_rad": float(4.0 * np.arcsin(min(1.0, 0.5 * chord))),
        "rate_rad_s": float(np.linalg.norm(a[10:13] - b[10:13])),
    }


def _worst(rows: list[dict[str, float]]) -> dict[str, float]:
    return {key: max(r[key] for r in rows) for key in rows[0]}


def _reference(truth: Any, states: Array, inputs: Array, dt: float) -> tuple[Array, Array]:
    """DOP853 over each interval: from the reference's own state (open loop) and from ``states`` (one step)."""
    from scipy.integrate import solve_ivp

    zero = np.zeros(6)

    def interval(k: int, s0: Array) -> Array:
        sol = solve_ivp(
            lambda t, s: truth.truth_derivative(t, s, inputs[k], zero),
            (k * dt, (k + 1) * dt),
            s0,
            method="DOP853",
            rtol=1e-13,
            atol=1e-15,
        )
        s = sol.y[:, -1].copy()
        s[6:10] /= np.linalg.norm(s[6:10])
        return s

    open_loop = states[0].copy()
    one_step = np.empty_like(states[1:])
    for k in range(len(inputs)):
        one_step[k] = interval(k, states[k])
        open_loop = interval(k, open_loop)
    return open_loop, one_step


def run(args: argparse.Namespace) -> int:
    from ..config import load_config
    from ..scenario.build import build_scenario, propagator_settings
    from ..sim.closed_loop import simulate

    cfg = load_config(args.config, scenario=args.scenario)
    scn = build_scenario(cfg)
    dt = cfg.mpc.dt
    rec = simulate(scn, "tbmpc", 0)
    truth = scn.truth
    dist = cfg.disturbance
    sigma = {
        key: float(np.sqrt(np.max(S)))
        for key, S in (
            ("position_m", dist.S_p_position),
            ("velocity_m_s", dist.S_p_velocity),
            ("attitude_rad", dist.S_r_attitude),
            ("rate_rad_s", dist.S_r_rate),
        )
    }
    inputs = np.asarray(rec.u)[: args.intervals]
    candidates: list[tuple[str, dict[str, Any]]] = [
        (f"rk4, {n} substeps", {"method": "rk4", "substeps": int(n)}) for n in args.substeps.split(",")
    ] + [(f"dopri5, rtol {r}", {"method": "dopri5", "rtol": float(r)}) for r in args.dopri_rtol.split(",")]
    configured = propagator_settings(cfg)
    for tol in args.gravity_tolerance.split(",") if args.gravity_tolerance else []:
        held = propagator_settings(cfg)
        held.gravity_expansion_tolerance = float(tol)
        candidates.append((f"configured, gravity held to {tol} m/s^2", {"settings": held}))
    candidates.append(("configured", {"settings": configured}))

    # The reference trajectory: the open-loop truth by the tightest integrator.
    states = np.empty((len(inputs) + 1, 13))
    states[0] = truth.state_to_truth(rec.x[0])
    for k in range(len(inputs)):
        res = truth.propagate(k * dt, states[k], inputs[k], dt, method="dopri5", rtol=1e-12, atol=1e-14)
        states[k + 1] = np.asarray(res.state)
    t0 = time.perf_counter()
    final_ref, one_step_ref = _reference(truth, states, inputs, dt)
    ref_seconds = time.perf_counter() - t0

    out: dict[str, Any] = {
        "machine": machine_info(),
        "scenario": args.scenario or (Path(args.config).stem if args.config else "bennu-paper"),
        "config": cfg.to_dict(),
        "intervals": len(inputs),
        "dt_s": dt,
        "reference": {"method": "scipy DOP853, rtol 1e-13, atol 1e-15", "seconds": ref_seconds},
        "configured": cfg.simulation.integrator
        + (f", {cfg.simulation.substeps} substeps" if cfg.simulation.integrator == "rk4" else ""),
        "disturbance_sigma": sigma,
        "candidates": {},
    }
    print(f"truth integrators over {len(inputs)} intervals of {dt} s (reference: DOP853 rtol 1e-13):")
    for name, kw in candidates:
        tol = kw["settings"].gravity_expansion_tolerance if "settings" in kw else 0.0
        best = float("inf")
        for _ in range(max(1, args.repeats)):
            hold = _core.gravity.ExpansionHold(0.0, tol) if tol > 0.0 else None  # the run's, carried along
            t0 = time.perf_counter()
            one = [truth.propagate(k * dt, states[k], inputs[k], dt, gravity_hold=hold, **kw) for k in range(len(inputs))]
            best = min(best, time.perf_counter() - t0)
        s = states[0].copy()
        open_hold = _core.gravity.ExpansionHold(0.0, tol) if tol > 0.0 else None
        for k in range(len(inputs)):
            s = np.asarray(truth.propagate(k * dt, s, inputs[k], dt, gravity_hold=open_hold, **kw).state)
        row: dict[str, Any] = {
            "one_step_max": _worst([_errors(np.asarray(r.state), one_step_ref[k]) for k, r in enumerate(one)]),
            "final": _errors(s, final_ref),
            "one_step_over_sigma": 0.0,
            "evaluations_per_interval": float(np.mean([r.evaluations for r in one])),
            "ms_per_interval": 1e3 * best / len(inputs),
        }
        if hold is not None:  # the field's evaluations with their gradient, and the largest error found
            row["gravity_tolerance"] = tol
            row["field_evaluations_per_interval"] = hold.evaluations / len(inputs)
            row["largest_expansion_error"] = hold.largest_error
        o, f = row["one_step_max"], row["final"]
        row["one_step_over_sigma"] = max(o[key] / sigma[key] for key in sigma)
        out["candidates"][name] = row
        print(
            f"  {name:22s} one step: {o['position_m']:.2e} m, {o['velocity_m_s']:.2e} m/s, "
            f"{o['attitude_rad']:.2e} rad, {o['rate_rad_s']:.2e} rad/s (<= {row['one_step_over_sigma']:.1e} sigma); "
            f"final: {f['position_m']:.2e} m, {f['velocity_m_s']:.2e} m/s, "
            f"{f['attitude_rad']:.2e} rad; {row['evaluations_per_interval']:.0f} evaluations"
            + (f" ({row['field_evaluations_per_interval']:.2f} of the field)" if hold is not None else "")
            + f", {row['ms_per_interval']:.3g} ms per interval"
        )
    write_json(args.json, out)
    return 0
