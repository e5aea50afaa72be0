"""``tubempc montecarlo``: a resumable Monte Carlo campaign (paper Table 4) with its failure bounds."""

from __future__ import annotations

import argparse
import sys

from .. import _core
from . import (
    EXIT_FAILED_RUNS,
    config_from_args,
    guarantee_status,
    parse_floats,
    parse_ints,
    parse_seed,
    plant_line,
    scenario_arguments,
)

DESCRIPTION = "resumable Monte Carlo campaign of both methods (paper Table 4) with failure bounds"


def _positive_int(text: str) -> int:
    value = parse_seed(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def _confidence(text: str) -> float:
    try:
        value = float(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), got {text!r}") from exc
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), got {value}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--runs", type=_positive_int, default=100)
    parser.add_argument("--workers", type=_positive_int, help="local worker processes (default: all cores)")
    parser.add_argument(
        "--scheduler",
        help="address of a running Dask scheduler (tcp://host:port, e.g. started by `dask scheduler`) whose workers "
        "fly the runs instead of local processes",
    )
    parser.add_argument(
        "--batch-size",
        type=_positive_int,
        help="runs per worker task (default: about 8 tasks per worker, at most 64 runs)",
    )
    parser.add_argument("--out", default="results/montecarlo")
    scenario_arguments(parser)
    parser.add_argument("--seed", type=parse_seed, default=0, help="master seed >= 0")
    parser.add_argument("--method", choices=[*_core.control.Method.names(), "both"], default="both")
    parser.add_argument("--retry-failed", action="store_true", help="rerun the runs recorded as failed")
    parser.add_argument("--only", type=parse_ints, help="rerun just these run indices (comma-separated)")
    parser.add_argument(
        "--confidence",
        type=_confidence,
        default=0.95,
        help="confidence of the failure bounds (Clopper-Pearson) and percentile intervals (default 0.95)",
    )
    parser.add_argument(
        "--percentiles",
        type=parse_floats,
        default=None,
        help="percentiles (%%) of each metric with confidence intervals (comma-separated; default 50,90,99)",
    )
    parser.add_argument("--quiet", action="store_true")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..analysis.metrics import below_or_above
    from ..analysis.statistics import DEFAULT_PERCENTILES, describe_bound
    from ..analysis.studies import montecarlo

    methods = tuple(_core.control.Method.names()) if args.method == "both" else (args.method,)
    s = montecarlo(
        config_from_args(args),
        args.runs,
        Path(args.out),
        master_seed=args.seed,
        workers=args.workers,
        scheduler=args.scheduler,
        batch_size=args.batch_size,
        methods=methods,
        retry_failed=args.retry_failed,
        only=args.only,
        progress=not args.quiet,
        confidence=args.confidence,
        percentiles=tuple(args.percentiles or DEFAULT_PERCENTILES),
    )
    print(f"plant: {plant_line(s.plant)}")
    for m, row in s.methods.items():
        print(
            f"{m:6s} J_p mean {row.J_p.mean:.4g} (3 sigma {row.J_p.three_sigma:.3g})  "
            f"J_r mean {row.J_r.mean:.4g} (3 sigma {row.J_r.three_sigma:.3g})  "
            f"runs outside the tube {row.runs_outside_tube}/{s.runs}"
        )
    if s.J_p_mean_reduction_percent is not None:
        print(f"TBMPC-FFA mean J_p is {below_or_above(s.J_p_mean_reduction_percent)} TBMPC's")
    st = s.statistics
    if st is not None:
        print(f"failure probabilities, one-sided Clopper-Pearson upper bounds at {100 * st.confidence:g} % confidence:")
        print(f"  failed run: {describe_bound(st.failed_run, st.confidence)}")
        for m, ms in st.methods.items():
            for kind, b in ms.failures.items():
                print(f"  {m} {kind}: {describe_bound(b, st.confidence)}")
        for m, ms in st.methods.items():
            jp = ms.metrics.get("J_p")
            if jp is None or not jp.worst:
                continue
            w = jp.worst[0]
            driver = (
                f"{jp.drivers[0].dispersion} (Spearman {jp.drivers[0].rho:+.2f}, p {jp.drivers[0].p_value:.2g})"
                if jp.drivers
                else f"- ({jp.drivers_note})"
            )
            print(f"{m:6s} worst J_p {w.value:.4g}: run {w.index} (seed {w.seed}); J_p's top driver {driver}")
    print(
        f"{s.runs} runs done ({s.executed_now} now, {len(s.failed_runs)} failed) in {s.wall_time_s:.1f} s; "
        f"{args.out}/summary.json"
    )
    if s.failed_runs:
        print(f"{len(s.failed_runs)} runs failed: exit status {EXIT_FAILED_RUNS}", file=sys.stderr)
        return EXIT_FAILED_RUNS
    lost = {
        m: [f"{row.runs_guarantee_lost}/{s.runs} runs (outside the tube, fallback steps or inside the body)"]
        for m, row in s.methods.items()
        if row.runs_guarantee_lost
    }
    return guarantee_status(lost)
