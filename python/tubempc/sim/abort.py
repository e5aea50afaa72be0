"""How a run flown with the certified safe abort ended (docs/model.md M52 "Safe abort"; issue #43): its summary from
the record. The abort's set-up (the hover, the designs, the library and its commit step) is :mod:`tubempc.design.abort`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from ..design.abort import height_above_site
from ..results.records import RunRecord
from ..results.summaries import AbortSummary
from ..scenario.build import Scenario

__all__ = ["abort_summary"]


def abort_summary(scn: Scenario, rec: RunRecord, inside_body: npt.NDArray[np.bool_]) -> AbortSummary | None:
    """How a run with ``[abort]`` ended (:class:`tubempc.results.summaries.AbortSummary`) from its record,
    ``applied["abort"]`` and which of its states lie inside the body (``inside_body``, (T + 1,):
    :func:`tubempc.analysis.runner.inside_body_mask`); None without it."""
    info = (rec.applied or {}).get("abort")
    if info is None:
        return None
    dt = scn.config.mpc.dt
    x = np.asarray(rec.x, dtype=float)
    t = np.asarray(rec.t, dtype=float)
    heights = height_above_site(scn, x, t)
    entered = info["entered_at_step"]
    refused = info["refused_at_step"]
    commit = int(info["commit_step"])
    after: dict[str, Any] = {}
    if entered is not None:
        k0 = int(entered)
        g = np.asarray(rec.g, dtype=float)[k0:, 0]
        n_inside = int(np.sum(inside_body[k0:]))
        after = {
            "entered_at": k0 * dt,
            "lowest_height": float(heights[k0:].min()),
            "max_glide_slope_g": float(g.max()),
            "states_inside_body": n_inside,
            "safe": bool(heights[-1] >= scn.config.abort.safe_altitude and g.max() <= 0.0 and n_inside == 0),
        }
    residual = info.get("max_residual")
    return AbortSummary(
        outcome="aborted" if entered is not None else "landed",
        cause=str(info["cause"]),
        refused_cause=str(info["refused_cause"]),
        refused_at=None if refused is None else int(refused) * dt,
        commit_time=None if commit < 0 else commit * dt,
        final_height=float(heights[-1]),
        abort_steps=0 if entered is None else len(rec.statuses) - int(entered),
        uncertified_steps=int(info.get("uncertified_steps", 0)),
        max_residual=None if residual is None else float(residual),
        **after,
    )
