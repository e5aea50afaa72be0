"""``tubempc run``: the paper's scenario end to end for TBMPC and/or TBMPC-FFA.

Writes ``DIR/summary.json`` (per method: J_p, J_r, control effort, terminal and RMS errors, the
largest tube excursion, cone violations of the actual trajectory, step-time statistics, solver
statuses), ``DIR/<method>.h5`` (all arrays, with the configuration and seed inside),
``DIR/config.toml`` and the main figures as PNG.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__, figures, metrics
from .closed_loop import simulate
from .config import Config
from .machine import machine_info
from .results import RunRecord, save_record
from .scenario import Scenario, build_scenario, landing_geometry

__all__ = ["run_methods", "run_summary", "save_figures"]


def run_summary(scn: Scenario, rec: RunRecord) -> dict[str, Any]:
    """Scalar results of one run (JSON-ready; :func:`tubempc.metrics.run_metrics`)."""
    return metrics.run_metrics(rec, scn.config.mpc.dt, scn.xf)


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
        ("fig08_controls.png", lambda: figures.controls(records, c.spacecraft.u_max, c.spacecraft.T_max)),
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

    if "tbmpc" in records:
        jobs.append(
            ("fig11_exceedances.png", lambda: figures.exceedances(records["tbmpc"], prior, c.identification.pw_scale))
        )

    def convergence(m: str, r: RunRecord) -> Callable[[], Any]:
        title = f"{m}: velocity error ||v - vbar|| and the Theorem 2 envelope"
        return lambda: figures.convergence(*metrics.velocity_convergence(r.t, r.x, r.zbar), "v - vbar", "m/s", title)

    jobs += [(f"fig14_convergence_{m}.png", convergence(m, r)) for m, r in records.items()]
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
    progress: bool = True,
    cache_dir: Path | None = None,
    make_figures: bool = True,
) -> dict[str, Any]:
    """Runs the methods, writes the results and returns the summary."""
    out.mkdir(parents=True, exist_ok=True)
    scn = build_scenario(cfg, shape_path=shape, cache_dir=cache_dir)
    scn.config.save(out / "config.toml")
    summary: dict[str, Any] = {
        "tubempc_version": __version__,
        "config_hash": scn.config.hash(),
        "seed": seed,
        "shape": scn.shape_source,
        "n_faces": len(scn.shape.faces),
        "machine": machine_info(),
        "reference": {
            "cost": scn.reference.cost,
            "iterations": scn.reference.iterations,
            "converged": scn.reference.converged,
            "max_defect": scn.reference.max_defect,
            "solve_time_s": scn.reference.solve_time_s,
        },
        "methods": {},
    }
    records: dict[str, RunRecord] = {}
    for m in methods:
        rec = simulate(scn, m, seed, progress=progress)
        records[m] = rec
        summary["methods"][m] = run_summary(scn, rec)
        save_record(out / f"{m}.h5", rec, config=scn.config.to_dict(), metadata=summary["methods"][m])
    if {"tbmpc", "ffa"} <= set(records):
        jp_t, jp_f = summary["methods"]["tbmpc"]["J_p"], summary["methods"]["ffa"]["J_p"]
        summary["comparison"] = {"J_p_reduction_percent": 100.0 * (1.0 - jp_f / jp_t)}
    (out / "summary.json").write_text(json.dumps(summary, indent=1, sort_keys=True))
    if make_figures:
        failed = save_figures(scn, records, out)
        if failed:
            summary["figure_errors"] = failed
            (out / "summary.json").write_text(json.dumps(summary, indent=1, sort_keys=True))
    return summary
