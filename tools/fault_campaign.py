"""Figures of a fault campaign (issue #43's goals), read from a Monte Carlo campaign's store flown with ``[faults]``
and ``[abort]``: per run its injected fault, its detection and the way it ended, landed within the spec (``--spec-m``
and ``--spec-m-s`` of the target), landed outside it, aborted safe or aborted unsafe; per fault kind the runs, the
detections and the detection latency (median and worst); the abort's certification over every step it flew.

    python tools/fault_campaign.py CAMPAIGN_DIR [OUT.json] [--method ffa] [--spec-m 1] [--spec-m-s 0.02] [--command TEXT]
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from tubempc.results.campaign_store import CampaignStore
from tubempc.results.machine import machine_info


def _column(runs: pa.Table, name: str, default: Any) -> list[Any]:
    """A column of the store as a list (``default`` for every run without it)."""
    if name not in runs.column_names:
        return [default] * runs.num_rows
    return [default if v is None else v for v in runs.column(name).to_pylist()]


def _quantiles(values: list[float]) -> dict[str, float | None]:
    if not values:
        return {"median": None, "worst": None}
    return {"median": float(np.median(values)), "worst": float(np.max(values))}


def summarise(folder: Path, method: str, spec_m: float, spec_m_s: float) -> dict[str, Any]:
    """The campaign's fault figures for one method (see the module comment)."""
    store = CampaignStore(folder)
    runs = store.runs()
    failed = runs.num_rows
    runs = runs.filter(pc.equal(runs.column("status"), "ok"))
    failed -= runs.num_rows
    if f"{method}.J_p" not in runs.column_names or runs.num_rows == 0:
        raise SystemExit(f"{folder}: no run of {method!r}")
    p = f"{method}."
    outcome = _column(runs, p + "abort.outcome", None)
    if any(o is None for o in outcome):
        raise SystemExit(f"{folder}: runs flown without [abort]")
    safe = _column(runs, p + "abort.safe", False)
    cause = _column(runs, p + "abort.cause", "none")
    entered = _column(runs, p + "abort.entered_at", None)
    refused = _column(runs, p + "abort.refused_cause", "none")
    uncertified = _column(runs, p + "abort.uncertified_steps", 0)
    residual = [r for r in _column(runs, p + "abort.max_residual", None) if r is not None]
    final_height = _column(runs, p + "abort.final_height", float("nan"))
    kind = _column(runs, "applied.fault.kind", "none")  # the injected fault (navigation or not)
    onset = _column(runs, "applied.fault.start", None)
    nav_detected = _column(runs, p + "navigation.faults.detected", False)
    nav_time = _column(runs, p + "navigation.faults.detection_time", None)
    nav_cause = _column(runs, p + "navigation.faults.cause", "none")
    refused_at = _column(runs, p + "abort.refused_at", None)
    pos = _column(runs, p + "terminal_error.position", float("nan"))
    vel = _column(runs, p + "terminal_error.velocity", float("nan"))
    inside_body = _column(runs, p + "states_inside_body", 0)
    outside_tube = _column(runs, p + "steps_outside_tube", 0)
    index = _column(runs, "index", -1)
    ends: dict[str, list[int]] = defaultdict(list)
    per_kind: dict[str, dict[str, Any]] = defaultdict(lambda: defaultdict(int))
    latencies: dict[str, list[float]] = defaultdict(list)
    abort_times: list[float] = []
    for i in range(runs.num_rows):
        # the first detection: the navigation's, or a trigger of the abort's supervision (entered, or refused past
        # the commit step); a navigation fault that entered the abort is the navigation's detection
        found = sorted(
            (float(t), name)
            for t, name in (
                (nav_time[i] if nav_detected[i] else None, nav_cause[i]),
                (entered[i], cause[i]),
                (refused_at[i], refused[i]),
            )
            if t is not None and name not in ("none", "navigation_fault")
        )
        if outcome[i] == "aborted":
            end = "aborted_safe" if safe[i] else "aborted_unsafe"
            abort_times.append(float(entered[i]))
        else:
            within = pos[i] <= spec_m and vel[i] <= spec_m_s and not inside_body[i]
            end = "landed_within_spec" if within else "landed_outside_spec"
        ends[end].append(int(index[i]))
        k = per_kind[kind[i]]
        k["runs"] += 1
        k[end] += 1
        k["detected"] += bool(found)
        k["aborted"] += outcome[i] == "aborted"
        k["refused_past_commit"] += refused[i] != "none"
        if found:
            k.setdefault("detections", defaultdict(int))[found[0][1]] += 1
            if kind[i] != "none" and onset[i] is not None:
                latencies[kind[i]].append(found[0][0] - float(onset[i]))
    kinds = {
        name: {
            **{key: (dict(v) if isinstance(v, dict) else v) for key, v in d.items()},
            "latency_s": _quantiles(latencies[name]),
        }
        for name, d in sorted(per_kind.items())
    }
    return {
        "method": method,
        "runs": runs.num_rows,
        "failed_runs": failed,
        "spec": {"position_m": spec_m, "velocity_m_s": spec_m_s},
        "ends": {name: len(v) for name, v in sorted(ends.items())},
        "runs_landed_outside_spec": ends.get("landed_outside_spec", []),
        "runs_aborted_unsafe": ends.get("aborted_unsafe", []),
        "aborts": {
            "runs": len(abort_times),
            "causes": dict(sorted((c, cause.count(c)) for c in set(cause) if c != "none")),
            "entry_time_s": _quantiles(abort_times),
            "lowest_final_height_m": min(
                (float(h) for h, o in zip(final_height, outcome, strict=True) if o == "aborted"), default=None
            ),
            "steps_on_an_uncertified_tube": int(sum(uncertified)),
            "max_lmi_residual": float(max(residual)) if residual else None,
        },
        "runs_with_steps_outside_tube": int(sum(1 for s in outside_tube if s)),
        "runs_inside_body": int(sum(1 for s in inside_body if s)),
        "per_fault_kind": kinds,
        "run_time_s_mean": float(np.mean(_column(runs, p + "run_time_s", float("nan")))),
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("folder", type=Path)
    p.add_argument("json", type=Path, nargs="?", help="write the figures to this JSON file too")
    p.add_argument("--method", default="ffa")
    p.add_argument("--spec-m", type=float, default=1.0, help="touchdown position spec (m)")
    p.add_argument("--spec-m-s", type=float, default=0.02, help="touchdown velocity spec (m/s)")
    p.add_argument("--command", default="")
    a = p.parse_args()
    out = summarise(a.folder, a.method, a.spec_m, a.spec_m_s)
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
