"""The cost of one campaign run (issue #41): core-seconds and instructions.

Two figures per scenario and method set:

- **Core-seconds per campaign run**: the scenario built and the designs shared once, as ``tubempc montecarlo``
  does, a first run to warm the process, then ``--runs`` runs of the campaign's run function (every method with
  one seed, the run's dispersions, its store output), each timed by the process's CPU clock (all its threads)
  and by the wall clock.
- **Instructions of a whole C++ run** (with valgrind and the C++ example ``examples/cpp/closed_loop``): the
  scenario exported with its configured seed (``disturbance.seed``, as ``tubempc run``) and flown by the example
  under callgrind from start to end, one method at a time; the total and the inclusive instructions of the truth's
  propagation, the polyhedral gravity (truth and controller), the controller's steps and set-up, the navigation
  and the actuation (callgrind_annotate). The instrumented flight must end where the native one does, to the bit.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from ..results.machine import machine_info
from ..testing.examples import find_example
from . import write_json

DESCRIPTION = "cost of one campaign run: core-seconds per run, and instructions of a whole C++ run (callgrind)"

#: Groups of the whole run's instructions: name -> demangled function-name prefixes (inclusive counts, summed;
#: the prefixes of a group never call each other).
GROUPS: dict[str, tuple[str, ...]] = {
    "truth_propagation": ("tubempc::dynamics::propagate(tubempc::dynamics::ProximityModel const&, double,",),
    "polyhedral_gravity": (
        "tubempc::gravity::PolyhedronGravity::evaluate(",
        "tubempc::gravity::PolyhedronGravity::acceleration(",
    ),
    "controller_steps": ("tubempc::control::Controller::step(", "tubempc::control::SafeAbort::step("),
    "controller_setup": ("tubempc::control::Controller::setup(",),
    "navigation": ("tubempc::nav::NavigationSystem::step(", "tubempc::nav::NavigationSystem::initialize("),
    "actuation": ("tubempc::actuators::ActuationSystem::step(",),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--config", help="scenario TOML (default: the packaged paper scenario)")
    source.add_argument("--scenario", help="a packaged scenario by name (e.g. bennu-tag-nav)")
    parser.add_argument("--method", choices=[*_core.control.Method.names(), "both"], default="both", help="default both")
    parser.add_argument("--runs", type=int, default=10, help="campaign runs timed after the warm-up (default 10)")
    parser.add_argument("--seed", type=int, default=1, help="the campaign's master seed (default 1)")
    parser.add_argument("--no-instructions", action="store_true", help="skip the instructions of the C++ run")
    parser.add_argument("--example", type=Path, help="the closed_loop binary (default: the newest build's)")
    parser.add_argument("--out", type=Path, help="folder for the exported scenario and the profiles (default: temporary)")
    parser.add_argument("--cache-dir", type=Path, help="reference-trajectory cache (default: OUT/cache)")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")


def core_seconds(cfg: Any, methods: tuple[str, ...], runs: int, master_seed: int, cache_dir: Path) -> dict[str, Any]:
    """Core-seconds and wall seconds of ``runs`` campaign runs after a warm-up run (figures per run)."""
    from ..analysis.campaign import run_seed
    from ..analysis.studies import campaign_run_output, fly_campaign_run
    from ..design.library import adopt_shared_designs, shared_designs
    from ..scenario.build import build_scenario

    started = time.perf_counter()
    scn = build_scenario(cfg, cache_dir=cache_dir)
    adopt_shared_designs(scn, shared_designs(scn, methods))
    setup_s = time.perf_counter() - started

    def fly(index: int) -> tuple[float, float]:
        cpu, wall = time.process_time(), time.perf_counter()
        flown, records = fly_campaign_run(cfg, scn, methods, None, 1, run_seed(master_seed, index))
        campaign_run_output(flown, records)
        return time.process_time() - cpu, time.perf_counter() - wall

    first = fly(0)
    timed = np.array([fly(i) for i in range(1, runs + 1)])
    return {
        "methods": list(methods),
        "runs": runs,
        "campaign_setup_s": setup_s,
        "first_run_core_s": first[0],
        "core_s_per_run": {
            "mean": float(timed[:, 0].mean()),
            "min": float(timed[:, 0].min()),
            "max": float(timed[:, 0].max()),
        },
        "wall_s_per_run": {
            "mean": float(timed[:, 1].mean()),
            "min": float(timed[:, 1].min()),
            "max": float(timed[:, 1].max()),
        },
    }


# "  1,234 (12.3%)  file:function(args) [object]": the count and the function (its file prefix removed)
_ANNOTATE_LINE = re.compile(r"^\s*([\d,]+)\s+(?:\([^)]*\)\s+)?(.*?)\s*(?:\[[^\]]*\])?\s*$")
_FILE_PREFIX = re.compile(r"^[^:\s]*:(?!:)")


def annotate_groups(profile: Path) -> dict[str, int]:
    """The total and the GROUPS' inclusive instructions of a callgrind profile (callgrind_annotate)."""
    annotate = shutil.which("callgrind_annotate")
    if annotate is None:
        raise SystemExit("bench runcost needs callgrind_annotate (Debian: valgrind)")
    text = subprocess.run(
        [annotate, "--inclusive=yes", "--threshold=100", str(profile)], capture_output=True, text=True, check=True
    ).stdout
    try:
        return annotated_groups(text)
    except ValueError as exc:
        raise RuntimeError(f"{profile}: {exc}") from exc


def annotated_groups(text: str) -> dict[str, int]:
    """The total and the GROUPS' inclusive instructions in callgrind_annotate's ``--inclusive=yes`` output."""
    out = dict.fromkeys(GROUPS, 0)
    total = None
    for line in text.splitlines():
        if "PROGRAM TOTALS" in line:
            total = int(line.split()[0].replace(",", ""))
            continue
        m = _ANNOTATE_LINE.match(line)
        if m is None:
            continue
        count, name = int(m.group(1).replace(",", "")), _FILE_PREFIX.sub("", m.group(2), count=1)
        for group, prefixes in GROUPS.items():
            if any(name.startswith(p) for p in prefixes):
                out[group] += count
    if total is None:
        raise ValueError("callgrind_annotate printed no PROGRAM TOTALS")
    return {"total": total, **out}


def instructions(
    cfg: Any, name: str, methods: tuple[str, ...], seed: int, example: Path, out: Path, cache_dir: Path
) -> dict[str, Any]:
    """Instructions of the whole C++ run of each method (the example under callgrind from start to end)."""
    from ..results.export import export_scenario
    from .instructions import fly_example, run_disturbance

    valgrind = shutil.which("valgrind")
    if valgrind is None:
        raise SystemExit("bench runcost needs valgrind on PATH (Debian: apt-get install valgrind), or --no-instructions")
    scenario = export_scenario(cfg, out / "scenario", cache_dir=cache_dir, seed=seed)
    steps = int(_core.io.read_scenario(str(scenario)).mission_steps)
    w_path = out / "disturbance.txt"
    np.savetxt(w_path, run_disturbance(cfg, seed, steps), fmt="%.17g")
    result: dict[str, Any] = {
        "valgrind": subprocess.run([valgrind, "--version"], capture_output=True, text=True, check=True).stdout.strip(),
        "scenario": name,
        "seed": seed,
        "steps": steps,
        "methods": {},
    }
    procs = []
    for method in methods:  # side by side: callgrind is single-threaded
        flight = [str(example), str(scenario), "--method", method, "--disturbance", str(w_path)]
        native = fly_example([*flight, "--json", str(out / f"native_{method}.json")], out / f"native_{method}.json")
        cmd = [valgrind, "--tool=callgrind", f"--callgrind-out-file={out / f'callgrind_{method}.out'}", *flight]
        cmd += ["--json", str(out / f"instrumented_{method}.json")]
        procs.append(
            (method, native, cmd, subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True))
        )
    for method, native, cmd, proc in procs:
        log, _ = proc.communicate()
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} exited with {proc.returncode}:\n{log}")
        ins = json.loads((out / f"instrumented_{method}.json").read_text(encoding="utf-8"))["methods"][method]
        nat = native["methods"][method]
        if ins["final_state"] != nat["final_state"]:
            raise RuntimeError(f"{method}: the instrumented flight ends elsewhere than the native one")
        groups = annotate_groups(out / f"callgrind_{method}.out")
        result["methods"][method] = {**groups, "per_step": groups["total"] / steps}
    return result


def run(args: argparse.Namespace) -> int:
    from ..config import load_config

    if args.runs < 1:
        raise SystemExit("bench runcost: --runs must be >= 1")
    info = machine_info()
    cfg = load_config(args.config, scenario=args.scenario)
    name = args.scenario or (Path(args.config).stem if args.config else "bennu-paper")
    methods = tuple(_core.control.Method.names()) if args.method == "both" else (args.method,)
    out: Path = args.out or Path(tempfile.mkdtemp(prefix="tubempc_bench_runcost_"))
    out.mkdir(parents=True, exist_ok=True)
    cache_dir = args.cache_dir or out / "cache"
    print(f"machine: {info['cpu']} ({info['cores']} cores); scenario {name}, methods {', '.join(methods)}")
    result: dict[str, Any] = {"machine": info, "scenario": name, "config": cfg.to_dict()}
    result["campaign_run"] = cs = core_seconds(cfg, methods, args.runs, args.seed, cache_dir)
    print(
        f"campaign run ({cs['runs']} runs after a warm-up): {cs['core_s_per_run']['mean']:.3f} core-s "
        f"(min {cs['core_s_per_run']['min']:.3f}), {cs['wall_s_per_run']['mean']:.3f} s wall per run"
    )
    if not args.no_instructions:
        example = find_example(args.example)
        seed = cfg.disturbance.seed  # a scenario file's seeds are at most 2^53: the configured run's
        result["cpp_run"] = ir = instructions(cfg, name, methods, seed, example, out, cache_dir)
        for method, row in ir["methods"].items():
            parts = ", ".join(f"{g} {row[g] / row['total']:.0%}" for g in GROUPS)
            print(f"C++ run, {method}: {row['total']:.3g} instructions ({row['per_step']:.3g} per step); {parts}")
    write_json(args.json, result)
    return 0
