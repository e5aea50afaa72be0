"""Command-line interface of tubempc: fly a scenario (``run``), list and make scenarios (``scenarios``,
``make-body``), analyse (``montecarlo``, ``sweep``, ``report``), export for C++ (``export-scenario``),
benchmark (``bench NAME``) and report the build (``info``, ``--version``).

Exit status (also in the README):
  0  done; every run kept its robustness guarantee
  1  internal error (a bug: rerun with --debug and report the traceback)
  2  usage error (a bad option or value)
  3  input error: a configuration, shape or scenario that cannot be flown (the message names the file
     and field), or an output folder that cannot be written
  4  done, but a run lost a guarantee: steps outside the tube, fallback steps or states inside the body
     (see the summary); for every command that flies: run, montecarlo, sweep, run --from-campaign
  5  a campaign finished with failed runs (before 4)
  6  a re-flight (run --from-campaign) differs from its campaign's record (before 4)
  130  interrupted (Ctrl-C)
"""

from __future__ import annotations

import argparse
import importlib.metadata
import os
import platform
import sys
from collections.abc import Sequence
from typing import Any

from . import __version__, benchmarks

_PYTHON_PACKAGES = ("numpy", "scipy", "cvxpy", "clarabel", "piqp", "plotly")
EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INPUT = 0, 1, 2, 3
EXIT_GUARANTEE_LOST, EXIT_FAILED_RUNS, EXIT_REFLIGHT_DIFFERS, EXIT_INTERRUPTED = 4, 5, 6, 130
#: Control steps of one run above which ``run`` warns before starting (the default mission has 300).
LARGE_RUN_STEPS = 3000


def _so3_selfcheck(n: int = 1000, seed: int = 0) -> float:
    """Largest |log(exp(phi)) - phi| over random rotation vectors with |phi| < pi (rad)."""
    import numpy as np

    from ._core import so3

    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        axis = rng.normal(size=3)
        phi = axis / np.linalg.norm(axis) * rng.uniform(0.0, np.pi * 0.999)
        worst = max(worst, float(np.max(np.abs(so3.log_map(so3.exp_map(phi)) - phi))))
    return worst


def _cmd_info(_: argparse.Namespace) -> int:
    from ._core import build_info

    info = build_info()
    print(f"tubempc {__version__}")
    print("C++ core:")
    for key in (
        "compiler",
        "build_type",
        "cxx_flags",
        "eigen_version",
        "eigen_simd",
        "piqp_version",
        "hardware_threads",
    ):
        print(f"  {key:17s} {info[key]}")
    print(f"Python {platform.python_version()} on {platform.machine()}")
    for name in _PYTHON_PACKAGES:
        try:
            version = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            version = "not installed"
        print(f"  {name:17s} {version}")
    print(f"so3 self-check: max |log(exp(phi)) - phi| = {_so3_selfcheck():.2e} rad over 1000 rotations")
    return 0


def _config(args: argparse.Namespace) -> Any:
    """The configuration of --config FILE or --scenario NAME (default: the paper's), with --shape-unit."""
    from .config import load_config

    cfg = load_config(getattr(args, "config", None), scenario=getattr(args, "scenario", None))
    if getattr(args, "shape_unit", None) and getattr(args, "shape", None) is None:
        cfg = cfg.with_overrides({"asteroid.shape_unit": args.shape_unit})
    return cfg


def _cmd_scenarios(_: argparse.Namespace) -> int:
    import importlib.resources

    from .config import SCENARIOS

    root = importlib.resources.files("tubempc").joinpath("data")
    for name, (file, about) in SCENARIOS.items():
        print(f"{name:14s} {about}\n{'':14s} {root.joinpath(*file.split('/'))}")
    print("fly one with 'tubempc run --scenario NAME'; copy its TOML to start your own (missing fields are the paper's)")
    return 0


def _cmd_make_body(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .bodies import contact_binary_shape, ellipsoid_shape
    from .shapes import save_shape

    if args.kind == "ellipsoid":
        if args.axes is None:
            raise ValueError("make-body ellipsoid: --axes a,b,c (semi-axes, m) is required")
        shape = ellipsoid_shape(args.axes, args.subdivisions, args.roughness, args.seed)
    else:
        if args.body_axes is None or args.head_axes is None or args.separation is None:
            raise ValueError("make-body contact-binary: --body-axes, --head-axes and --separation are required")
        shape = contact_binary_shape(
            args.body_axes, args.head_axes, args.separation, args.subdivisions, args.roughness, args.seed
        )
    out = Path(args.out)
    save_shape(out, shape, unit="m")
    extent = shape.vertices.max(axis=0) - shape.vertices.min(axis=0)
    print(
        f"wrote {out}: {len(shape.faces)} faces, extent {extent[0]:.1f} x {extent[1]:.1f} x {extent[2]:.1f} m, "
        f'volume {shape.volume:.4g} m^3 (OBJ in metres: asteroid.shape_unit = "m")'
    )
    return 0


def _cmd_repair_shape(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .shapes import load_shape, save_shape

    before = load_shape(Path(args.file), unit=args.unit, repair=True)
    out = Path(args.out)
    save_shape(out, before, unit="m")
    print(
        f"wrote {out}: {len(before.faces)} faces, {before.n_flipped_faces} flipped to a consistent outward orientation, "
        f'volume {before.volume:.4g} m^3 (OBJ in metres: asteroid.shape_unit = "m")'
    )
    return EXIT_OK


def _cmd_refly(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .analysis import refly_montecarlo_run

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
        f"run {args.index} (seed {cmp.seed}) re-flown: every metric, dispersion and array (runs/run_*.npz) "
        "equals the campaign record, under the campaign's configuration hash"
    )
    print(f"results in {args.out}/ (refly.json, <method>.h5)")
    return _guarantee_status({m: reasons for m, reasons in cmp.guarantee_lost.items() if reasons})


def _guarantee_status(lost: dict[str, list[str]]) -> int:
    """EXIT_GUARANTEE_LOST (said on stderr) if any run lost a guarantee, else EXIT_OK."""
    if not lost:
        return EXIT_OK
    what = "; ".join(f"{name}: {', '.join(reasons)}" for name, reasons in lost.items())
    print(f"robustness guarantee lost by {what}: exit status {EXIT_GUARANTEE_LOST}", file=sys.stderr)
    return EXIT_GUARANTEE_LOST


def _cmd_run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .metrics import below_or_above
    from .runner import guarantee_lost, run_methods

    if args.from_campaign is not None:
        return _cmd_refly(args)
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
    cfg = _config(args)
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
    methods = ["tbmpc", "ffa"] if args.method == "both" else [args.method]
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
        )
        reasons = guarantee_lost(s)
        if reasons:
            lost[m] = reasons
    print("(tube excursion: e^T Pe^-1 e of the error one step after the plan; <= 1 inside the tube, > 1 outside)")
    if summary.comparison is not None:
        print(f"TBMPC-FFA J_p is {below_or_above(summary.comparison.J_p_reduction_percent)} TBMPC's")
    for name, error in (summary.figure_errors or {}).items():
        print(f"figure {name} not drawn: {error}", file=sys.stderr)
    print(f"results in {out}/ (summary.json, <method>.h5, figures)")
    return _guarantee_status(lost)


def _cmd_export_scenario(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .export import export_scenario, read_scenario

    path = export_scenario(_config(args), Path(args.out), cache_dir=Path(args.cache_dir) if args.cache_dir else None)
    scn = read_scenario(str(path))  # the C++ reader validates what was written
    print(
        f"wrote {path} (T = {scn.mission_steps} steps, N = {scn.settings.horizon}) with "
        f"{', '.join(sorted({scn.model.shape, scn.truth.shape}))} and config.toml"
    )
    return 0


def _floats(text: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from exc


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from exc
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def _ints(text: str) -> list[int]:
    try:
        return [int(v) for v in text.split(",") if v.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from exc


def _cmd_montecarlo(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .analysis import montecarlo
    from .metrics import below_or_above

    methods = ("tbmpc", "ffa") if args.method == "both" else (args.method,)
    s = montecarlo(
        _config(args),
        args.runs,
        Path(args.out),
        master_seed=args.seed,
        workers=args.workers,
        scheduler=args.scheduler,
        methods=methods,
        retry_failed=args.retry_failed,
        only=args.only,
        progress=not args.quiet,
    )
    for m, row in s.methods.items():
        print(
            f"{m:6s} J_p mean {row.J_p.mean:.4g} (3 sigma {row.J_p.three_sigma:.3g})  "
            f"J_r mean {row.J_r.mean:.4g} (3 sigma {row.J_r.three_sigma:.3g})  "
            f"runs outside the tube {row.runs_outside_tube}/{s.runs}"
        )
    if s.J_p_mean_reduction_percent is not None:
        print(f"TBMPC-FFA mean J_p is {below_or_above(s.J_p_mean_reduction_percent)} TBMPC's")
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
    return _guarantee_status(lost)


def _cmd_sweep(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .analysis import sweep
    from .claims import holding_floor
    from .runner import guarantee_lost

    s = sweep(_config(args), args.lambda_p, args.lambda_r, Path(args.out), seed=args.seed, progress=not args.quiet)
    print(f"{'':40s} {'J_p':>8s} {'J_r':>8s} {'|dr(T)| m':>10s} {'RMS r m':>9s} {'outside':>8s} {'tube feasible':>14s}")
    for name, row in s.rows.items():
        feasible = (
            "every step"
            if row.tube_feasible_every_step
            else f"no: {row.tube_design_failures} designs failed, {row.tube_uncertified_steps} steps uncertified"
        )
        print(
            f"{name:40s} {row.J_p:8.4g} {row.J_r:8.4g} {row.terminal_error.position:10.3g} "
            f"{row.rms_error.position:9.3g} {row.steps_outside_tube:8d} {feasible:>14s}"
        )
    smallest = s.smallest_feasible_lambda_p
    print(f"smallest lambda_p with a feasible tube at every step: {smallest if smallest is not None else 'none'}")
    floor = holding_floor(s.ffa_rows)
    print(f"the tube holds (feasible, never left) for every lambda_p swept >= {floor if floor is not None else 'none'}")
    print(f"{args.out}/sweep.json and figures")
    return _guarantee_status({name: reasons for name, row in s.rows.items() if (reasons := guarantee_lost(row))})


def _cmd_report(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .report import write_report

    html, md = write_report(Path(args.dir))
    print(f"{html}\n{md}")
    return 0


def _scenario_arguments(p: argparse.ArgumentParser) -> None:
    group = p.add_mutually_exclusive_group()
    group.add_argument("--config", help="scenario TOML (fields left out are the paper scenario's)")
    group.add_argument("--scenario", help="a packaged scenario by name (see 'tubempc scenarios'; default: bennu-paper)")
    p.add_argument(
        "--shape-unit",
        choices=["km", "m"],
        help="unit of the coordinates of --shape (required with it), else of the config's shape file",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="tubempc", description=__doc__)
    parser.add_argument("--version", action="version", version=f"tubempc {__version__}")
    parser.add_argument("--debug", action="store_true", help="show the traceback of an error")
    sub = parser.add_subparsers(dest="command", required=True)
    p_info = sub.add_parser("info", help="report the core's build and the Python dependencies")
    p_info.set_defaults(func=_cmd_info)
    p_sc = sub.add_parser("scenarios", help="list the packaged scenarios")
    p_sc.set_defaults(func=_cmd_scenarios)
    p_body = sub.add_parser("make-body", help="generate a small-body shape (OBJ in metres) for your own mission")
    p_body.add_argument("kind", choices=["ellipsoid", "contact-binary"])
    p_body.add_argument("--axes", type=_floats, help="ellipsoid: semi-axes a,b,c (m)")
    p_body.add_argument("--body-axes", type=_floats, help="contact binary: the larger lobe's semi-axes (m)")
    p_body.add_argument("--head-axes", type=_floats, help="contact binary: the smaller lobe's semi-axes (m)")
    p_body.add_argument("--separation", type=float, help="contact binary: distance of the lobes' centres (m)")
    p_body.add_argument("--subdivisions", type=int, default=12, help="geodesic resolution n (20 n^2 faces)")
    p_body.add_argument("--roughness", type=float, default=0.0, help="relative surface roughness in [0, 0.5)")
    p_body.add_argument("--seed", type=int, default=0, help="roughness seed")
    p_body.add_argument("--out", required=True, help="OBJ file to write")
    p_body.set_defaults(func=_cmd_make_body)
    p_fix = sub.add_parser(
        "repair-shape", help="orient a shape's faces consistently outward and write it as an OBJ in metres"
    )
    p_fix.add_argument("file", help="shape file (OBJ, PDS v/f table, ICQ, PLY, STL)")
    p_fix.add_argument("--unit", choices=["km", "m"], required=True, help="unit of the file's coordinates")
    p_fix.add_argument("--out", required=True, help="OBJ file to write (metres)")
    p_fix.set_defaults(func=_cmd_repair_shape)
    p_run = sub.add_parser("run", help="closed-loop TBMPC and/or TBMPC-FFA on a scenario (default: the paper's)")
    _scenario_arguments(p_run)
    p_run.add_argument("--method", choices=["tbmpc", "ffa", "both"], default="both")
    p_run.add_argument(
        "--shape",
        help="shape file (OBJ, PDS v/f table, ICQ, PLY, STL) instead of the config's, with --shape-unit; "
        "a relative path is taken against the working directory",
    )
    p_run.add_argument("--seed", type=_seed, help="disturbance seed >= 0 (default: the config's)")
    p_run.add_argument("--out", default="results/run", help="output folder")
    p_run.add_argument("--cache-dir", help="reference-trajectory cache (default: OUT/cache)")
    p_run.add_argument("--no-figures", action="store_true")
    p_run.add_argument("--quiet", action="store_true", help="no progress bar")
    p_run.add_argument(
        "--from-campaign",
        metavar="DIR",
        help="re-fly one run of a Monte Carlo campaign (its configuration, seed and cut) and compare it with "
        "the campaign's record",
    )
    p_run.add_argument("--index", type=int, help="with --from-campaign: the run's index")
    p_run.set_defaults(func=_cmd_run)
    p_exp = sub.add_parser(
        "export-scenario", help="write the closed loop's scenario file for C++ programs (examples/cpp/closed_loop)"
    )
    _scenario_arguments(p_exp)
    p_exp.add_argument("--out", required=True, help="output folder (scenario.txt, shape.obj, config.toml)")
    p_exp.add_argument("--cache-dir", help="reference-trajectory cache (default: none)")
    p_exp.set_defaults(func=_cmd_export_scenario)
    p_mc = sub.add_parser("montecarlo", help="resumable Monte Carlo campaign of both methods (paper Table 4)")
    p_mc.add_argument("--runs", type=int, default=100)
    p_mc.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    p_mc.add_argument("--scheduler", help="Dask scheduler address (tcp://host:port) instead of local processes")
    p_mc.add_argument("--out", default="results/montecarlo")
    _scenario_arguments(p_mc)
    p_mc.add_argument("--seed", type=_seed, default=0, help="master seed >= 0")
    p_mc.add_argument("--method", choices=["tbmpc", "ffa", "both"], default="both")
    p_mc.add_argument("--retry-failed", action="store_true", help="rerun the runs recorded as failed")
    p_mc.add_argument("--only", type=_ints, help="rerun just these run indices (comma-separated)")
    p_mc.add_argument("--quiet", action="store_true")
    p_mc.set_defaults(func=_cmd_montecarlo)
    p_sw = sub.add_parser("sweep", help="forgetting-factor sweep (paper Table 3, Figures 15-16)")
    p_sw.add_argument("--lambda-p", type=_floats, default=[0.96, 0.97, 0.98])
    p_sw.add_argument("--lambda-r", type=_floats, help="one per --lambda-p value (default: the config's)")
    p_sw.add_argument("--out", default="results/sweep")
    _scenario_arguments(p_sw)
    p_sw.add_argument("--seed", type=_seed, default=0, help="disturbance seed >= 0")
    p_sw.add_argument("--quiet", action="store_true")
    p_sw.set_defaults(func=_cmd_sweep)
    p_rep = sub.add_parser("report", help="HTML and Markdown report of a results folder")
    p_rep.add_argument("dir", help="folder with summary.json (run), sweep/ and montecarlo/ sub-folders if present")
    p_rep.set_defaults(func=_cmd_report)
    p_bench = sub.add_parser("bench", help="run a benchmark ('tubempc bench NAME -h' for its options)")
    p_bench.add_argument("benchmark", choices=benchmarks.available())
    p_bench.add_argument("options", nargs=argparse.REMAINDER, help="the benchmark's options")
    p_bench.set_defaults(func=_cmd_bench)
    return parser


def _cmd_bench(args: argparse.Namespace) -> int:
    """Imports the benchmark only when it runs (so that the command line starts at once)."""
    module = benchmarks.load(args.benchmark)
    parser = argparse.ArgumentParser(prog=f"tubempc bench {args.benchmark}", description=module.DESCRIPTION)
    module.add_arguments(parser)
    return int(module.run(parser.parse_args(args.options)))


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command line; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        print("tubempc: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (ValueError, OSError) as exc:  # ConfigError, ShapeError, ScenarioError; unreadable or unwritable paths
        if args.debug:
            raise
        print(f"tubempc: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except Exception as exc:
        if args.debug:
            raise
        print(
            f"tubempc: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback)", file=sys.stderr
        )
        return EXIT_INTERNAL


def _release_semaphores() -> None:
    """Unlinks the named semaphores of this process's multiprocessing locks and queues, whose finalisers
    os._exit skips: the resource tracker then has none to report as leaked on Ctrl-C. Only the
    semaphores' finalisers run (no join of a process or thread)."""
    try:
        from multiprocessing import synchronize, util

        registry: dict[Any, Any] = getattr(util, "_finalizer_registry", {})
        for finalizer in list(registry.values()):
            if getattr(finalizer, "_callback", None) is synchronize.SemLock._cleanup:  # type: ignore[attr-defined]
                finalizer()
    except Exception:  # best effort on the way out: never turn Ctrl-C into an error
        return


def entry_point() -> None:
    """Console script: exits with main()'s status, at once on Ctrl-C (a running LMI or QP solve in a
    worker thread or the design process is not waited for; results already written stay)."""
    try:
        status = main()
    except KeyboardInterrupt:
        status = EXIT_INTERRUPTED
    policy = sys.modules.get("tubempc.tube_policy")  # imported only if a run used it
    if policy is not None:
        policy.shutdown_design_worker(wait=status != EXIT_INTERRUPTED)
    if status == EXIT_INTERRUPTED:
        _release_semaphores()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


if __name__ == "__main__":
    entry_point()
