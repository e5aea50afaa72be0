"""``tubempc run``: the paper's scenario end to end for TBMPC and/or TBMPC-FFA.

Writes ``DIR/summary.json`` (per method: J_p, J_r, control effort, terminal and RMS errors, the
largest tube excursion, cone violations of the actual trajectory, step-time statistics, solver
statuses), ``DIR/<method>.h5`` (all arrays, with the configuration and seed inside),
``DIR/config.toml`` and the main figures as PNG.
"""

from __future__ import annotations

import collections
import json
import platform
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__, figures, metrics
from .closed_loop import Scenario, SimulationResult, build_scenario, simulate
from .config import Config
from .results import save_result

__all__ = ["run_methods", "run_summary"]

_UNITS = {"t": "s", "x": "[m, m/s, rad, rad/s]", "zbar": "[m, m/s, rad, rad/s]", "u": "[m/s^2 (L), N m (B)]",
          "v": "[m/s^2 (L), N m (B)]", "Pe_p": "[m, m/s]^2", "Pe_r": "[rad, rad/s]^2", "g": "m",
          "w": "[m, m/s, rad, rad/s]", "time_step": "s"}


def _fit_dict(a: dict[str, np.ndarray]) -> dict[str, float]:
    try:
        _, _, fit = velocity_convergence(a)
    except ValueError:  # too short, or no error at all
        return {}
    return {"C_e0_m_per_s": fit.C * fit.e0, "rho": fit.rho, "ebar_m_per_s": fit.ebar}


def _stats_ms(seconds: np.ndarray) -> dict[str, float]:
    ms = 1e3 * np.asarray(seconds, dtype=float)
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)),
            "mean_ms": float(np.mean(ms)), "max_ms": float(np.max(ms))}


def velocity_convergence(a: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, metrics.ConvergenceFit]:
    """Theorem 2 envelope of ||v - vbar|| fitted from its largest value on (paper Figure 14)."""
    err = np.linalg.norm(a["x"][:, 3:6] - a["zbar"][:, 3:6], axis=1)
    k0 = int(np.argmax(err))
    return a["t"][k0:], err[k0:], metrics.fit_exponential_convergence(err[k0:])


def run_summary(scn: Scenario, res: SimulationResult) -> dict[str, Any]:
    """Scalar results of one run (JSON-ready)."""
    a = res.arrays
    cfg = scn.config
    s = metrics.summarize(a["x"], a["zbar"], a["u"], cfg.mpc.dt, scn.xf)
    g = a["g"]
    s.update({
        "max_tube_excursion": {"translation": float(a["excursion"][:, 0].max()),
                               "rotation": float(a["excursion"][:, 1].max())},
        "steps_outside_tube": int(np.sum(np.any(a["excursion"] > 1.0 + 1e-9, axis=1))),
        "constraint_violations": {"glide_slope_steps": int(np.sum(g[:, 0] > 0)), "los_steps": int(np.sum(g[:, 1] > 0)),
                                  "max_glide_slope_g_m": float(g[:, 0].max()), "max_los_g_m": float(g[:, 1].max())},
        "step_time": {name: _stats_ms(a[f"time_{name}"]) for name in
                      ("step", "tube", "mpc", "linearize", "build", "solve", "propagate", "identify")},
        "scp_iterations_mean": float(np.mean(a["scp_iterations"])),
        "model_evaluations_mean": float(np.mean(a["model_evaluations"])),
        "active_set_qp_fraction": float(np.sum(a["active_set_solves"]) / max(1.0, float(np.sum(a["scp_iterations"])))),
        "velocity_convergence_fit": _fit_dict(a),
        "statuses": dict(collections.Counter(res.statuses)),
        "tube_statuses": dict(collections.Counter(res.tube_statuses)),
        "run_time_s": res.wall_time_s,
        "seed": res.seed,
    })
    return s


def run_methods(cfg: Config, methods: list[str], seed: int, out: Path, *, shape: str | None = None,
                progress: bool = True, cache_dir: Path | None = None, make_figures: bool = True) -> dict[str, Any]:
    """Runs the methods, writes the results and returns the summary."""
    out.mkdir(parents=True, exist_ok=True)
    scn = build_scenario(cfg, shape_path=shape, cache_dir=cache_dir)
    scn.config.save(out / "config.toml")
    summary: dict[str, Any] = {
        "tubempc_version": __version__, "config_hash": scn.config.hash(), "seed": seed,
        "shape": scn.shape_source, "n_faces": len(scn.shape.faces),
        "machine": {"python": platform.python_version(), "platform": platform.platform()},
        "reference": {"cost": scn.reference.cost, "iterations": scn.reference.iterations,
                      "converged": scn.reference.converged, "max_defect": scn.reference.max_defect,
                      "solve_time_s": scn.reference.solve_time_s},
        "methods": {},
    }
    results: dict[str, SimulationResult] = {}
    for m in methods:
        res = simulate(scn, m, seed, progress=progress)
        results[m] = res
        summary["methods"][m] = run_summary(scn, res)
        save_result(out / f"{m}.h5", {**res.arrays, "status": np.array(res.statuses)},
                    config=scn.config.to_dict(), seed=seed, method=m, units=_UNITS,
                    metadata=summary["methods"][m])
    if {"tbmpc", "ffa"} <= set(results):
        jp_t, jp_f = summary["methods"]["tbmpc"]["J_p"], summary["methods"]["ffa"]["J_p"]
        summary["comparison"] = {"J_p_reduction_percent": 100.0 * (1.0 - jp_f / jp_t)}
    (out / "summary.json").write_text(json.dumps(summary, indent=1, sort_keys=True))
    if make_figures:
        arrays = {m: r.arrays for m, r in results.items()}
        c = scn.config
        figures.save(figures.trajectory_3d(arrays, c.constraints.glide_slope_angle), out / "fig03_trajectory.png")
        figures.save(figures.states(arrays), out / "fig04_states.png")
        figures.save(figures.errors(arrays), out / "fig06_errors.png")
        figures.save(figures.controls(arrays, c.spacecraft.u_max, c.spacecraft.T_max), out / "fig08_controls.png")
        figures.save(figures.disturbances(arrays, c.identification.pw_scale), out / "fig09_disturbances.png")
        figures.save(figures.tube_projections(arrays), out / "fig12_tube.png")
        figures.save(figures.constraints(arrays), out / "fig13_constraints.png")
        for m, r in results.items():
            t, err, fit = velocity_convergence(r.arrays)
            figures.save(figures.convergence(t, err, fit, "v - vbar"), out / f"fig14_convergence_{m}.png")
    return summary
