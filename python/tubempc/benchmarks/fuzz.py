"""Fuzzing of the shape loaders, the config reader and the scenario-file reader (``tubempc.testing.fuzz``): N
mutated inputs of every format (OBJ, PDS v/f table, ICQ, PLY, STL, scenario TOML, C++ scenario file),
each read in a worker process with a time limit and classified as rejected (a clean error naming the
file), accepted (a mesh the independent check finds valid), broken mesh accepted, error without the
file, crash or hang. Prints the table and writes it with examples of every non-clean outcome to
OUT/fuzz.json. Exit code 1 when any input is neither rejected cleanly nor accepted valid.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..results.machine import machine_info

DESCRIPTION = (
    "fuzz the shape loaders, the config reader and the scenario-file reader: crashes, hangs, errors without a "
    "file, broken meshes"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--inputs", type=int, default=10_000, help="number of inputs (default 10000)")
    parser.add_argument("--seed", type=int, default=0, help="campaign seed (default 0)")
    parser.add_argument("--timeout", type=float, default=10.0, help="time limit per input in s (default 10)")
    parser.add_argument(
        "--out", type=Path, default=Path("results/bench_fuzz"), help="folder for fuzz.json (default results/bench_fuzz)"
    )
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")


def run(args: argparse.Namespace) -> int:
    from ..testing.fuzz import OUTCOMES, run_campaign, table

    if args.inputs < 1 or not args.timeout > 0:
        raise SystemExit("--inputs must be >= 1 and --timeout > 0")
    info = machine_info()
    print(f"machine: {info['cpu']} ({info['cores']} cores), Python {info['python']}")
    step = max(1, args.inputs // 20)

    def progress(done: int) -> None:
        if done % step == 0:
            print(f"  {done}/{args.inputs}", file=sys.stderr, flush=True)

    result = run_campaign(args.inputs, args.seed, args.timeout, progress=progress)
    print(
        f"tubempc bench fuzz --inputs {args.inputs} --seed {args.seed} --timeout {args.timeout}: {result.wall_time_s:.1f} s"
    )
    print(table(result))
    for example in result.examples[:10]:
        print(f"  input {example['index']} ({example['format']}): {example['outcome']}: {example['detail']}")
    figures = {
        "machine": info,
        "inputs": args.inputs,
        "seed": args.seed,
        "timeout_s": args.timeout,
        "wall_time_s": result.wall_time_s,
        "counts": {fmt: {o: c[o] for o in OUTCOMES} for fmt, c in result.counts.items()},
        "examples": result.examples,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    for path in (args.out / "fuzz.json", args.json):
        if path is not None:
            path.write_text(json.dumps(figures, indent=1))
    bad = sum(c[o] for c in result.counts.values() for o in OUTCOMES if o not in ("rejected", "accepted"))
    return 1 if bad else 0
