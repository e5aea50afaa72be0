"""``tubempc report DIR``: one self-contained HTML file (figures embedded) and a Markdown twin.

DIR may hold a run (``summary.json`` from ``tubempc run``, here or in ``DIR/run``), a sweep
(``sweep.json``, here or in ``DIR/sweep``) and a Monte Carlo campaign (``summary.json`` here or in
``DIR/montecarlo``); each file says its kind (:mod:`tubempc.results.summaries`). Each part states its
scenario (from the ``config.toml`` saved beside it), the reference's status, the steps outside the
tube, the fallbacks and the tube statuses. Only the paper's own scenario is set
beside the paper's values (docs/model.md "Metrics"; paper Tables 3-4). A run with thrusters and wheels
(``spacecraft.actuators`` not "ideal") is compared, method by method, with the same mission flown with ideal
actuators, the same seed, reference and input bounds (flown when the report is written). Every figure has a
caption.
"""

from __future__ import annotations

import base64
import datetime
import html
from collections.abc import Callable, Mapping
from dataclasses import fields
from pathlib import Path

from .. import __version__
from ..config import Config, ConfigError, load_config
from ..results.summaries import (
    CampaignStatistics,
    FailureBound,
    MethodResult,
    MonteCarloSummary,
    NavigationSummary,
    RunSummary,
    Summary,
    SweepSummary,
    load_summary,
)
from .claims import PAPER_REDUCTION_TABLE3, PAPER_REDUCTION_TABLE4, PAPER_TABLE3, PAPER_TABLE4, paper_claims
from .metrics import below_or_above

__all__ = ["actuation_comparison", "paper_under_physics", "write_report"]

_WHY = (
    "The paper does not publish its disturbance realisation, its truth model or its spacecraft inertia, so "
    "absolute values differ; the comparison is between the methods. Our scenario's disturbance, the exact "
    "attitude kinematics, the normalised tube weights and the input cost on the deviation from the reference "
    'are project decisions documented in docs/decisions.md ("Readings of the paper", "The paper\'s claims"); '
    "J_r in particular is dominated by the feedback torque that the simulated attitude disturbance requires."
)


#: Where a results folder may hold its summaries, in the order they are looked for.
_SUMMARY_FILES = ("summary.json", "run/summary.json", "sweep.json", "sweep/sweep.json", "montecarlo/summary.json")


def _summaries(root: Path) -> dict[str, tuple[Summary, Path]]:
    """The first summary of each kind in ``root`` (each file says its kind, tubempc.results.summaries) and its
    folder."""
    found: dict[str, tuple[Summary, Path]] = {}
    for name in _SUMMARY_FILES:
        if (root / name).exists():
            s = load_summary(root / name)
            found.setdefault(s.KIND, (s, (root / name).parent))
    return found


def _or_dash(value: int | None) -> str:
    return "-" if value is None else str(value)


def _table(header: list[str], rows: list[list[str]]) -> tuple[str, str]:
    h = "<table><tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in header) + "</tr>"
    h += "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in rows) + "</table>"
    m = "| " + " | ".join(header) + " |\n|" + "---|" * len(header) + "\n"
    m += "".join("| " + " | ".join(r) + " |\n" for r in rows)
    return h, m


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def _fmt_or_dash(v: float | None) -> str:
    return "-" if v is None else _fmt(v)


def _navigation_row(method: str, n: NavigationSummary) -> list[str]:
    """A run's navigation (its summary) as a row of the report's navigation table."""
    e = n.touchdown_error
    t = n.nees
    nees = (
        ["-", "-", "-"] if t is None else [_fmt(t.mean), f"[{_fmt(t.lower)}, {_fmt(t.upper)}]", "yes" if t.inside else "no"]
    )
    return [
        method,
        _fmt(e.position),
        _fmt(e.velocity),
        _fmt(e.attitude),
        _fmt(e.angular_velocity),
        *nees,
        str(n.landmarks_used),
        _fmt_or_dash(n.landmarks_per_frame_mean),
        _fmt_or_dash(n.landmarks_per_frame_min),
        _fmt(n.max_gauge.translation),
        _fmt(n.max_gauge.rotation),
        str(n.steps_outside_output_tube),
    ]


#: Caption of each figure file the commands write (paper figure in brackets).
CAPTIONS = {
    "fig03_trajectory": "Trajectories in the orbital frame L with the asteroid and the glide-slope cone at t_f, "
    "the reference (dotted) and predicted horizons (paper Fig. 3).",
    "fig04_states_translation": "Position and velocity of both methods against the reference (paper Fig. 4).",
    "fig05_states_rotation": "Attitude (Lie algebra) and angular velocity against the reference (paper Fig. 5).",
    "fig06_errors_translation": "Tracking errors x - zbar of position and velocity (paper Fig. 6).",
    "fig07_errors_rotation": "Tracking errors x - zbar of attitude and angular velocity (paper Fig. 7).",
    "fig08_controls": "Inputs with their limits (paper Fig. 8).",
    "fig09_disturbances_translation": "Measured exogenous inputs of position and velocity with TBMPC's fixed and "
    "TBMPC-FFA's identified 3-sigma bounds (paper Fig. 9).",
    "fig10_disturbances_rotation": "Measured exogenous inputs of attitude and angular velocity with TBMPC's fixed and "
    "TBMPC-FFA's identified 3-sigma bounds (paper Fig. 10).",
    "fig11_exceedances": "TBMPC's attitude exogenous inputs against its fixed 3-sigma bounds, the steps outside "
    "them marked (paper Fig. 11).",
    "fig12_tube": "Actual minus nominal state inside the tube's projections (paper Fig. 12).",
    "fig13_constraints": "Glide-slope and line-of-sight constraint values of the actual trajectories, feasible "
    "below 0 (paper Fig. 13).",
    "fig14_convergence_tbmpc": "TBMPC: velocity error norm and the fitted Theorem 2 envelope, or why none exists "
    "(paper Fig. 14).",
    "fig14_convergence_ffa": "TBMPC-FFA: velocity error norm and the fitted Theorem 2 envelope, or why none exists "
    "(paper Fig. 14).",
    "fig15_lambda_x": "Error of x and tube half-width against the forgetting factor (paper Fig. 15).",
    "fig16_lambda_phi": "Error of phi_x and tube half-width against the forgetting factor (paper Fig. 16).",
    "fig15_actuation": "Thruster firings, cumulative delta-v and propellant, and the wheels' momentum.",
    "fig19_navigation_errors": "Navigation: estimation error x - x^ per axis (position, velocity, attitude) with the "
    "filter's 3-sigma bounds.",
    "fig20_landmarks": "Navigation: landmarks in the last camera frame of each control period (crosses: steps whose "
    "navigation status is not ok).",
    "fig22_fault_timeline": "Fault timeline: the height above the site with the fault's onset, its detection, the "
    "abort's entry (or a trigger refused past the commit time) and the navigation's fault flag.",
}


def _caption(stem: str) -> str:
    if stem.startswith("fig21_touchdown_"):
        return (
            f"{stem.rsplit('_', 1)[-1]}: touchdown dispersion of the campaign on the site map (east, north in the "
            "site's tangent plane), the 99.7 % ellipse of a Gaussian fit and the 1 m goal."
        )
    if stem.startswith("fig17") or stem.startswith("fig18"):
        method = stem.rsplit("_", 1)[-1]
        group = "translational" if stem.startswith("fig17") else "rotational"
        return (
            f"{method}: {group} errors x - z of the Monte Carlo runs (the first 300 by index at most) against the "
            f"largest tube half-width over every run (paper Fig. {stem[3:5]})."
        )
    return CAPTIONS.get(stem, stem)


def _scenario(folder: Path) -> tuple[Config | None, bool]:
    """The configuration saved beside a result and whether it is the paper's own scenario (flown in either
    plant: ``simulation.plant`` says who propagated the truth, not what the scenario is)."""
    path = folder / "config.toml"
    if not path.exists():
        return None, False
    try:
        cfg = load_config(path)
    except ConfigError:
        return None, False
    return cfg, cfg.with_overrides({"simulation.plant": "project"}) == load_config()


def paper_under_physics(folder: Path) -> bool:
    """Whether a result is the paper's scenario flown in the physical environment (bennu-paper-physical, in
    either plant): the paper's claims are then checked against physics (docs/model.md "Physical environment")."""
    cfg, _ = _scenario(folder)
    if cfg is None or cfg.disturbance.model != "physical":
        return False
    paper = load_config()
    drawn = {
        "simulation.plant": "project",
        "disturbance.model": "drawn",
        "simulation.truth_shape_subdivisions": 0,
        "disturbance.growth_r": paper.disturbance.growth_r,  # of the draw, which physics does not make
    }
    # the environment's dispersions (its campaigns' draws, the actuator errors among them) are physics' own too
    for section, names in (
        ("physical", [f.name for f in fields(paper.physical) if f.name.endswith(("_dispersion", "_dispersion_B"))]),
        ("disturbance", ["scale_error_p", "misalignment_p", "scale_error_r", "misalignment_r"]),
    ):
        drawn.update({f"{section}.{n}": getattr(getattr(paper, section), n) for n in names})
    return cfg.with_overrides(drawn) == paper


def _mission_view(folder: Path, cfg: Config | None, methods: list[str]) -> tuple[str, str]:
    """The interactive 3D view (HTML, tubempc.analysis.view3d) of a run folder and the section's note; a view
    that cannot be drawn leaves a note instead and never fails the report."""
    if cfg is None:
        return "", "No 3D view: no readable config.toml beside the results."
    try:
        from ..results.records import load_record
        from ..scenario.build import build_scenario
        from .view3d import mission_view_html

        scn = build_scenario(cfg, cache_dir=folder / "cache")
        records = {m: load_record(folder / f"{m}.h5")[0] for m in methods}
        view = mission_view_html(scn, records)
    except Exception as exc:  # the report of the numbers must not depend on the view
        return "", f"No 3D view: {type(exc).__name__}: {exc}"
    note = (
        "Interactive in the HTML report (drag to turn, scroll to zoom): the asteroid and the glide-slope cone "
        "at t_f, the reference and the actual trajectories, the translational tubes (true scale) and the site."
    )
    if cfg.navigation.enabled:
        note += (
            " Flown on navigation: the slider shows the navigation camera's footprint at a few times (the asteroid "
            "as it was then, the field of view's outline and edges, the landmarks in that frame)."
        )
    return view, note


def actuation_comparison(
    folder: Path, cfg: Config, seed: int, results: Mapping[str, MethodResult]
) -> dict[str, dict[str, float]]:
    """Each method's run with actuators (``results``, its summary) against the same mission flown now with ideal
    actuators (:func:`tubempc.scenario.build.ideal_counterpart`: the same reference and input bounds) and
    the same seed: steps outside the tube, terminal position error (m) and net delta-v (m/s) of both and their
    ratios, and the run's thruster delta-v (m/s), propellant (kg), pulses and largest wheel momentum (N m s)."""
    from ..scenario.build import build_scenario, ideal_counterpart
    from ..sim.closed_loop import simulate
    from .metrics import net_delta_v, run_metrics

    scn = build_scenario(cfg, cache_dir=folder / "cache")
    _, ideal = ideal_counterpart(cfg, scn, cache_dir=folder / "cache")
    dt = cfg.mpc.dt
    out: dict[str, dict[str, float]] = {}
    for method, r in results.items():
        if r.actuation is None:
            raise ValueError(f"{method}: the run's summary has no actuation figures")
        rec = simulate(ideal, method, seed)
        base = run_metrics(rec, dt, ideal.xf)
        dv = net_delta_v(rec, dt)
        out[method] = {
            "steps_outside_tube": r.steps_outside_tube,
            "ideal_steps_outside_tube": base.steps_outside_tube,
            "terminal_position_error": r.terminal_error.position,
            "ideal_terminal_position_error": base.terminal_error.position,
            "terminal_error_ratio": r.terminal_error.position / base.terminal_error.position,
            "net_delta_v": r.actuation.net_delta_v,
            "ideal_net_delta_v": dv,
            "net_delta_v_ratio": r.actuation.net_delta_v / dv,
            "thruster_delta_v": r.actuation.thruster_delta_v,
            "propellant": r.actuation.propellant,
            "pulses": r.actuation.pulses,
            "max_wheel_momentum": r.actuation.max_wheel_momentum,
        }
    return out


def _plant_text(plant: str | None) -> str:
    """Who propagated the truth (``simulation.plant``)."""
    if plant == "basilisk":
        return "truth propagated by Basilisk (simulation.plant = basilisk)"
    return "truth propagated by the project's plant"


def _scenario_text(cfg: Config | None, paper: bool) -> str:
    if cfg is None:
        return "scenario: unknown (no readable config.toml beside the results)"
    a, b, m = cfg.asteroid, cfg.boundary, cfg.mpc
    site = (
        f"site at latitude {b.site_latitude * 57.29577951308232:.3g} deg, longitude "
        f"{b.site_longitude * 57.29577951308232:.3g} deg"
        if b.terminal == "site" and b.site == "lat_lon"
        else f"terminal: {b.terminal}"
    )
    return (
        f"scenario: {'the paper scenario (Bennu, Tables 1-2)' if paper else 'not the paper scenario'}; shape "
        f"{a.shape}, density {a.density:g} kg/m^3, spin period {a.spin_period / 3600:.4g} h, {site}, t_f "
        f"{m.t_f:g} s, dt {m.dt:g} s, horizon {m.horizon}, lambda_p {cfg.identification.lambda_p:g}, lambda_r "
        f"{cfg.identification.lambda_r:g}"
    )


def _statistics_section(
    st: CampaignStatistics,
    where: Path,
    section: Callable[[str, str], None],
    table: Callable[[list[str], list[list[str]]], None],
    paragraph: Callable[[str], None],
) -> None:
    """The campaign's statistics (tubempc.analysis.statistics): failure bounds, percentiles with their
    confidence intervals, the worst runs with their seeds and the dispersions driving each metric."""
    conf = f"{100 * st.confidence:g} %"
    section(
        "Failure probabilities",
        f"Each failure kind's count over the runs and the one-sided Clopper-Pearson upper bound on its probability at "
        f"{conf} confidence (0 failures in n runs: 1 - {1 - st.confidence:g}^(1/n), about 3/n at 95 %). A kind "
        "that cannot be judged for this campaign says why.",
    )
    rows = [["(campaign)", "failed run", *_bound_cells(st.failed_run)]]
    for m, ms in st.methods.items():
        for kind, b in ms.failures.items():
            rows.append([m, kind.replace("_", " "), *_bound_cells(b)])
    table(["method", "failure kind", "runs failing", "rate", f"upper bound ({conf})", "note"], rows)
    paragraph(
        "tube exit: the largest tube excursion above 1; touchdown: the terminal error above 1 m or 2 cm/s (where the "
        "mission ends in a touchdown); cone violation: a step outside the glide slope or the line of sight; inside "
        "body: a state inside the body; any: any of them or a failed run, over every run attempted."
    )
    section(
        "Percentiles, worst runs and drivers",
        f"Percentiles with distribution-free {conf} confidence intervals (order statistics; '-' where the runs are "
        "too few), the worst run with its seed (re-fly it alone: tubempc run --from-campaign "
        f"{where} --index I), and the applied dispersion with the largest Spearman rank correlation (p: the "
        "probability of so large a correlation without one; * significant after Bonferroni over the "
        f"{st.dispersions_varied} dispersions that varied).",
    )
    rows = []
    for m, ms in st.methods.items():
        for name, ss in ms.metrics.items():
            pct = [f"{_fmt(p.value)} [{_fmt_or_dash(p.lower)}, {_fmt_or_dash(p.upper)}]" for p in ss.percentiles]
            worst = f"{_fmt(ss.worst[0].value)} (run {ss.worst[0].index}, seed {ss.worst[0].seed})" if ss.worst else "-"
            if ss.drivers:
                d = ss.drivers[0]
                driver = f"{d.dispersion} rho {d.rho:+.2f}, p {d.p_value:.2g}{' *' if d.significant else ''}"
            else:
                driver = ss.drivers_note or "-"
            rows.append([m, name.replace("_", " "), *pct, worst, driver])
    first = next(iter(st.methods.values()), None)
    metrics = next(iter(first.metrics.values()), None) if first is not None else None
    head = [f"p{p.percent:g} [CI]" for p in metrics.percentiles] if metrics is not None else []
    table(["method", "metric", *head, "worst (run, seed)", "top driver"], rows)


def _bound_cells(b: FailureBound) -> list[str]:
    if not b.evaluated or b.failures is None or b.runs is None or b.rate is None or b.upper_bound is None:
        return ["-", "-", "-", f"not evaluated: {b.reason}"]
    return [f"{b.failures}/{b.runs}", f"{_fmt(100 * b.rate)} %", f"{_fmt(100 * b.upper_bound)} %", b.reason or ""]


def write_report(root: Path) -> tuple[Path, Path]:
    """Writes ``root/report.html`` and ``root/report.md``; returns their paths."""
    if not root.is_dir():
        raise ValueError(f"{root}: not a folder")
    found = _summaries(root)
    if not found:
        raise ValueError(f"{root}: no summary.json, sweep.json or montecarlo/summary.json to report")
    folder = {id(s): where for s, where in found.values()}
    run = next((s for s, _ in found.values() if isinstance(s, RunSummary)), None)
    sweep = next((s for s, _ in found.values() if isinstance(s, SweepSummary)), None)
    mc = next((s for s, _ in found.values() if isinstance(s, MonteCarloSummary)), None)
    parts_h: list[str] = []
    parts_m: list[str] = []
    figures: list[Path] = []

    def section(title: str, text: str = "") -> None:
        parts_h.append(f"<h2>{html.escape(title)}</h2>" + (f"<p>{html.escape(text)}</p>" if text else ""))
        parts_m.append(f"\n## {title}\n\n" + (f"{text}\n\n" if text else ""))

    def table(header: list[str], rows: list[list[str]]) -> None:
        h, m = _table(header, rows)
        parts_h.append(h)
        parts_m.append(m + "\n")

    def paragraph(text: str) -> None:
        parts_h.append(f"<p>{html.escape(text)}</p>")
        parts_m.append(f"{text}\n\n")

    paragraph(f"tubempc {__version__}, report written {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC from {root}.")
    any_paper = False
    if run is not None:
        run_dir = folder[id(run)]
        cfg, paper = _scenario(run_dir)
        any_paper |= paper
        ref = run.reference
        section(
            "Closed loop (tubempc run)",
            f"seed {run.seed}, shape {run.shape}, config {run.config_hash[:12]}, {_plant_text(run.plant)}; "
            f"{_scenario_text(cfg, paper)}; reference {'converged' if ref.converged else 'NOT converged'} "
            f"in {ref.iterations} SCP iterations"
            + (
                "."
                if ref.last_subproblem == "optimal"
                else f" (last convex subproblem: {ref.last_subproblem}, its solution checked)."
            ),
        )
        rows = []
        for m, r in run.methods.items():
            row = [m, _fmt(r.J_p), _fmt(r.J_r)]
            if paper:
                p3 = PAPER_TABLE3["TBMPC" if m == "tbmpc" else "0.96"]
                row = [m, _fmt(r.J_p), _fmt(p3[0]), _fmt(r.J_r), _fmt(p3[1])]
            tube = ", ".join(f"{k} {v}" for k, v in sorted(r.tube_statuses.items()))
            rows.append(
                [
                    *row,
                    _fmt(r.terminal_error.position),
                    str(r.steps_outside_tube),
                    _fmt(r.max_tube_excursion.translation),
                    _fmt(r.max_tube_excursion.rotation),
                    _or_dash(r.fallback_steps),
                    _or_dash(r.states_inside_body),
                    str(r.constraint_violations.steps),
                    tube,
                    _fmt(r.step_time["step"].median_ms),
                ]
            )
        head = ["method", "J_p", "paper J_p", "J_r", "paper J_r"] if paper else ["method", "J_p", "J_r"]
        table(
            [
                *head,
                "terminal position error (m)",
                "steps outside the tube",
                "max excursion p",
                "max excursion r",
                "fallback steps",
                "states inside the body",
                "cone violations",
                "tube statuses",
                "step median (ms)",
            ],
            rows,
        )
        paragraph(
            "Tube excursion: e^T Pe^-1 e of the error one step after the plan; <= 1 inside the tube, > 1 "
            "outside (the robustness guarantee lost at that step)."
        )
        navigated = {m: r.navigation for m, r in run.methods.items() if r.navigation is not None}
        if navigated:
            section(
                "Navigation",
                'The runs flew on the onboard estimate x^ (docs/model.md "Output-feedback tube"): the estimation '
                "error x - x^ at touchdown (the last step), the average of the 15-state NEES over the steps against "
                "the 95 % bounds of an average of independent chi-square samples, the camera's landmarks folded into "
                "the filter, and the true state's largest gauge in the output-feedback tube z + Omega (+) E.",
            )
            table(
                [
                    "method",
                    "touchdown error r (m)",  # norms of x - x^ (no "|": the Markdown table's separator)
                    "v (m/s)",
                    "phi (rad)",
                    "omega (rad/s)",
                    "average NEES",
                    "95 % bounds",
                    "inside",
                    "landmarks used",
                    "per frame",
                    "fewest per frame",
                    "max gauge p",
                    "max gauge r",
                    "steps gauge > 1",
                ],
                [_navigation_row(m, n) for m, n in navigated.items()],
            )
            paragraph(
                "The bounds take the steps' NEES as independent; successive steps' errors are correlated, so the "
                "bounds are optimistic (too narrow) and an average outside them is a hint, not a verdict. E is a "
                "probabilistic set: a gauge above 1 is not a lost guarantee."
            )
        if run.comparison is not None:
            red = run.comparison.J_p_reduction_percent
            paper_red = f" (paper: {PAPER_REDUCTION_TABLE3:.1f} %)." if paper else "."
            paragraph(f"TBMPC-FFA's J_p is {below_or_above(red)} TBMPC's" + paper_red)
        if cfg is not None and cfg.spacecraft.actuators != "ideal":
            section(
                "Actuators against ideal actuators",
                f"spacecraft.actuators = {cfg.spacecraft.actuators}; each method against the same mission flown now "
                "with ideal actuators, the same seed, reference and input bounds (the actuators' one-failure box).",
            )
            try:
                comp = actuation_comparison(run_dir, cfg, run.seed, run.methods)
            except Exception as exc:  # the report of the run's own numbers must not depend on the second flight
                paragraph(f"No comparison: {type(exc).__name__}: {exc}")
            else:
                table(
                    [
                        "method",
                        "steps outside the tube (ideal)",
                        "terminal position error (m)",
                        "ideal (m)",
                        "ratio",
                        "net delta-v (m/s)",
                        "ideal (m/s)",
                        "ratio",
                        "thrusters' delta-v (m/s)",
                        "propellant (kg)",
                        "pulses",
                        "max wheel momentum (N m s)",
                    ],
                    [
                        [
                            m,
                            f"{c['steps_outside_tube']:g} ({c['ideal_steps_outside_tube']:g})",
                            _fmt(c["terminal_position_error"]),
                            _fmt(c["ideal_terminal_position_error"]),
                            _fmt(c["terminal_error_ratio"]),
                            _fmt(c["net_delta_v"]),
                            _fmt(c["ideal_net_delta_v"]),
                            _fmt(c["net_delta_v_ratio"]),
                            _fmt(c["thruster_delta_v"]),
                            _fmt(c["propellant"]),
                            f"{c['pulses']:g}",
                            _fmt(c["max_wheel_momentum"]),
                        ]
                        for m, c in comp.items()
                    ],
                )
                paragraph(
                    "Net delta-v: the sum of |u_p delivered| dt; the thrusters' delta-v: the sum of their impulses / m "
                    "(opposed firings for torques and dumping count in it)."
                )
        view, note = _mission_view(run_dir, cfg, list(run.methods))
        section("The mission in 3D", note)
        parts_h.append(view)
        figures += sorted(run_dir.glob("fig*.png"))
    if sweep is not None:
        sweep_dir = folder[id(sweep)]
        cfg, paper = _scenario(sweep_dir)
        any_paper |= paper
        section("Forgetting-factor sweep (paper Table 3)", _scenario_text(cfg, paper))
        rows = []
        for name, sr in sweep.rows.items():
            key = "TBMPC" if sr.lambda_p is None else f"{sr.lambda_p:g}"
            paper_ref = PAPER_TABLE3.get(key)
            paper_cols = (
                [_fmt(paper_ref[0]) if paper_ref else "-", _fmt(paper_ref[1]) if paper_ref else "-"] if paper else []
            )
            rows.append(
                [
                    name,
                    _fmt(sr.J_p),
                    _fmt(sr.J_r),
                    *paper_cols,
                    _fmt(sr.control_effort.translation),
                    _fmt(sr.control_effort.rotation),
                    _fmt(sr.terminal_error.position),
                    _fmt(sr.rms_error.position),
                ]
            )
        head = ["case", "J_p", "J_r", *(["paper J_p", "paper J_r"] if paper else [])]
        table([*head, "effort u_p (m/s^2)", "effort T (N m)", "terminal position error (m)", "RMS r (m)"], rows)
        figures += sorted(sweep_dir.glob("fig1[56]*.png"))
    if mc is not None:
        mc_dir = folder[id(mc)]
        cfg, paper = _scenario(mc_dir)
        any_paper |= paper
        section(
            "Monte Carlo (paper Table 4)",
            f"{mc.runs} runs, master seed {mc.master_seed}, wall time {mc.wall_time_s:.0f} s, {_plant_text(mc.plant)}; "
            f"{_scenario_text(cfg, paper)}",
        )
        rows = []
        for m, mr in mc.methods.items():
            p = PAPER_TABLE4.get(m)
            paper_cols = [_fmt(p["J_p"][0]), _fmt(p["J_p"][1]), _fmt(p["J_r"][0]), _fmt(p["J_r"][1])] if paper and p else []
            rows.append(
                [
                    m,
                    _fmt(mr.J_p.mean),
                    _fmt(mr.J_p.three_sigma),
                    _fmt(mr.J_r.mean),
                    _fmt(mr.J_r.three_sigma),
                    *paper_cols,
                    f"{mr.runs_outside_tube}/{mc.runs}",
                ]
            )
        head = ["method", "J_p mean", "J_p 3 sigma", "J_r mean", "J_r 3 sigma"]
        if paper:
            head += ["paper J_p mean", "paper J_p 3 sigma", "paper J_r mean", "paper J_r 3 sigma"]
        nav_runs = any(mr.nees_inside_fraction is not None for mr in mc.methods.values())
        if nav_runs:  # flown on navigation: the share of runs whose average NEES is inside its bounds
            for row, mr in zip(rows, mc.methods.values(), strict=True):
                row.append("-" if mr.nees_inside_fraction is None else f"{100 * mr.nees_inside_fraction:.0f} %")
        table(
            [*head, "runs outside the tube", *(["runs with the average NEES inside its bounds"] if nav_runs else [])], rows
        )
        if nav_runs:
            paragraph(
                "Average NEES: each run's average of the 15-state NEES over its steps against the 95 % bounds of an "
                "average of independent chi-square samples (optimistic: successive steps are correlated)."
            )
        if mc.J_p_mean_reduction_percent is not None:
            red = mc.J_p_mean_reduction_percent
            paragraph(
                f"TBMPC-FFA's mean J_p is {below_or_above(red)} TBMPC's"
                + (f" (paper: {PAPER_REDUCTION_TABLE4:.1f} % below)." if paper else ".")
            )
        if mc.statistics is not None:
            _statistics_section(
                mc.statistics, mc_dir.relative_to(root) if mc_dir != root else Path("."), section, table, paragraph
            )
        figures += sorted(mc_dir.glob("fig*.png"))
    claims = paper_claims(
        folder[id(run)] if run is not None else None,
        folder[id(sweep)] if sweep is not None else None,
        folder[id(mc)] if mc is not None else None,
    )
    physics = any(paper_under_physics(folder[id(x)]) for x in (run, sweep, mc) if x is not None)
    if claims and physics:
        section(
            "The paper's claims under physics",
            "The paper's scenario flown in the physical environment instead of the drawn disturbance (a heterogeneous "
            "body, attitude-dependent SRP, the gravity-gradient torque, mass, inertia and actuator errors; no draw): "
            "each claim of Sections 3.2-3.4 measured on the results above, 'yes' where it holds under physics "
            "(tubempc.analysis.claims; computed from the files).",
        )
        table(
            ["claim", "paper", "paper's figure", "measured under physics", "holds"],
            [[c.claim, c.where, c.paper, c.measured, c.verdict] for c in claims],
        )
    elif claims and any_paper:
        section(
            "The paper's claims",
            "Each claim of Sections 3.2-3.4 measured on the results above (tubempc.analysis.claims; computed from the "
            "files, not typed in).",
        )
        table(
            ["claim", "paper", "paper's figure", "measured", "reproduced"],
            [[c.claim, c.where, c.paper, c.measured, c.verdict] for c in claims],
        )
    elif claims:
        section(
            "The paper's claims",
            "Not checked: these results are not of the paper's scenario (Bennu, Tables 1-2), so the paper's "
            "numbers do not apply to them.",
        )
    if any_paper:
        section("Why the numbers differ from the paper's", _WHY)
    section("Figures")
    for f in figures:
        data = base64.b64encode(f.read_bytes()).decode()
        caption = f"{f.name}: {_caption(f.stem)}"
        parts_h.append(
            f'<figure><img src="data:image/png;base64,{data}" alt="{html.escape(f.name)}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )
        parts_m.append(f"![{f.stem}]({f.relative_to(root).as_posix()})\n\n*{caption}*\n\n")
    style = (
        "body{font-family:sans-serif;max-width:1200px;margin:auto}table{border-collapse:collapse;margin:1em 0}"
        "td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}img{max-width:100%}"
    )
    out_h = root / "report.html"
    out_h.write_text(
        f'<!doctype html><html><head><meta charset="utf-8"><title>tubempc report</title>'
        f"<style>{style}</style></head><body><h1>tubempc report</h1>{''.join(parts_h)}</body></html>"
    )
    out_m = root / "report.md"
    out_m.write_text("# tubempc report\n" + "".join(parts_m))
    return out_h, out_m
