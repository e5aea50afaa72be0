"""Navigation figures of a Monte Carlo campaign flown with ``[navigation]`` on (issue #30's goals):
touchdown position and velocity errors, cone violations, the true state in the output-feedback tube
z + Omega (+) E at every step, the estimate in the certified tube Omega, and the filter's consistency
(the average NEES over the first ``--nees-runs`` runs at each step against its 95 % chi-square bounds),
read from the campaign's store.

    python tools/nav_campaign.py CAMPAIGN_DIR [OUT.json] [--method ffa] [--nees-runs 100] [--figure PNG] [--command TEXT]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
from scipy.stats import chi2

from tubempc.results.campaign_store import CampaignStore
from tubempc.results.machine import machine_info

#: The per-step navigation arrays a campaign's store keeps per method.
_NAV_ARRAYS = ("nav_gauge", "nav_gauge_estimate", "nav_nees", "nav_error", "nav_sigma", "nav_landmarks")


def summarise(folder: Path, method: str, nees_runs: int) -> dict[str, Any]:
    """The campaign's navigation figures for one method (from its store, tubempc.results.campaign_store)."""
    store = CampaignStore(folder)
    runs = store.runs()
    runs = runs.filter(pc.equal(runs.column("status"), "ok"))
    if f"{method}.J_p" not in runs.column_names or runs.num_rows == 0:
        raise SystemExit(f"{folder}: no run of {method!r}")
    stacked = {name: store.stacked_steps(method, name) for name in _NAV_ARRAYS}
    if stacked["nav_nees"][1].size == 0:
        raise SystemExit(f"{folder}: no run of {method!r} flown with navigation")
    if any(not np.array_equal(idx, stacked["nav_nees"][0]) for idx, _ in stacked.values()):
        raise SystemExit(f"{folder}: the runs' navigation arrays are incomplete")
    ordered = np.asarray(runs.column("index").to_numpy())
    if not np.array_equal(ordered, stacked["nav_nees"][0]):
        raise SystemExit(f"{folder}: some runs of {method!r} have no navigation arrays")

    def col(name: str) -> np.ndarray:
        c = runs.column(f"{method}.{name}") if f"{method}.{name}" in runs.column_names else None
        if c is None:
            return np.zeros(runs.num_rows)
        return np.nan_to_num(np.asarray(c.cast(pa.float64()).to_numpy(zero_copy_only=False), dtype=float))

    results = runs.num_rows
    pos = col("terminal_error.position")
    vel = col("terminal_error.velocity")
    cone = col("constraint_violations.glide_slope_steps") + col("constraint_violations.los_steps")
    gauge = stacked["nav_gauge"][1]  # (runs, T, 2)
    gauge_est = stacked["nav_gauge_estimate"][1]
    nees = stacked["nav_nees"][1].astype(float)  # (runs, T + 1)
    err, sig = stacked["nav_error"][1], stacked["nav_sigma"][1]
    landmarks = stacked["nav_landmarks"][1]
    m = min(nees_runs, results)
    avg = nees[:m, 1:].mean(axis=0)  # per step, over runs (k >= 1: after the first period)
    lo, hi = chi2.ppf([0.025, 0.975], 15 * m) / m
    return {
        "method": method,
        "runs": results,
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
        "runs_inside_body": int(np.sum(col("states_inside_body") > 0)),
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
        "run_time_s_mean": float(np.mean(col("run_time_s"))),
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
