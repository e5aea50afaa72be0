"""Instructions per step: what a controller, navigation and actuation step costs on any processor.

Wall-clock figures drift with the machine's load; an instruction count does not. The mission of a scenario
(exported with ``tubempc export-scenario``) is flown by the C++ example (``examples/cpp/closed_loop``) under
valgrind's callgrind with ``--instructions``: callgrind's client requests switch collection on for each
controller, navigation and actuation call alone and dump it as one part of the profile, so that nothing of
Python, of the set-up or of the simulated plant is counted in a step (the example dumps its set-up and its
truth's propagation as parts of their own: the set-up's instructions are reported once per method). The flight
is the run of ``--seed`` (its additive disturbance, its navigation noise and actuator errors), with no background
designs (as every C++ flight).

Per method and component: the median, p99 and largest count over the mission's steps, and "ms on a 200 MIPS
processor" (instructions / 200e6, a RAD750-class or LEON4 core at one instruction per cycle: an order of
magnitude, not a timing model). For each component's worst step, what it did: the MPC's SCP iterations
(QPs), active-set solves and factorisations, PIQP's iterations, the nodes discretised, the polyhedral
gravity evaluations (calls counted by callgrind) and the instructions inside the gravity and the LDL^T
factorisation. The navigation call holds the sensors' simulation (ray casting the truth's shape: the truth
side, which flight hardware replaces); the onboard estimator is the call less the sensors' calls, and the
onboard step is controller + estimator + actuation of one period.

The instrumented flight is checked against a native one: the same final state to the bit, the same
statuses (a step slowed ~50x by valgrind must not reach the MPC's time limit). ``--runs 2`` (default) flies
it twice and reports the largest relative difference of the figures between the runs.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import tempfile
import time
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from ..results.machine import machine_info
from ..testing.examples import find_example
from . import write_json

DESCRIPTION = "instructions per controller, navigation and actuation step of a mission (valgrind's callgrind)"

MIPS = 200.0  # the reference processor of the "ms on a 200 MIPS processor" column (million instructions/s)
COMPONENTS = ("controller", "navigation", "actuation")

# Functions whose calls a part's profile counts or whose inclusive instructions it sums (demangled name
# prefixes, matched up to the argument list).
GRAVITY = ("tubempc::gravity::PolyhedronGravity::evaluate", "tubempc::gravity::PolyhedronGravity::acceleration")
LDLT = ("tubempc::mpc::PartialLdlt::",)
SENSORS = (
    "tubempc::nav::Altimeter::measure",
    "tubempc::nav::NavCamera::measure",
    "tubempc::nav::Imu::measure",
    "tubempc::nav::StarTracker::measure",
    "tubempc::nav::NavigationSystem::sensor_truth",
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--config", help="scenario TOML (default: the packaged paper scenario)")
    source.add_argument("--scenario", help="a packaged scenario by name (e.g. bennu-tag-nav)")
    parser.add_argument("--method", choices=[*_core.control.Method.names(), "both"], default="both", help="default both")
    parser.add_argument(
        "--seed", type=int, help="the run flown: its disturbance, navigation and actuators (default: the config's)"
    )
    parser.add_argument(
        "--example",
        type=Path,
        help="the closed_loop binary (default: the newest build/*/examples/cpp/closed_loop/closed_loop "
        "under the current directory); built with <valgrind/callgrind.h> (Debian: valgrind)",
    )
    parser.add_argument("--runs", type=int, default=2, help="instrumented flights, compared (default 2)")
    parser.add_argument(
        "--out",
        type=Path,
        help="folder for the scenario, the profiles and the example's outputs (default: a temporary folder)",
    )
    parser.add_argument("--cache-dir", type=Path, help="reference-trajectory cache (default: OUT/cache)")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")


# ---- callgrind's profile ---------------------------------------------------------------------------


@dataclass
class Part:
    """One dump of a callgrind profile: its label, instructions, and per function (demangled name) the
    calls made to it and their inclusive instructions (from callers outside the same group)."""

    label: str
    instructions: int = 0
    calls: dict[str, int] = field(default_factory=lambda: defaultdict(int))
    inclusive: dict[str, int] = field(default_factory=lambda: defaultdict(int))

    def count(self, prefixes: Iterable[str]) -> tuple[int, int]:
        """Calls to, and inclusive instructions of, the functions named by ``prefixes`` (from callers
        outside them: recursion and calls among them are not counted twice)."""
        group = tuple(prefixes)
        n = sum(v for name, v in self.calls.items() if _matches(name, group))
        ir = sum(v for name, v in self.inclusive.items() if _matches(name, group))
        return n, ir


def _matches(name: str, prefixes: tuple[str, ...]) -> bool:
    base = name.split("(", 1)[0]
    return any(base.startswith(p) for p in prefixes)


_NAMED = re.compile(r"^\((\d+)\)(?: (.*))?$")


def parse_callgrind(path: Path, groups: Iterable[tuple[str, ...]]) -> list[Part]:
    """The parts of a callgrind profile written with ``--combine-dumps=yes`` (format: valgrind's
    callgrind_format), in order. Calls are gathered for the functions of ``groups`` only, each call counted
    when its caller is outside the callee's group."""
    groups = [tuple(g) for g in groups]
    names: dict[str, str] = {}  # compressed ids of fn/cfn (one table for the whole file)
    parts: list[Part] = []
    part: Part | None = None
    fn = ""
    cfn = ""
    pending_call = 0  # the count of a "calls=" line whose cost line follows
    skip = False  # the next line is a call's cost line
    fn_groups: tuple[tuple[str, ...], ...] = ()

    def resolve(value: str) -> str:
        m = _NAMED.match(value)
        if not m:
            return value
        if m.group(2) is not None:
            names[m.group(1)] = m.group(2)
            return m.group(2)
        return names[m.group(1)]

    with path.open(encoding="utf-8", errors="replace") as f:
        for line in f:
            if skip:
                skip = False
                if part is not None and cfn:
                    cost = line.split()
                    part.calls[cfn] += pending_call
                    part.inclusive[cfn] += int(cost[1]) if len(cost) > 1 else 0
                continue
            c = line[0] if line else ""
            if c.isdigit() or c in "+-*":
                continue  # a cost line of the current function (its self cost)
            if line.startswith("desc: Trigger: "):
                label = line[len("desc: Trigger: ") :].strip()
                part = Part(label.removeprefix("Client Request: "))
                parts.append(part)
            elif line.startswith("fn="):
                fn = resolve(line[3:].rstrip("\n"))
                fn_groups = tuple(g for g in groups if _matches(fn, g))
            elif line.startswith("cfn="):
                callee = resolve(line[4:].rstrip("\n"))
                cfn = callee if any(_matches(callee, g) and g not in fn_groups for g in groups) else ""
            elif line.startswith("calls="):
                pending_call = int(line[6:].split()[0])
                skip = True
            elif line.startswith(("summary:", "totals:")) and part is not None:
                part.instructions = int(line.split()[1])
            elif line.startswith(("cfi=", "cfl=")):
                resolve(line[4:].rstrip("\n"))
            elif line.startswith(("ob=", "fl=", "fi=", "fe=", "cob=")):
                resolve(line.split("=", 1)[1].rstrip("\n"))
    return parts


# ---- the flights ---------------------------------------------------------------------------------


def run_disturbance(cfg: Any, seed: int, steps: int) -> np.ndarray:
    """The run's additive disturbance w_k (steps x 12), as the Python closed loop draws it (tubempc.sim)."""
    from ..models.disturbances import AdditiveDisturbance

    d = cfg.disturbance
    draw = AdditiveDisturbance(d.S_p, d.S_r, seed=seed, growth_p=d.growth_p, growth_r=d.growth_r, n_steps=steps)
    return np.array([np.concatenate(draw.sample(k)) for k in range(steps)])


def fly_example(command: list[str], json_path: Path) -> dict[str, Any]:
    proc = subprocess.run(command, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited with {proc.returncode}:\n{proc.stdout}{proc.stderr}")
    result: dict[str, Any] = json.loads(json_path.read_text(encoding="utf-8"))
    return result


def _stats(counts: np.ndarray) -> dict[str, float]:
    return {
        "median": float(np.median(counts)),
        "p99": float(np.percentile(counts, 99)),
        "max": float(counts.max()),
        "mean": float(counts.mean()),
    }


def _per_step(parts: list[Part], method: str, steps: int) -> dict[str, list[Part]]:
    """The parts of one method, per component, in step order (every step present)."""
    out: dict[str, list[Part]] = {}
    for component in COMPONENTS:
        mine = {int(p.label.split()[2]): p for p in parts if p.label.split()[:2] == [method, component]}
        if not mine:
            continue
        if sorted(mine) != list(range(steps)):
            raise RuntimeError(f"the profile lacks {method} {component} steps ({len(mine)} of {steps})")
        out[component] = [mine[k] for k in range(steps)]
    return out


def _method_figures(parts: dict[str, list[Part]], flight: dict[str, Any]) -> dict[str, Any]:
    """Per component: the distribution, the worst step and what it did; the onboard step's sum."""
    counts = flight["step_counts"]
    out: dict[str, Any] = {"components": {}}
    series: dict[str, np.ndarray] = {}
    for component, ps in parts.items():
        ir = np.array([p.instructions for p in ps], dtype=np.int64)
        series[component] = ir
        gravity = np.array([p.count(GRAVITY) for p in ps], dtype=np.int64)
        ldlt = np.array([p.count(LDLT)[1] for p in ps], dtype=np.int64)
        k = int(np.argmax(ir))
        worst: dict[str, Any] = {
            "step": k,
            "instructions": int(ir[k]),
            "gravity_evaluations": int(gravity[k, 0]),
            "gravity_instructions": int(gravity[k, 1]),
        }
        if component == "controller":
            worst["ldlt_instructions"] = int(ldlt[k])
            for key in (
                "scp_iterations",
                "active_set_solves",
                "active_set_iterations",
                "active_set_failures",
                "qp_iterations",
                "model_evaluations",
            ):
                worst[key] = int(counts[key][k])
            worst["mpc_status"] = _core.mpc.Status(counts["mpc_status"][k]).name
        elif component == "navigation":
            sensors = np.array([p.count(SENSORS)[1] for p in ps], dtype=np.int64)
            series["estimator"] = ir - sensors
            worst["sensor_instructions"] = int(sensors[k])
            worst["measurements"] = int(counts["navigation_measurements"][k])
        elif component == "actuation":
            worst["allocation_iterations"] = int(counts["allocation_iterations"][k])
        out["components"][component] = {
            **_stats(ir),
            "worst": worst,
            "share_gravity": float(gravity[:, 1].sum() / ir.sum()),
            **({"share_ldlt": float(ldlt.sum() / ir.sum())} if component == "controller" else {}),
            "gravity_evaluations_per_step": _stats(gravity[:, 0].astype(float)),
        }
    if "estimator" in series:
        est = series["estimator"]
        out["components"]["estimator"] = {
            **_stats(est),
            "worst": {"step": int(np.argmax(est)), "instructions": int(est.max())},
        }
    onboard = series["controller"] + series.get("estimator", 0) + series.get("actuation", 0)
    out["onboard"] = {
        **_stats(onboard),
        "worst": {"step": int(np.argmax(onboard)), "instructions": int(onboard.max())},
        "parts": [c for c in ("controller", "estimator", "actuation") if c in series],
    }
    abort = flight.get("abort")
    if abort and abort["entered_at_step"] >= 0:  # the supervised descent's steps and the abort's, apart
        k0, ir = int(abort["entered_at_step"]), series["controller"]
        out["abort"] = {
            "cause": abort["cause"],
            "entered_at_step": k0,
            "descent_controller": _stats(ir[:k0]),
            "abort_controller": _stats(ir[k0:]),
        }
    out["per_step"] = {c: v.tolist() for c, v in series.items()}
    return out


def _relative_spread(a: dict[str, Any], b: dict[str, Any]) -> float:
    """The largest relative difference of the runs' median, p99, max and per-step counts."""
    worst = 0.0
    for component, sa in a["per_step"].items():
        x, y = np.asarray(sa, dtype=float), np.asarray(b["per_step"][component], dtype=float)
        worst = max(worst, float(np.max(np.abs(x - y) / np.maximum(x, 1.0))))
    return worst


def _ms(instructions: float) -> float:
    return instructions / (MIPS * 1e6) * 1e3


def run(args: argparse.Namespace) -> int:
    from ..config import load_config
    from ..results.export import export_scenario

    if args.runs < 1:
        raise SystemExit("bench instructions: --runs must be >= 1")
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        raise SystemExit("bench instructions needs valgrind on PATH (Debian: apt-get install valgrind)")
    version = subprocess.run([valgrind, "--version"], capture_output=True, text=True, check=True).stdout.strip()
    info = machine_info()
    example = find_example(args.example)
    out: Path = args.out or Path(tempfile.mkdtemp(prefix="tubempc_bench_instructions_"))
    out.mkdir(parents=True, exist_ok=True)
    cfg = load_config(args.config, scenario=args.scenario)
    seed = cfg.disturbance.seed if args.seed is None else args.seed
    scenario = export_scenario(cfg, out / "scenario", cache_dir=args.cache_dir or out / "cache", seed=seed)
    steps = int(_core.io.read_scenario(str(scenario)).mission_steps)
    w_path = out / "disturbance.txt"
    np.savetxt(w_path, run_disturbance(cfg, seed, steps), fmt="%.17g")
    name = args.scenario or (Path(args.config).stem if args.config else "bennu-paper")
    print(f"machine: {info['cpu']} ({info['cores']} cores); {version}; example: {example}")
    print(f"scenario {name}: {scenario} ({steps} steps), seed {seed}")

    flight = [str(example), str(scenario), "--method", args.method, "--disturbance", str(w_path)]
    native = fly_example([*flight, "--json", str(out / "native.json")], out / "native.json")
    # The instrumented flights run side by side (one process each; callgrind is single-threaded).
    started = time.perf_counter()
    procs = []
    for r in range(args.runs):
        cmd = [
            valgrind,
            "--tool=callgrind",
            "--collect-atstart=no",
            "--combine-dumps=yes",
            f"--callgrind-out-file={out / f'callgrind_run{r}.out'}",
            *flight,
            "--instructions",
            "--json",
            str(out / f"instrumented_run{r}.json"),
        ]
        procs.append((cmd, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)))
    for cmd, proc in procs:
        log, _ = proc.communicate()
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} exited with {proc.returncode}:\n{log}")
    wall = time.perf_counter() - started
    runs: list[dict[str, Any]] = []
    for r in range(args.runs):
        instrumented = json.loads((out / f"instrumented_run{r}.json").read_text(encoding="utf-8"))
        parts = parse_callgrind(out / f"callgrind_run{r}.out", (GRAVITY, LDLT, SENSORS))
        figures: dict[str, Any] = {"methods": {}}
        for method, nat in native["methods"].items():
            ins = instrumented["methods"][method]
            if ins["final_state"] != nat["final_state"] or ins["statuses"] != nat["statuses"]:
                raise RuntimeError(
                    f"{method}: the instrumented flight differs from the native one (final state or statuses: "
                    f"{ins['statuses']} against {nat['statuses']}); a step may have hit the MPC's time limit"
                )
            figures["methods"][method] = _method_figures(_per_step(parts, method, steps), ins)
            figures["methods"][method]["allocations"] = {c: ins[f"allocations_{c}"] for c in COMPONENTS}
            # the set-up's calls, once per run (dumped apart so that no step is charged with their calls)
            figures["methods"][method]["setup_instructions"] = sum(
                p.instructions for p in parts if p.label.split()[:2] == [method, "setup"]
            )
        runs.append(figures)
    print(f"{args.runs} instrumented flights: {wall:.0f} s")

    spread = max(
        (_relative_spread(runs[0]["methods"][m], r["methods"][m]) for r in runs[1:] for m in runs[0]["methods"]),
        default=0.0,
    )
    result: dict[str, Any] = {
        "machine": info,
        "valgrind": version,
        "example_build": native.get("build", {}),
        "scenario": name,
        "seed": seed,
        "steps": steps,
        "mips": MIPS,
        "runs": args.runs,
        "instrumented_wall_s": wall,
        "max_relative_difference_between_runs": spread,
        "methods": runs[0]["methods"],
        "setup_memory_bytes": setup_memory(native),
    }
    _print(result)
    write_json(args.json, result)
    return 0


def setup_memory(flight: dict[str, Any]) -> dict[str, Any] | None:
    """The heap memory each component keeps after its set-up, from the example's JSON (bytes, the blocks' usable
    sizes: ``{"retained", "peak"}`` per component, the shared ones and each method's) and the component that
    keeps the most (``largest``); None when the example did not count (no glibc, or a sanitizer build)."""
    shared = flight.get("setup_memory_bytes")
    if not flight.get("allocations_counted") or shared is None:
        return None
    parts = {f"shared {name}": m for name, m in shared.items() if m is not None}
    for method, f in flight["methods"].items():
        parts.update({f"{method} {name}": m for name, m in f["setup_memory_bytes"].items() if m is not None})
    largest = max(parts, key=lambda name: parts[name]["retained"])
    return {
        "shared": shared,
        "methods": {method: f["setup_memory_bytes"] for method, f in flight["methods"].items()},
        "largest": {"component": largest, **parts[largest]},
    }


def _print(result: dict[str, Any]) -> None:
    print(f"instructions per step, {result['scenario']} ({result['steps']} steps); ms on a {MIPS:.0f} MIPS processor")
    print(f"{'method':7s} {'component':11s} {'median':>10s} {'p99':>10s} {'max':>10s}   {'ms median':>9s} {'ms max':>7s}")
    for method, m in result["methods"].items():
        rows = [*m["components"].items(), ("onboard", m["onboard"])]
        for component, c in rows:
            print(
                f"{method:7s} {component:11s} {c['median']:10.4g} {c['p99']:10.4g} {c['max']:10.4g}   "
                f"{_ms(c['median']):9.3f} {_ms(c['max']):7.2f}"
            )
        w = m["components"]["controller"]["worst"]
        print(
            f"        worst controller step k={w['step']}: {w['scp_iterations']} SCP iterations, "
            f"{w['active_set_solves']} active-set solves with {w['active_set_iterations']} factorisations "
            f"({w['active_set_failures']} failed tries), {w['qp_iterations']} PIQP iterations, "
            f"{w['model_evaluations']} nodes discretised, {w['gravity_evaluations']} gravity evaluations "
            f"({100 * w['gravity_instructions'] / w['instructions']:.0f} % of its instructions), LDL^T "
            f"{100 * w['ldlt_instructions'] / w['instructions']:.0f} %"
        )
        if "abort" in m:
            a = m["abort"]
            d, b = a["descent_controller"], a["abort_controller"]
            print(
                f"        safe abort ({a['cause']}) at k={a['entered_at_step']}: controller step median / max "
                f"{d['median']:.4g} / {d['max']:.4g} supervised descent, {b['median']:.4g} / {b['max']:.4g} abort"
            )
    memory = result["setup_memory_bytes"]
    if memory is not None:
        big = memory["largest"]
        print(
            f"set-up memory kept, the largest: {big['component']} {big['retained'] / 1e6:.3g} MB "
            f"(peak {big['peak'] / 1e6:.3g} MB)"
        )
    print(
        f"largest relative difference between the {result['runs']} runs: "
        f"{result['max_relative_difference_between_runs']:.2g}"
    )
