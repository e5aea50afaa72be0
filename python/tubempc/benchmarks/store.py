"""The campaign store (tubempc.results.campaign_store) at scale: one real run of a scenario flown as a
campaign flies it, then ``--runs`` synthetic runs made from it (every float of its result and arrays
scaled by its own random factor 1 + 1e-3 u, u uniform in [-1, 1], for every run: runs as different in
their low bits as flown ones) written through the store's writer as a campaign writes them; the write time per run (parts,
merges and the final merge included), the bytes per run of each table, the files left, and the read
times: the runs table whole, every per-step array of one method, and one run alone (its row and arrays,
as a re-flight reads them)."""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..results.campaign_store import CampaignStore, CampaignStoreWriter, RunOutput, RunRow
from ..results.machine import machine_info
from . import write_json

DESCRIPTION = "campaign store: write and read time and bytes per run for synthetic runs made from a real one"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", default="bennu-tag-nav", help="the packaged scenario of the real run")
    parser.add_argument("--method", default="ffa", help="the method(s) flown: tbmpc, ffa or both")
    parser.add_argument("--runs", type=int, default=10_000, help="synthetic runs written (default 10^4)")
    parser.add_argument("--out", type=Path, help="keep the store in this folder (default: a temporary one)")
    parser.add_argument("--json", type=Path, default=None, help="write the figures to this JSON file")


def _perturbed(value: Any, rng: np.random.Generator) -> Any:
    if isinstance(value, Mapping):
        return {k: _perturbed(v, rng) for k, v in value.items()}
    if isinstance(value, list):
        return [_perturbed(v, rng) for v in value]
    if isinstance(value, np.ndarray):
        if value.dtype.kind == "f":
            return (value * (1.0 + 1e-3 * rng.uniform(-1.0, 1.0, value.shape))).astype(value.dtype)
        return value
    if isinstance(value, float):
        return value * (1.0 + 1e-3 * float(rng.uniform(-1.0, 1.0)))
    return value


def _size(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.glob("*.parquet"))


def run(args: argparse.Namespace) -> int:
    from ..analysis.studies import campaign_run_output, fly_campaign_run
    from ..config import load_config
    from ..scenario.build import METHODS, build_scenario

    if args.runs < 1:
        raise ValueError(f"--runs must be >= 1, got {args.runs}")
    methods = tuple(METHODS) if args.method == "both" else (args.method,)
    info = machine_info()
    print(f"machine: {info['cpu']} ({info['cores']} cores)")
    cfg = load_config(scenario=args.scenario)
    tmp = Path(tempfile.mkdtemp(prefix="tubempc-store-"))
    out = args.out or tmp / "campaign"
    try:
        scn = build_scenario(cfg, cache_dir=tmp / "cache")
        t0 = time.perf_counter()
        flown, records = fly_campaign_run(cfg, scn, methods, None, 1, 0)
        fly_s = time.perf_counter() - t0
        template = campaign_run_output(flown, records)
        steps_per_run = {m: {k: list(v.shape) for k, v in a.items()} for m, a in template.steps.items()}
        print(f"one real run of {args.scenario} ({', '.join(methods)}) flown in {fly_s:.2f} s; writing {args.runs} runs")
        rng = np.random.default_rng(1)
        if out.exists():
            shutil.rmtree(out)
        write_s = 0.0  # the writer's time only, not the making of the runs
        w = CampaignStoreWriter(out)
        for i in range(args.runs):
            output = RunOutput(_perturbed(template.result, rng), _perturbed(dict(template.steps), rng))
            t0 = time.perf_counter()
            w.add(RunRow(i, 1000 + i, True, 1.0, output))
            write_s += time.perf_counter() - t0
        t0 = time.perf_counter()
        w.close()
        write_s += time.perf_counter() - t0
        runs_dir, steps_dir = out / "store" / "runs", out / "store" / "steps"
        runs_bytes, steps_bytes = _size(runs_dir), _size(steps_dir)
        files = len(list(runs_dir.glob("*.parquet"))) + len(list(steps_dir.glob("*.parquet")))
        t0 = time.perf_counter()
        store = CampaignStore(out)
        table = store.runs()
        read_runs_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        rows = sum(t.num_rows for m in methods for t in store.iter_steps(m))
        read_steps_s = time.perf_counter() - t0
        one = args.runs // 2
        t0 = time.perf_counter()
        alone = CampaignStore(out)
        alone.row(one)
        arrays = alone.steps(one)
        read_one_s = time.perf_counter() - t0
        assert table.num_rows == args.runs and all(arrays[m] for m in methods)
        result = {
            "scenario": args.scenario,
            "methods": list(methods),
            "runs": args.runs,
            "runs_columns": table.num_columns,
            "steps_rows": rows,
            "step_arrays": steps_per_run,
            "real_run_s": fly_s,
            "write_s_per_run": write_s / args.runs,
            "read_runs_table_s_per_run": read_runs_s / args.runs,
            "read_steps_s_per_run": read_steps_s / args.runs,
            "read_one_run_s": read_one_s,
            "runs_bytes_per_run": runs_bytes / args.runs,
            "steps_bytes_per_run": steps_bytes / args.runs,
            "files": files,
            "load_average_1min": os.getloadavg()[0],  # the machine is shared: others' processes slow the timings
            "machine": info,
        }
        print(
            f"write {1e3 * result['write_s_per_run']:.3g} ms/run; read: runs table "
            f"{1e6 * result['read_runs_table_s_per_run']:.3g} us/run, per-step arrays "
            f"{1e3 * result['read_steps_s_per_run']:.3g} ms/run, run {one} alone {1e3 * read_one_s:.3g} ms; "
            f"{result['runs_bytes_per_run']:.0f} + {result['steps_bytes_per_run']:.0f} bytes/run (runs + steps, "
            f"{table.num_columns} columns, {rows} step rows); {files} files"
        )
        write_json(args.json, result)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0
