"""The same closed loop from C++ and from Python: a scenario exported by ``tubempc export-scenario``
flown with TBMPC-FFA by the C++ example (``examples/cpp/closed_loop``, the core embedded through CMake)
and by the same loop written in Python over the bindings (``_core.control.Controller.step`` and the
truth propagation ``_core.dynamics.ProximityModel.propagate``, same settings, no disturbance, no
background designs; with navigation in the scenario, ``_core.nav.NavigationSystem`` on IMU sub-steps and
the controller on its estimate; with actuators, ``_core.actuators.ActuationSystem``). Both read the one
scenario file, so they fly the same mission with the same code (the final states agree to the bit); the
per-step times show what the bindings add (argument conversion, the result copy, the GIL) and should
otherwise match within the machine's noise. The two loops run alternately ``--repeats`` times.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from ..results.machine import machine_info
from ..testing.examples import find_example

DESCRIPTION = "closed loop of an exported scenario: the C++ example binary against the same loop through the bindings"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--config", help="scenario TOML (default: the packaged paper scenario)")
    source.add_argument("--scenario", help="a packaged scenario by name (e.g. bennu-tag-nav)")
    parser.add_argument(
        "--seed", type=int, help="the run whose navigation and actuators are exported (default: the config's)"
    )
    parser.add_argument(
        "--example",
        type=Path,
        help="the closed_loop binary (default: the newest build/*/examples/cpp/closed_loop/closed_loop "
        "under the current directory, from a build with TUBEMPC_BUILD_EXAMPLES=ON)",
    )
    parser.add_argument("--repeats", type=int, default=3, help="runs of each loop, alternating (default 3)")
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("results/bench_embed"),
        help="folder for the scenario, the example's outputs and embed.json (default results/bench_embed)",
    )
    parser.add_argument("--cache-dir", type=Path, help="reference-trajectory cache (default: OUT/cache)")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")


def _navigation(s: Any, controller_model: Any, shapes: tuple[Any, ...], same_shape: bool) -> Any:
    """The scenario's NavigationSystem (None without navigation): the filter ray-casts the controller's
    shape, the sensors the truth's."""
    if not s.navigation.enabled:
        return None
    filter_caster = _core.nav.RayCaster(shapes[0])
    sensor_caster = filter_caster if same_shape else _core.nav.RayCaster(shapes[1])
    n = s.navigation
    return _core.nav.NavigationSystem(controller_model, sensor_caster, filter_caster, n.landmarks, n.settings, n.seed)


def _actuation(s: Any) -> Any:
    """The scenario's ActuationSystem (None: ideal actuators)."""
    a = s.actuators
    if not a.enabled:
        return None
    wheels = _core.actuators.ReactionWheels(a.wheels, a.momentum_dump)
    wheels.set_momentum(a.wheel_momentum)
    return _core.actuators.ActuationSystem(_core.actuators.ThrusterCluster(a.thrusters), wheels, a.settings)


def python_loop(scenario_path: str | Path) -> dict[str, Any]:
    """The loop of ``examples/cpp/closed_loop`` (TBMPC-FFA) written over the bindings; times in s per step:
    the controller's own split and the wall time of the call through the bindings."""

    s = _core.io.read_scenario(str(scenario_path))
    files = [(s.resolve(b.shape), b.shape_unit_scale) for b in (s.model, s.truth)]
    shapes = tuple(_core.gravity.load_shape(*f) for f in files)

    def model(body: Any, shape: Any) -> Any:
        return _core.dynamics.ProximityModel(_core.gravity.PolyhedronGravity(shape, body.density), body.params)

    controller_model, truth = model(s.model, shapes[0]), model(s.truth, shapes[1])
    t_setup = time.perf_counter()
    settings = s.controller
    settings.method = _core.control.Method.Ffa
    ctrl = _core.control.Controller(_core.mpc.LinearizedProximityModel(controller_model), s.settings, settings)
    ctrl.setup(s.reference, s.ffa_designs)
    T, dt, t0 = s.mission_steps, s.settings.dt, s.reference.t0
    p, zbar = s.propagator, np.asarray(s.reference.z)
    no_disturbance = np.zeros(6)
    tol = p.gravity_expansion_tolerance  # the run's held gravity expansion, as the example's
    gravity_hold = _core.gravity.ExpansionHold(0.0, tol) if tol > 0.0 else None
    x = np.asarray(s.x0, dtype=np.float64)
    state = _core.dynamics.state_to_truth(x)
    nav = _navigation(s, controller_model, shapes, files[0] == files[1])
    actuation = _actuation(s)
    x_hat, h, n_sub, E = x, dt, 1, None
    srp_L = np.asarray(truth.srp_acceleration_L)
    if nav is not None:  # the IMU's sub-steps and the controller on the estimate (tubempc.sim.closed_loop)
        h = nav.base_period
        n_sub = round(dt / h)
    samples = (np.zeros(n_sub), np.zeros((n_sub, 13)), np.zeros((n_sub, 3)))  # t, truth, accel_nongrav_L
    if nav is not None:
        est = nav.initialize(t0, state, srp_L, zbar[6:9, 0])
        x_hat, E = np.asarray(est.x_hat), s.navigation.error_set_scale * np.asarray(est.P_x)
    setup_s = time.perf_counter() - t_setup
    time_call, time_controller, time_mpc = np.zeros(T), np.zeros(T), np.zeros(T)
    statuses: dict[str, int] = {}
    scp = 0
    for k in range(T):
        t_k = t0 + k * dt
        a = time.perf_counter()
        if E is not None:
            ctrl.set_estimation_error(E)
        r = ctrl.step(k, x_hat)
        time_call[k] = time.perf_counter() - a
        u = np.asarray(r.u)
        if actuation is not None:
            C_BL = np.asarray(_core.so3.rotation_matrix(state[6:10])).T
            u = np.asarray(actuation.step(t_k, u, C_BL).u_delivered)
        for j in range(n_sub):
            prop = truth.propagate(
                t_k + j * h if nav is not None else t_k, state, u, h, p, no_disturbance, None, gravity_hold
            )
            if prop.status != _core.dynamics.PropagationStatus.Success:
                raise RuntimeError(f"truth propagation failed at step {k}: {prop.status.name}")
            state = np.asarray(prop.state)
            if nav is not None:
                samples[0][j], samples[1][j], samples[2][j] = t_k + (j + 1) * h, state, u[:3] + srp_L
        x = _core.dynamics.truth_to_state(state, zbar[6:9, k + 1])
        state = _core.dynamics.state_to_truth(x)
        x_hat = x
        if nav is not None:
            samples[1][-1] = state  # the last sample is after the (here zero) disturbance
            est = nav.step(*samples, zbar[6:9, k + 1])
            x_hat, E = np.asarray(est.x_hat), s.navigation.error_set_scale * np.asarray(est.P_x)
        time_controller[k], time_mpc[k] = r.timings.total, r.timings.mpc
        statuses[str(r.mpc.status)] = statuses.get(str(r.mpc.status), 0) + 1
        scp += r.mpc.scp_iterations
    return {
        "steps": T,
        "setup_s": setup_s,
        "scp_iterations": scp,
        "statuses": statuses,
        "final_state": x.tolist(),
        "time_call_s": time_call.tolist(),
        "time_controller_s": time_controller.tolist(),
        "time_mpc_s": time_mpc.tolist(),
    }


def cpp_loop(example: Path, scenario_path: Path, json_path: Path) -> dict[str, Any]:
    """Runs the example binary on the scenario (TBMPC-FFA); its JSON output (python_loop's fields but the
    call's wall time, which the controller's own time stands for, and the heap allocations)."""
    proc = subprocess.run(
        [str(example), str(scenario_path), "--method", "ffa", "--json", str(json_path)],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        raise RuntimeError(f"{example} exited with {proc.returncode}:\n{proc.stdout}{proc.stderr}")
    result: dict[str, Any] = json.loads(json_path.read_text(encoding="utf-8"))["methods"]["ffa"]
    result["time_call_s"] = result["time_controller_s"]
    return result


def _stats(values: Any) -> dict[str, float]:
    a = np.asarray(values, dtype=np.float64)
    return {"median": float(np.median(a)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


def run(args: argparse.Namespace) -> int:
    from ..config import load_config
    from ..results.export import export_scenario

    if args.repeats < 1:
        raise SystemExit("--repeats must be >= 1")
    info = machine_info()
    print(f"machine: {info['cpu']} ({info['cores']} cores), Python {info['python']}")
    example = find_example(args.example)
    out: Path = args.out
    cfg = load_config(args.config, scenario=args.scenario)
    scenario = export_scenario(cfg, out / "scenario", cache_dir=args.cache_dir or out / "cache", seed=args.seed)
    print(f"scenario: {scenario}; example: {example}")
    runs: list[dict[str, Any]] = []
    for i in range(args.repeats):
        for loop in ("cpp", "python"):
            r = cpp_loop(example, scenario, out / f"cpp_run{i}.json") if loop == "cpp" else python_loop(scenario)
            runs.append(
                {
                    "loop": loop,
                    "run": i,
                    "statuses": r["statuses"],
                    "scp_iterations": r["scp_iterations"],
                    "final_state": r["final_state"],
                    "call": _stats(r["time_call_s"]),
                    "controller": _stats(r["time_controller_s"]),
                    "mpc": _stats(r["time_mpc_s"]),
                    **(
                        {
                            key: r[key]
                            for key in (
                                "allocations_controller",
                                "allocations_navigation",
                                "allocations_actuation",
                                "allocations_truth",
                            )
                        }
                        if loop == "cpp"
                        else {}
                    ),
                }
            )
    print(
        f"{'loop':8s} {'run':>3s}  {'controller median':>17s} {'p99':>8s} {'max':>8s}   {'call median':>11s} "
        f"{'p99':>8s}   [ms]   statuses"
    )
    for r in runs:
        print(
            f"{r['loop']:8s} {r['run']:3d}  {1e3 * r['controller']['median']:17.3f} "
            f"{1e3 * r['controller']['p99']:8.3f} {1e3 * r['controller']['max']:8.3f}   "
            f"{1e3 * r['call']['median']:11.3f} {1e3 * r['call']['p99']:8.3f}   {r['statuses']}"
        )
    summary: dict[str, Any] = {}
    for loop in ("cpp", "python"):
        mine = [r for r in runs if r["loop"] == loop]
        summary[loop] = {
            key: {stat: float(np.median([r[key][stat] for r in mine])) for stat in ("median", "p99", "max")}
            for key in ("call", "controller", "mpc")
        }
    finals = np.array([r["final_state"] for r in runs])
    spread = float(np.max(np.abs(finals - finals[0])))
    ratio = summary["python"]["call"]["median"] / summary["cpp"]["controller"]["median"]
    print(
        f"median over runs, controller step: C++ {1e3 * summary['cpp']['controller']['median']:.3f} ms (p99 "
        f"{1e3 * summary['cpp']['controller']['p99']:.3f}), through the Python bindings "
        f"{1e3 * summary['python']['call']['median']:.3f} ms (p99 {1e3 * summary['python']['call']['p99']:.3f}); "
        f"Python / C++ = {ratio:.3f}"
    )
    print(f"largest difference between the runs' final states: {spread:.3g} (0: every run flew the same trajectory)")
    cpp_runs = [r for r in runs if r["loop"] == "cpp"]
    worst = {k: max(r[f"allocations_{k}"] for r in cpp_runs) for k in ("controller", "navigation", "actuation")}
    print(
        f"C++ example: heap allocations after setup: controller step {worst['controller']}, navigation "
        f"{worst['navigation']}, actuation {worst['actuation']}"
    )
    result = {
        "machine": info,
        "config": str(out / "scenario" / "config.toml"),
        "scenario": str(scenario),
        "example": str(example),
        "repeats": args.repeats,
        "runs": runs,
        "summary": summary,
        "python_over_cpp_controller_median": ratio,
        "final_state_spread": spread,
    }
    text = json.dumps(result, indent=2) + "\n"
    (out / "embed.json").write_text(text, encoding="utf-8")
    print(f"wrote {out / 'embed.json'} (configuration: {out / 'scenario' / 'config.toml'})")
    if args.json is not None:
        args.json.write_text(text, encoding="utf-8")
    return 0
