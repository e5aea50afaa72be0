"""Navigation figures of a Monte Carlo campaign flown with ``[navigation]`` on (issue #30's goals):
touchdown position and velocity errors, cone violations, the true state in the output-feedback tube
z + Omega (+) E at every step, the estimate in the certified tube Omega, and the filter's consistency
(the average NEES over the first ``--nees-runs`` runs at each step against its 95 % chi-square bounds).

    python tools/nav_campaign.py CAMPAIGN_DIR [OUT.json] [--method ffa] [--nees-runs 100] [--figure PNG] [--command TEXT]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import chi2

from tubempc.results.machine import machine_info


def summarise(folder: Path, method: str, nees_runs: int) -> dict[str, Any]:
    """The campaign's navigation figures for one method."""
    results, arrays = [], []
    for path in sorted((folder / "runs").glob("run_*.json")):
        run = json.loads(path.read_text(encoding="utf-8"))
        if not run.get("ok") or method not in run["result"]:
            continue
        results.append(run["result"][method])
        with np.load(path.with_suffix(".npz")) as d:
            arrays.append({k.removeprefix(f"{method}_"): d[k] for k in d.files if k.startswith(f"{method}_nav_")})
    if not results or "nav_nees" not in arrays[0]:
        raise SystemExit(f"{folder}: no run of {method!r} flown with navigation")
    pos = np.array([r["terminal_error"]["position"] for r in results])
    vel = np.array([r["terminal_error"]["velocity"] for r in results])
    cone = np.array([sum(r["constraint_violations"][k] for k in ("glide_slope_steps", "los_steps")) for r in results])
    gauge = np.stack([a["nav_gauge"] for a in arrays])  # (runs, T, 2)
    gauge_est = np.stack([a["nav_gauge_estimate"] for a in arrays])
    nees = np.stack([a["nav_nees"] for a in arrays]).astype(float)  # (runs, T + 1)
    err, sig = np.stack([a["nav_error"] for a in arrays]), np.stack([a["nav_sigma"] for a in arrays])
    landmarks = np.stack([a["nav_landmarks"] for a in arrays])
    m = min(nees_runs, len(results))
    avg = nees[:m, 1:].mean(axis=0)  # per step, over runs (k >= 1: after the first period)
    lo, hi = chi2.ppf([0.025, 0.975], 15 * m) / m
    return {
        "method": method,
        "runs": len(results),
        "touchdown_position_error_m": {
            "max": float(pos.max()),
            "p99_7": float(np.quantile(pos, 0.997)),
            "mean": float(pos.mean()),
            "runs_over_1_m": int(np.sum(pos > 1.0)),
        },
        "touchdown_velocity_error_m_s": {
            "max": float(vel.max()),
            "p99_7": float(np.quantile(vel, 0.997)),
            "mean": float(vel.mean()),
            "runs_over_2_cm_s": int(np.sum(vel > 0.02)),
        },
        "runs_with_cone_violation": int(np.sum(cone > 0)),
        "runs_inside_body": int(sum((r.get("states_inside_body") or 0) > 0 for r in results)),
        "output_feedback_tube": {
            "max_gauge_true_state": float(gauge.max()),
            "runs_true_state_outside": int(np.sum(gauge.max(axis=(1, 2)) > 1.0)),
            "steps_true_state_outside": int(np.sum(gauge.max(axis=2) > 1.0)),
            "max_gauge_estimate_in_omega": float(gauge_est.max()),
            "runs_estimate_outside_omega": int(np.sum(gauge_est.max(axis=(1, 2)) > 1.0)),
        },
        "nees": {
            "runs": m,
            "dof": 15,
            "average_over_runs_and_steps": float(avg.mean()),
            "bounds_95": [float(lo), float(hi)],
            "steps_inside_bounds_fraction": float(np.mean((avg >= lo) & (avg <= hi))),
            "steps_above_bound_fraction": float(np.mean(avg > hi)),
        },
        "error_inside_3_sigma_fraction": float(np.mean(np.abs(err) <= 3.0 * sig)),
        "landmarks_per_frame": {"mean": float(landmarks.mean()), "min": float(landmarks.min())},
        "run_time_s_mean": float(np.mean([r["run_time_s"] for r in results])),
    }


def dispersion_figure(folder: Path, method: str, path: Path) -> None:
    """The touchdown offsets x_T - x_f in the site's tangent plane on the site map, with their 99.7 %
    ellipse and the 1 m goal (tubempc.analysis.dispersion_figure, as ``tubempc montecarlo`` draws it)."""
    from tubempc.analysis import dispersion_figure as draw
    from tubempc.analysis import figures
    from tubempc.config import load_config
    from tubempc.scenario import build_scenario

    scn = build_scenario(load_config(folder / "config.toml"), cache_dir=folder / "cache")
    if scn.site is None:
        raise SystemExit(f"{folder}: the campaign's mission has no landing site")
    fig = draw(scn, folder, method)
    if fig is None:
        raise SystemExit(f"{folder}: no run kept its touchdown error (campaigns before the navigation arrays)")
    figures.save(fig, path)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("folder", type=Path)
    p.add_argument("--method", default="ffa")
    p.add_argument("--nees-runs", type=int, default=100)
    p.add_argument("json", type=Path, nargs="?", help="write the figures to this JSON file too")
    p.add_argument("--command", default="")
    p.add_argument("--figure", type=Path, help="touchdown dispersion on the site map (PNG)")
    a = p.parse_args()
    out = summarise(a.folder, a.method, a.nees_runs)
    if a.figure:
        dispersion_figure(a.folder, a.method, a.figure)
    summary = json.loads((a.folder / "summary.json").read_text(encoding="utf-8"))
    out["campaign_wall_time_s"] = summary.get("wall_time_s")
    out["workers"] = summary.get("workers")
    out["command"] = a.command
    out["machine"] = summary.get("machine") or machine_info()
    text = json.dumps(out, indent=2)
    print(text)
    if a.json:
        a.json.write_text(text + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
