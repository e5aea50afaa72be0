"""``tubempc run``: the paper's scenario end to end for TBMPC and/or TBMPC-FFA.

Writes ``DIR/summary.json`` (per method: J_p, J_r, control effort, terminal and RMS errors, the
largest tube excursion, cone violations of the actual trajectory, step-time statistics, solver
statuses), ``DIR/<method>.h5`` (all arrays, with the configuration and seed inside),
``DIR/config.toml`` and the main figures as PNG.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import __version__
from ..config import Config
from ..design.abort import height_above_site
from ..results.machine import machine_info
from ..results.pinning import pin_config, shape_record
from ..results.records import RunRecord, save_record
from ..results.summaries import (
    CampaignMethodResult,
    Comparison,
    ReferenceSummary,
    RunMetrics,
    RunSummary,
    fallback_steps,
    write_summary,
)
from ..scenario.build import Scenario, build_scenario, landing_geometry
from ..scenario.sites import inside
from ..sim.abort import abort_summary
from ..sim.closed_loop import simulate
from . import figures, metrics

__all__ = [
    "aborted",
    "guarantee_lost",
    "inside_body_mask",
    "run_methods",
    "run_summary",
    "save_figures",
    "states_inside_body",
]


def states_inside_body(scn: Scenario, rec: RunRecord) -> int:
    """How many of the run's actual states x_k (k = 0..T) lie inside the body (:func:`inside_body_mask`): a state
    inside the body is never a flown mission."""
    return int(np.sum(inside_body_mask(scn, rec)))


def inside_body_mask(scn: Scenario, rec: RunRecord) -> npt.NDArray[np.bool_]:
    """Which of the run's actual states x_k (k = 0..T) lie inside the body (the controller's shape, or in a
    physical environment the truth's, where the run's centre of mass puts it: a dispersed run's, from its record's
    ``applied``; turned to its attitude at t_k = k dt)."""
    dt = scn.config.mpc.dt
    r_A = np.array([np.asarray(scn.model.C_AL(k * dt)) @ x[:3] for k, x in enumerate(np.asarray(rec.x))])
    if scn.physical is not None:
        body = scn.physical.parts[0]
        flown = (rec.applied or {}).get("truth", {}).get("physical")
        offset_A = body.offset_A if flown is None else np.asarray(flown["parts"][0]["offset_A"], dtype=float)
        return inside(body.shape, r_A - offset_A)
    return inside(scn.shape, r_A)


def run_summary(scn: Scenario, rec: RunRecord) -> RunMetrics:
    """Scalar results of one run (:func:`tubempc.analysis.metrics.run_metrics`) with the number of states inside
    the body (``states_inside_body``)."""
    mask = inside_body_mask(scn, rec)
    return dataclasses.replace(
        metrics.run_metrics(rec, scn.config.mpc.dt, scn.xf),
        states_inside_body=int(np.sum(mask)),
        abort=abort_summary(scn, rec, mask),
    )


def guarantee_lost(result: RunMetrics | CampaignMethodResult) -> list[str]:
    """What a run's result (its summary or a campaign's per-method record) says was lost: steps outside
    the tube, fallback steps, states inside the body, steps the actuators did not deliver (empty: every
    guarantee kept). The exit status 4
    of every command means a non-empty list for some run."""
    reasons = []
    if result.steps_outside_tube:
        reasons.append(f"{result.steps_outside_tube} steps outside the tube")
    fallbacks = result.fallback_steps
    if fallbacks is None:  # not recorded: count the statuses
        fallbacks = fallback_steps(result.statuses)
    if fallbacks:
        reasons.append(f"{fallbacks} fallback steps")
    if result.states_inside_body:
        reasons.append(f"{result.states_inside_body} states inside the body")
    if result.actuation is not None and result.actuation.not_delivered_steps:
        reasons.append(f"{result.actuation.not_delivered_steps} steps the actuators did not deliver")
    a = result.abort
    if a is not None and a.outcome == "aborted" and not a.safe:
        reasons.append(f"an abort that did not end safe (final height {a.final_height:.3g} m)")
    if a is not None and a.uncertified_steps:
        reasons.append(f"{a.uncertified_steps} abort steps on an uncertified tube")
    return reasons


def aborted(result: RunMetrics | CampaignMethodResult) -> str | None:
    """The abort of a run that aborted ("<cause> at <t> s"), None if it did not abort."""
    a = result.abort
    if a is None or a.outcome != "aborted":
        return None
    return f"{a.cause} at {a.entered_at:g} s"


def save_figures(scn: Scenario, records: dict[str, RunRecord], out: Path) -> dict[str, str]:
    """The run's figures (paper Figures 3-14) as PNG files in ``out``. A figure that cannot be drawn
    is skipped with a warning (the run's results are already written); returns {file: error}."""
    c = scn.config
    t_f = c.mpc.t_f
    vertices_L, faces, apex_L, axis_L = landing_geometry(scn, t_f)
    body_L, cone_L = (vertices_L, faces), (apex_L, axis_L)
    prior = np.concatenate([np.diag(c.identification.S0_p), np.diag(c.identification.S0_r)])
    jobs: list[tuple[str, Callable[[], Any]]] = [
        (
            "fig03_trajectory.png",
            lambda: figures.trajectory_3d(records, c.constraints.glide_slope_angle, body_L=body_L, cone_L=cone_L),
        ),
        ("fig04_states_translation.png", lambda: figures.states(records, figures.TRANSLATION)),
        ("fig05_states_rotation.png", lambda: figures.states(records, figures.ROTATION)),
        ("fig06_errors_translation.png", lambda: figures.errors(records, figures.TRANSLATION)),
        ("fig07_errors_rotation.png", lambda: figures.errors(records, figures.ROTATION)),
        ("fig08_controls.png", lambda: figures.controls(records, *scn.input_bounds)),
        (
            "fig09_disturbances_translation.png",
            lambda: figures.disturbances(records, c.identification.pw_scale, prior, figures.TRANSLATION),
        ),
        (
            "fig10_disturbances_rotation.png",
            lambda: figures.disturbances(records, c.identification.pw_scale, prior, figures.ROTATION),
        ),
        ("fig12_tube.png", lambda: figures.tube_projections(records)),
        ("fig13_constraints.png", lambda: figures.constraints(records)),
    ]

    if scn.actuation is not None:
        n_thrusters = len(scn.actuation.suite.cluster)
        jobs.append(("fig15_actuation.png", lambda: figures.actuation(records, n_thrusters)))
    if "tbmpc" in records:
        jobs.append(
            ("fig11_exceedances.png", lambda: figures.exceedances(records["tbmpc"], prior, c.identification.pw_scale))
        )

    def convergence(m: str, r: RunRecord) -> Callable[[], Any]:
        title = f"{m}: velocity error ||v - vbar|| and the Theorem 2 envelope"
        return lambda: figures.convergence(*metrics.velocity_convergence(r.t, r.x, r.zbar), "v - vbar", "m/s", title)

    jobs += [(f"fig14_convergence_{m}.png", convergence(m, r)) for m, r in records.items()]
    if any(r.navigation is not None for r in records.values()):  # flown on navigation
        jobs += [
            ("fig19_navigation_errors.png", lambda: figures.navigation_errors(records)),
            ("fig20_landmarks.png", lambda: figures.landmarks_visible(records)),
        ]
    if any(figures.fault_events(r) for r in records.values()) and scn.site is not None:  # a fault or an abort
        heights = {m: height_above_site(scn, r.x, r.t) for m, r in records.items()}
        commit = (next(iter(records.values())).applied or {}).get("abort", {}).get("commit_step")
        commit_time = None if commit is None or commit < 0 else commit * c.mpc.dt
        jobs.append(("fig22_fault_timeline.png", lambda: figures.fault_timeline(records, heights, commit_time)))
    failed: dict[str, str] = {}
    for name, make in jobs:
        try:
            figures.save(make(), out / name)
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
            failed[name] = f"{type(exc).__name__}: {exc}"
            warnings.warn(
                f"{out / name}: figure not drawn ({failed[name]}); the run's results are saved", RuntimeWarning, stacklevel=2
            )
    return failed


def run_methods(
    cfg: Config,
    methods: list[str],
    seed: int,
    out: Path,
    *,
    shape: str | None = None,
    shape_unit: str | None = None,
    progress: bool = True,
    cache_dir: Path | None = None,
    make_figures: bool = True,
) -> RunSummary:
    """Runs the methods, writes the results and returns the summary.

    ``shape`` (a path) replaces the configuration's shape and needs ``shape_unit`` ("m" or "km"). The
    folder keeps a copy of a shape file, named by its saved ``config.toml`` (:mod:`tubempc.results.pinning`),
    so that it re-flies and re-reports wherever it is copied."""
    if shape is not None:
        if shape_unit is None:
            raise ValueError(f"{shape}: a shape given apart from the configuration needs its unit (--shape-unit m|km)")
        cfg = cfg.with_overrides({"asteroid.shape": str(Path(shape).resolve()), "asteroid.shape_unit": shape_unit})
    out.mkdir(parents=True, exist_ok=True)
    cfg = pin_config(cfg, out)
    scn = build_scenario(cfg, cache_dir=cache_dir)
    scn.config.save(out / "config.toml")
    reference = ReferenceSummary(
        cost=scn.reference.cost,
        iterations=scn.reference.iterations,
        converged=scn.reference.converged,
        last_subproblem=scn.reference.last_subproblem,
        max_defect=scn.reference.max_defect,
        solve_time_s=scn.reference.solve_time_s,
    )
    records: dict[str, RunRecord] = {}
    results: dict[str, RunMetrics] = {}
    for m in methods:
        rec = simulate(scn, m, seed, progress=progress)
        records[m] = rec
        results[m] = run_summary(scn, rec)
        save_record(out / f"{m}.h5", rec, config=scn.config.to_dict(), metadata=results[m].to_json())
    comparison = None
    if {"tbmpc", "ffa"} <= set(records):
        comparison = Comparison(J_p_reduction_percent=100.0 * (1.0 - results["ffa"].J_p / results["tbmpc"].J_p))
    summary = RunSummary(
        tubempc_version=__version__,
        config_hash=scn.config.hash(),
        seed=seed,
        shape=scn.shape_source,
        shape_file=shape_record(scn.config),
        n_faces=len(scn.shape.faces),
        machine=machine_info(),
        reference=reference,
        methods=results,
        comparison=comparison,
        plant=scn.config.simulation.plant,
    )
    write_summary(out / "summary.json", summary)
    if make_figures:
        failed = save_figures(scn, records, out)
        if failed:
            summary = dataclasses.replace(summary, figure_errors=failed)
            write_summary(out / "summary.json", summary)
    return summary
