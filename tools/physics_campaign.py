"""Figures of a Monte Carlo campaign flown in the physical environment (disturbance.model = "physical", the truth
dispersed per run; issue #40's goal "100-run campaigns of TBMPC and TBMPC-FFA ... in each plant"): per method the
runs and steps outside the tube, the touchdown (terminal) errors, J_p and J_r, the drawn mass errors of the runs
that left the tube against those that did not, how far the drawn body moved the truth's surface at the site, and,
given the nominal run's folder (and a sweep's), the paper's claims under physics measured with the campaign
(tubempc.analysis.claims). Writes the JSON that tools/benchmarks_md.py reads (docs/benchmarks/physics_<name>.json).

    python tools/physics_campaign.py CAMPAIGN_DIR [OUT.json] [--run RUN_DIR] [--sweep SWEEP_DIR] [--command TEXT]
        [--name NAME]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from tubempc.results.campaign_store import CampaignStore
from tubempc.results.machine import machine_info


def _spread(values: np.ndarray) -> dict[str, float]:
    return {
        "mean": float(values.mean()),
        "3sigma": float(3.0 * values.std(ddof=1)) if values.size > 1 else 0.0,
        "min": float(values.min()),
        "max": float(values.max()),
    }


def _errors(values: np.ndarray) -> dict[str, float]:
    return {"max": float(values.max()), "p99_7": float(np.quantile(values, 0.997)), "mean": float(values.mean())}


def _range(values: list[float]) -> list[float] | None:
    return [float(min(values)), float(max(values))] if values else None


def site_surface_shift(folder: Path, offsets_A: list[list[float]]) -> dict[str, Any] | None:
    """How far each run's drawn body moved the truth's surface at the landing site, along the site's normal, from
    the nominal truth's (m; the body's shift n . (o_run - o_nominal)); None without a site."""
    from tubempc.config import load_config
    from tubempc.scenario import build_scenario

    scn = build_scenario(load_config(folder / "config.toml"), cache_dir=folder / "cache")
    if scn.site is None or scn.physical is None:
        return None
    n = np.asarray(scn.site.normal_A, dtype=float)
    nominal = np.asarray(scn.physical.parts[0].offset_A, dtype=float)
    shift = np.array([float(n @ (np.asarray(o, dtype=float) - nominal)) for o in offsets_A])
    return {"min": float(shift.min()), "max": float(shift.max()), "std": float(shift.std(ddof=1)) if shift.size > 1 else 0.0}


def _cone_steps(result: dict[str, Any]) -> int:
    c = result["constraint_violations"]
    return int(c["glide_slope_steps"] + c["los_steps"])


def summarise(folder: Path) -> dict[str, Any]:
    """The campaign's figures per method (every successful run, from the campaign's store:
    tubempc.results.campaign_store)."""
    store = CampaignStore(folder)
    failed = sorted(store.failures())
    results: list[dict[str, Any]] = [store.result(i) for i in store.indices("ok")]
    if not results:
        raise SystemExit(f"{folder}: no successful run")
    applied = [r["applied"] for r in results]
    physical = [a["truth"].get("physical") for a in applied]
    if any(p is None or p.get("drawn") is None for p in physical):
        raise SystemExit(f"{folder}: not a campaign of a dispersed physical environment (a run without a drawn truth)")
    mass_error = [float(p["drawn"]["mass_error"]) for p in physical]
    methods: dict[str, Any] = {}
    for m in ("tbmpc", "ffa"):
        rows = [r[m] for r in results if m in r]
        if not rows:
            continue
        steps = np.array([r["steps_outside_tube"] for r in rows])
        exc = np.array([max(r["max_tube_excursion"]["translation"], r["max_tube_excursion"]["rotation"]) for r in rows])
        outside = [e for e, s in zip(mass_error, steps, strict=True) if s > 0]
        inside = [e for e, s in zip(mass_error, steps, strict=True) if s == 0]
        methods[m] = {
            "runs": len(rows),
            "runs_outside_tube": int(np.sum(steps > 0)),
            "steps_outside_tube": {"total": int(steps.sum()), "max_per_run": int(steps.max())},
            "max_tube_excursion": float(exc.max()),
            "J_p": _spread(np.array([r["J_p"] for r in rows])),
            "J_r": _spread(np.array([r["J_r"] for r in rows])),
            "touchdown_position_error_m": _errors(np.array([r["terminal_error"]["position"] for r in rows])),
            "touchdown_velocity_error_m_s": _errors(np.array([r["terminal_error"]["velocity"] for r in rows])),
            "runs_inside_body": int(sum((r.get("states_inside_body") or 0) > 0 for r in rows)),
            "runs_with_cone_violation": int(sum(_cone_steps(r) > 0 for r in rows)),
            "drawn_mass_error": {"runs_outside_tube": _range(outside), "runs_inside_tube": _range(inside)},
            "run_time_s_mean": float(np.mean([r["run_time_s"] for r in rows])),
        }
    out: dict[str, Any] = {"runs": len(results), "failed_runs": failed, "methods": methods}
    if {"tbmpc", "ffa"} <= set(methods):
        out["J_p_mean_reduction_percent"] = 100.0 * (1.0 - methods["ffa"]["J_p"]["mean"] / methods["tbmpc"]["J_p"]["mean"])
    out["drawn_mass_error"] = _range(mass_error)
    out["site_surface_shift_m"] = site_surface_shift(folder, [p["parts"][0]["offset_A"] for p in physical])
    return out


def claims(run: Path | None, sweep: Path | None, campaign: Path) -> list[dict[str, Any]]:
    """The paper's claims measured on the nominal run, the sweep and the campaign (empty without a run, or for a
    scenario that is not the paper's under physics)."""
    if run is None:
        return []
    from tubempc.analysis.claims import paper_claims
    from tubempc.analysis.report import paper_under_physics

    if not paper_under_physics(run):
        return []
    return [
        {"claim": c.claim, "where": c.where, "paper": c.paper, "measured": c.measured, "holds": c.verdict}
        for c in paper_claims(run, sweep, campaign)
    ]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("folder", type=Path, help="the campaign's folder (tubempc montecarlo --out)")
    p.add_argument("json", type=Path, nargs="?", help="write the figures to this JSON file too")
    p.add_argument("--run", type=Path, help="the nominal run's folder (tubempc run --out), for the paper's claims")
    p.add_argument("--sweep", type=Path, help="a sweep's folder (tubempc sweep --out), for the paper's claims")
    p.add_argument("--command", default="", help="the commands that made the folders, as the page shows them")
    p.add_argument(
        "--name",
        help="what the page calls the campaign's configuration (default: the packaged scenario it flew, else its file)",
    )
    a = p.parse_args()
    summary = json.loads((a.folder / "summary.json").read_text(encoding="utf-8"))
    config = a.folder / "config.toml"
    out: dict[str, Any] = {"scenario": "", "plant": summary.get("plant") or "project"}
    out["master_seed"] = summary.get("master_seed")
    out.update(summarise(a.folder))
    out["claims"] = claims(a.run, a.sweep, a.folder)
    out["config_hash"] = summary.get("config_hash")
    # the last invocation's wall time (a resumed campaign's is its last part's); the runs' own is the sum below
    out["campaign_wall_time_s"] = summary.get("wall_time_s")
    out["runs_time_s"] = float(np.nansum(CampaignStore(a.folder).column("run_time_s")))
    out["workers"] = summary.get("workers")
    out["command"] = a.command
    out["machine"] = summary.get("machine") or machine_info()
    out["scenario"] = a.name or _scenario_name(config)
    text = json.dumps(out, indent=2)
    print(text)
    if a.json:
        a.json.write_text(text + "\n", encoding="utf-8")
    return 0


def _scenario_name(config: Path) -> str:
    """The packaged scenario whose configuration the campaign flew (in either plant), or the file's name."""
    from tubempc.config import SCENARIOS, load_config

    flown = load_config(config).with_overrides({"simulation.plant": "project"})
    for name in SCENARIOS:
        if load_config(scenario=name) == flown:
            return name
    return config.name


if __name__ == "__main__":
    sys.exit(main())
