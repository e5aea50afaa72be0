"""``tubempc run``: the closed loop of each method on a scenario, or one Monte Carlo run re-flown
(``--from-campaign``)."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from .. import _core
from . import (
    EXIT_REFLIGHT_DIFFERS,
    EXIT_USAGE,
    config_from_args,
    guarantee_status,
    parse_seed,
    plant_line,
    scenario_arguments,
)

if TYPE_CHECKING:
    from ..results.summaries import AbortSummary, NavigationSummary

DESCRIPTION = "closed-loop TBMPC and/or TBMPC-FFA on a scenario (default: the paper's)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    scenario_arguments(parser)
    parser.add_argument("--method", choices=[*_core.control.Method.names(), "both"], default="both")
    parser.add_argument(
        "--shape",
        help="shape file (OBJ, PDS v/f table, ICQ, PLY, STL) instead of the config's, with --shape-unit; "
        "a relative path is taken against the working directory",
    )
    parser.add_argument("--seed", type=parse_seed, help="disturbance seed >= 0 (default: the config's)")
    parser.add_argument("--out", default="results/run", help="output folder")
    parser.add_argument("--cache-dir", help="reference-trajectory cache (default: OUT/cache)")
    parser.add_argument("--no-figures", action="store_true")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument(
        "--from-campaign",
        metavar="DIR",
        help="re-fly one run of a Monte Carlo campaign (its configuration, seed and cut) and compare it with "
        "the campaign's record",
    )
    parser.add_argument("--index", type=int, help="with --from-campaign: the run's index")


def navigation_text(nav: NavigationSummary) -> str:
    """A run's navigation in a few words for its console line: the estimation error at touchdown, the
    average NEES with its 95 % bounds (steps taken as independent) and the landmarks per camera frame."""
    e = nav.touchdown_error
    parts = [f"|e_r| {e.position:.3g} m, |e_v| {e.velocity:.3g} m/s at touchdown"]
    if nav.nees is None:
        parts.append("no NEES")
    else:
        n = nav.nees
        parts.append(f"NEES {n.mean:.3g} {'in' if n.inside else 'NOT in'} [{n.lower:.3g}, {n.upper:.3g}] ({n.steps} steps)")
    if nav.landmarks_per_frame_mean is not None and nav.landmarks_per_frame_min is not None:
        parts.append(f"{nav.landmarks_per_frame_mean:.3g} landmarks/frame (min {nav.landmarks_per_frame_min:.3g})")
    else:
        parts.append(f"{nav.landmarks_used} landmarks")
    g = nav.max_gauge
    parts.append(f"gauge p/r {g.translation:.3g}/{g.rotation:.3g}, {nav.steps_outside_output_tube} steps above 1")
    return ", ".join(parts)


#: Control steps of one run above which ``run`` warns before starting (the default mission has 300).
LARGE_RUN_STEPS = 3000


def _refly(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..analysis.studies import refly_montecarlo_run

    given = [f"--{n.replace('_', '-')}" for n in ("config", "scenario", "shape", "seed") if getattr(args, n) is not None]
    if given or args.method != "both" or args.index is None:
        print(
            f"tubempc run --from-campaign: give --index and none of {', '.join(given) or '--config/--scenario/...'} "
            "(the campaign fixes the configuration, the seed and the methods)",
            file=sys.stderr,
        )
        return EXIT_USAGE
    cmp = refly_montecarlo_run(Path(args.from_campaign), args.index, Path(args.out))
    for m, r in cmp.methods.items():
        print(f"{m:6s} J_p={r['J_p']:.10g} J_r={r['J_r']:.10g}")
    if not cmp.equal:
        differences = ", ".join(cmp.differences)
        print(
            f"run {args.index} re-flown differs from the campaign record: {differences}: exit status "
            f"{EXIT_REFLIGHT_DIFFERS}",
            file=sys.stderr,
        )
        return EXIT_REFLIGHT_DIFFERS
    print(
        f"run {args.index} (seed {cmp.seed}) re-flown: every metric, dispersion and per-step array "
        "equals the campaign record, under the campaign's configuration hash"
    )
    print(f"results in {args.out}/ (refly.json, <method>.h5)")
    return guarantee_status({m: reasons for m, reasons in cmp.guarantee_lost.items() if reasons})


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..analysis.metrics import below_or_above
    from ..analysis.runner import aborted, guarantee_lost, run_methods

    if args.from_campaign is not None:
        return _refly(args)
    if args.index is not None:
        print("tubempc run: --index goes with --from-campaign", file=sys.stderr)
        return EXIT_USAGE
    if args.shape is not None and args.shape_unit is None:
        print(
            "tubempc run: --shape needs --shape-unit km|m (the unit of its coordinates; the configuration's "
            "asteroid.shape_unit belongs to the configuration's shape)",
            file=sys.stderr,
        )
        return EXIT_USAGE
    cfg = config_from_args(args)
    if cfg.defaulted:
        print(
            f"{cfg.source}: {len(cfg.defaulted)} fields not given, taken from the packaged paper scenario: "
            f"{', '.join(cfg.defaulted[:8])}{', ...' if len(cfg.defaulted) > 8 else ''}"
        )
        if "disturbance.growth_r" in cfg.defaulted:
            print(
                f"{cfg.source}: disturbance.growth_r not given: {cfg.disturbance.growth_r:g}, a stationary attitude "
                "disturbance inside the prior's 3-sigma ellipsoid (the paper scenario's own is 2.5; README "
                '"Your own mission")'
            )
    methods = _core.control.Method.names() if args.method == "both" else [args.method]
    seed = cfg.disturbance.seed if args.seed is None else args.seed
    if cfg.mpc.n_steps > LARGE_RUN_STEPS:
        print(
            f"warning: {cfg.mpc.n_steps} control steps per run (mpc.t_f / mpc.dt; the paper's mission has 300): "
            f"expect about {cfg.mpc.n_steps * 0.02 * len(methods) / 60:.0f} min or more and "
            f"{cfg.mpc.n_steps * cfg.mpc.horizon * 12 * 8 * len(methods) / 1e9:.1f} GB of plans; Ctrl-C stops",
            file=sys.stderr,
        )
    out = Path(args.out)
    summary = run_methods(
        cfg,
        methods,
        seed,
        out,
        shape=args.shape,
        shape_unit=args.shape_unit if args.shape is not None else None,
        progress=not args.quiet,
        cache_dir=Path(args.cache_dir) if args.cache_dir else out / "cache",
        make_figures=not args.no_figures,
    )
    ref = summary.reference
    accuracy = (
        ""
        if ref.last_subproblem == "optimal"
        else f"; its last convex subproblem solved to reduced accuracy ({ref.last_subproblem}), its solution "
        "checked against the input bounds and the dynamics"
    )
    print(f"plant: {plant_line(summary.plant)}")
    print(
        f"reference: {'converged' if ref.converged else 'NOT converged'} in {ref.iterations} SCP iterations "
        f"(dynamics defect {ref.max_defect:.2g}{accuracy})"
    )
    lost: dict[str, list[str]] = {}
    for m, s in summary.methods.items():
        st = s.step_time
        print(
            f"{m:6s} J_p={s.J_p:.4g} J_r={s.J_r:.4g} terminal |dr|={s.terminal_error.position:.3g} m "
            f"steps outside the tube {s.steps_outside_tube}, fallback steps {s.fallback_steps}, largest excursion p/r "
            f"{s.max_tube_excursion.translation:.3g}/{s.max_tube_excursion.rotation:.3g} "
            f"cone violations gs/los={s.constraint_violations.glide_slope_steps}/"
            f"{s.constraint_violations.los_steps} step median {st['step'].median_ms:.2f} ms "
            f"(tube {st['tube'].median_ms:.2f}, mpc {st['mpc'].median_ms:.2f}) run {s.run_time_s:.1f} s "
            f"states inside the body {s.states_inside_body}"
            + ("" if s.navigation is None else f"; nav: {navigation_text(s.navigation)}")
        )
        if s.abort is not None:
            print(f"{m:6s} {abort_text(s.abort)}")
        reasons = guarantee_lost(s)
        if reasons:
            lost[m] = reasons
    print("(tube excursion: e^T Pe^-1 e of the error one step after the plan; <= 1 inside the tube, > 1 outside)")
    if any(s.navigation is not None for s in summary.methods.values()):
        print(
            "(nav: e = x - x^ at the last step; NEES: the average over the steps of the 15-state NEES, against the 95 % "
            "bounds of an average of independent chi-square samples, optimistic since successive steps are "
            "correlated; gauge: the true state in z + Omega (+) E, <= 1 inside, E a probabilistic set)"
        )
    if summary.comparison is not None:
        print(f"TBMPC-FFA J_p is {below_or_above(summary.comparison.J_p_reduction_percent)} TBMPC's")
    for name, error in (summary.figure_errors or {}).items():
        print(f"figure {name} not drawn: {error}", file=sys.stderr)
    print(f"results in {out}/ (summary.json, <method>.h5, figures)")
    aborts = {m: why for m, s in summary.methods.items() if (why := aborted(s)) is not None}
    return guarantee_status(lost, aborts)


def abort_text(a: AbortSummary) -> str:
    """One line on a run's abort: landed or aborted (cause, time, safe), a refused detection, the commit time."""
    commit = "never armed" if a.commit_time is None else f"commit at {a.commit_time:g} s"
    refused = "" if a.refused_at is None else f"; {a.refused_cause} at {a.refused_at:g} s refused (committed)"
    if a.outcome == "aborted":
        return (
            f"aborted ({a.cause} at {a.entered_at:g} s, {commit}): {'safe' if a.safe else 'NOT safe'}, final height "
            f"{a.final_height:.3g} m, lowest {a.lowest_height:.3g} m, {a.abort_steps} abort steps, {a.uncertified_steps} "
            f"uncertified, largest LMI residual {a.max_residual:.2g}"
        )
    return f"landed ({commit}{refused})"
