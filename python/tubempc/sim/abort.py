"""The certified safe abort's set-up (docs/model.md M52 "Safe abort"; issue #43): the hover reference, the abort
controller's certified designs, and the library of nominal aborts from entries over the descent with the commit step.

- The hover: a point ``abort.hover_altitude`` above the site's surface along its normal, fixed in the body frame A
  and so turning in L; at rest relative to the surface with the boresight down (:func:`tubempc.scenario.sites.
  terminal_state`) at every node of the descent's time base, its attitude the nearest to the descent's at the same
  node; its input the one that keeps it, solved from the model's exact discretisation.
- The designs: TBMPC-FFA's set-up designs (:func:`tubempc.design.library.controller_designs`) about the hover's first
  node: the abort's tube is updated and certified at every step it flies (``control::SafeAbort``).
- The library: from the descent's reference state every ``abort.entry_period`` steps, the abort controller flown on
  the controller's model without disturbance (its exact discretisation at each step's state and command) to the
  end of the mission. An entry is certified when every step's
  tube is certified (residual <= 0), no step fell back, its plan never enters the body, keeps the glide-slope cone
  (g <= 0) and the input bounds (the actuators' one-failure box when flown with actuators), and ends above
  ``abort.safe_altitude``. The commit step is the last entry of the unbroken run of certified entries from the
  first; the step enters an abort at any step up to it (between two entries the state is the descent's between
  two certified ones: the entries sample the descent, they do not cover every state).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..design.library import controller_designs, controller_settings
from ..results.records import RunRecord
from ..results.summaries import AbortSummary
from ..scenario.build import Scenario, mpc_settings
from ..scenario.reference import ReferenceTrajectory
from ..scenario.sites import inside, terminal_state

__all__ = [
    "AbortEntry",
    "AbortLibrary",
    "abort_library",
    "abort_summary",
    "height_above_site",
    "hover_reference",
    "new_abort",
]

Array = npt.NDArray[np.float64]

#: Fixed-point iterations of the hover's input (the input enters the dynamics affinely: two suffice).
_HOVER_INPUT_ITERATIONS = 3
#: Tolerance of the plan's checks on the cone (m) and the input bounds (relative).
_CONE_TOLERANCE_M = 1e-6
_INPUT_TOLERANCE = 1e-9


@dataclass(frozen=True)
class AbortEntry:
    """One entry of the abort library: the nominal abort from the descent's reference state at ``step``."""

    step: int
    certified: bool
    reason: str  # what failed ("" when certified)
    lowest_height_m: float  # the plan's lowest height above the site's surface along its normal
    final_height_m: float
    max_glide_slope_m: float  # largest g of the cone over the plan (<= 0: inside)
    max_residual: float  # largest LMI residual of the tubes flown (<= 0: certified)
    plan: Array  # (T - step + 1, 12) the nominal states from the entry to the end of the mission


@dataclass(frozen=True)
class AbortLibrary:
    """The abort's set-up: hover reference, designs, the library's entries and the commit step (-1: no certified
    entry, the descent is committed from the start)."""

    hover: ReferenceTrajectory
    designs: Any  # _core.control.ControllerDesigns
    mpc_settings: Any  # _core.mpc.Settings
    controller_settings: Any  # _core.control.ControllerSettings
    entries: tuple[AbortEntry, ...]
    commit_step: int
    setup_time_s: float


def _positions_A(scn: Scenario, x: npt.ArrayLike, t: npt.ArrayLike) -> Array:
    """Positions (m, (n, 3)) in the body frame A of states ``x`` (n, 12) at times ``t`` (n,)."""
    X = np.atleast_2d(np.asarray(x, dtype=float))
    times = np.atleast_1d(np.asarray(t, dtype=float))
    return np.array([np.asarray(scn.model.C_AL(float(tk))) @ X[i, :3] for i, tk in enumerate(times)])


def height_above_site(scn: Scenario, x: npt.ArrayLike, t: npt.ArrayLike) -> Array:
    """Height (m) of states ``x`` (n, 12) at times ``t`` (n,) above the site's surface along its normal."""
    assert scn.site is not None
    return np.asarray((_positions_A(scn, x, t) - scn.site.surface_A) @ scn.site.normal_A, dtype=float)


def hover_reference(scn: Scenario) -> ReferenceTrajectory:
    """The abort's hover over the descent's time base, one horizon past its end (see the module comment)."""
    cfg = scn.config
    if scn.site is None:
        raise ValueError('abort.enabled: the abort hovers above the landing site: it needs boundary.terminal = "site"')
    ref, dt = scn.reference, cfg.mpc.dt
    # past the mission's end by one horizon: the abort controller never enters the MPC's shrinking phase (the hover
    # is a state to hold, not a terminal set to reach)
    n = scn.n_steps + cfg.mpc.horizon
    times = np.arange(n + 1, dtype=np.float64) * dt
    point_A = scn.site.surface_A + cfg.abort.hover_altitude * scn.site.normal_A
    X = np.array(
        [
            terminal_state(
                point_A,
                scn.site.normal_A,
                scn.model.C_AL(float(t)),
                scn.model.rotation_rate_AL,
                cfg.spacecraft.boresight_B,
                ref.x[min(k, scn.n_steps), 6:9],
            )
            for k, t in enumerate(times)
        ]
    )
    U = np.zeros((n, 6))
    for _ in range(_HOVER_INPUT_ITERATIONS):
        Ad, Bd, cd = scn.model.discretize(0.0, X[:-1], U, dt)
        miss = X[1:] - (np.einsum("kij,kj->ki", Ad, X[:-1]) + np.einsum("kij,kj->ki", Bd, U) + cd)
        U = U + np.array([np.linalg.lstsq(Bd[k], miss[k], rcond=None)[0] for k in range(len(U))])
    Ad, Bd, cd = scn.model.discretize(0.0, X[:-1], U, dt)
    defect = X[1:] - (np.einsum("kij,kj->ki", Ad, X[:-1]) + np.einsum("kij,kj->ki", Bd, U) + cd)
    u_max, T_max = scn.input_bounds
    if np.abs(U[:, :3]).max() > u_max or np.abs(U[:, 3:]).max() > T_max:
        raise ValueError(
            f"{cfg.source}: abort.hover_altitude: holding the hover needs more than the input bounds "
            f"({np.abs(U[:, :3]).max():.3g} m/s^2 of {u_max:.3g})"
        )
    return ReferenceTrajectory(
        t=times,
        x=X,
        u=U,
        cost=float(np.sum(np.linalg.norm(U[:, :3], axis=1) + np.linalg.norm(U[:, 3:], axis=1)) * dt),
        iterations=_HOVER_INPUT_ITERATIONS,
        converged=True,
        max_step=0.0,
        max_defect=float(np.abs(defect).max()),
        solve_time_s=0.0,
    )


def _abort_scenario(scn: Scenario, hover: ReferenceTrajectory) -> Scenario:
    """The scenario with the hover as its reference (its designs and settings computed about it)."""
    return dataclasses.replace(scn, reference=hover, xf=hover.x[-1])


def new_abort(scn: Scenario, library: AbortLibrary, commit_step: int | None = None) -> Any:
    """A ``_core.control.SafeAbort`` set up with the library's hover and designs, armed up to its commit step (or
    ``commit_step``) with the triggers of ``[abort]``."""
    a = scn.config.abort
    s = _core.control.AbortSettings()
    s.commit_step = library.commit_step if commit_step is None else commit_step
    s.on_navigation_fault = a.on_navigation_fault
    s.on_tube_uncertified = a.on_tube_uncertified
    s.on_allocation_infeasible = a.on_allocation_infeasible
    abort = _core.control.SafeAbort(
        _core.mpc.LinearizedProximityModel(scn.model.core), library.mpc_settings, library.controller_settings, s
    )
    h = library.hover
    abort.setup(_core.mpc.Reference(h.x.T.copy(), h.u.T.copy(), 0.0), library.designs)
    return abort


def _fly_entry(scn: Scenario, abort: Any, k0: int, u_bounds: Array) -> AbortEntry:
    """The nominal abort from the descent's reference state at step ``k0`` (see the module comment)."""
    T, dt = scn.n_steps, scn.config.mpc.dt
    abort.reset()
    x = scn.reference.x[k0].copy()
    plan = [x]
    residual, reasons = -np.inf, []
    for k in range(k0, T):
        step = abort.step(k, x)
        if not all(_core.control.certified(s) for s in step.tube_status):
            reasons.append(f"tube not certified at step {k}")
        residual = max(residual, *step.residual)
        if str(step.mpc.status).startswith("fallback"):
            reasons.append(f"fallback at step {k} ({step.mpc.status})")
        if np.any(np.abs(np.asarray(step.u)) > u_bounds * (1.0 + _INPUT_TOLERANCE)):
            reasons.append(f"input beyond its bound at step {k}")
        u = np.asarray(step.u, dtype=float)
        Ad, Bd, cd = scn.model.discretize(k * dt, x, u, dt)  # the controller's model, undisturbed
        x = Ad @ x + Bd @ u + cd
        plan.append(x)
    P = np.array(plan)
    t = np.arange(k0, T + 1) * dt
    heights = height_above_site(scn, P, t)
    if np.any(inside(scn.shape, _positions_A(scn, P, t))):
        reasons.append("a state inside the body")
    cone = max(scn.model.glide_slope(P[i], float(tk))[0] for i, tk in enumerate(t))
    if cone > _CONE_TOLERANCE_M:
        reasons.append(f"outside the glide-slope cone by {cone:.3g} m")
    if residual > 0.0:
        reasons.append(f"LMI residual {residual:.3g} > 0")
    if heights[-1] < scn.config.abort.safe_altitude:
        reasons.append(f"ends {heights[-1]:.3g} m above the site, below abort.safe_altitude")
    return AbortEntry(
        step=k0,
        certified=not reasons,
        reason="; ".join(dict.fromkeys(reasons)),
        lowest_height_m=float(heights.min()),
        final_height_m=float(heights[-1]),
        max_glide_slope_m=float(cone),
        max_residual=float(residual),
        plan=P,
    )


def abort_library(scn: Scenario) -> AbortLibrary:
    """The abort's set-up for the scenario (computed once per scenario; see the module comment)."""
    if "abort" in scn.tube_designs:
        library: AbortLibrary = scn.tube_designs["abort"]
        return library
    t0 = time.perf_counter()
    hover = hover_reference(scn)
    abort_scn = _abort_scenario(scn, hover)
    designs = controller_designs(abort_scn, "ffa")
    partial = AbortLibrary(
        hover=hover,
        designs=designs,
        mpc_settings=mpc_settings(abort_scn),
        controller_settings=controller_settings(abort_scn, "ffa"),
        entries=(),
        commit_step=-1,
        setup_time_s=0.0,
    )
    abort = new_abort(scn, partial, commit_step=-1)
    u_max, T_max = scn.input_bounds
    bounds = np.r_[[u_max] * 3, [T_max] * 3]
    entries = tuple(_fly_entry(scn, abort, k, bounds) for k in range(0, scn.n_steps, scn.config.abort.entry_period))
    commit = -1
    for e in entries:
        if not e.certified:
            break
        commit = e.step
    library = dataclasses.replace(partial, entries=entries, commit_step=commit, setup_time_s=time.perf_counter() - t0)
    scn.tube_designs["abort"] = library
    return library


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
