"""The certified safe abort's set-up (docs/model.md M52 "Safe abort"; issue #43): the hover reference, the abort
controller's certified designs and their envelope, and the library of nominal aborts from entries over the descent
with the commit step (how a run with the abort ended: :mod:`tubempc.sim.abort`).

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
from ..scenario.build import Scenario, mpc_settings
from ..scenario.reference import ReferenceTrajectory
from ..scenario.sites import inside, terminal_state
from .library import controller_designs, controller_settings

__all__ = [
    "AbortEntry",
    "AbortLibrary",
    "abort_library",
    "abort_settings",
    "command_step",
    "design_envelope",
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
    #: per subsystem (p, r), the largest ratio c to the prior's disturbance set such that c times the prior's set
    #: lies inside a design of the abort's library: the identified sets, shaped as the prior, the abort can certify
    envelope: tuple[float, float] = (0.0, 0.0)


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


def design_envelope(designs: Any, settings: Any) -> tuple[float, float]:
    """Per subsystem the largest c with c P_W0 inside a library design's set (P_W0 = pw_scale S^_0, the identifier's
    prior): 1 / min over the designs of lambda_max(P_design^-1 P_W0) (``_core.control.cover_ratio``)."""
    out = []
    for library, ident in ((designs.library_p, settings.identification_p), (designs.library_r, settings.identification_r)):
        prior = ident.pw_scale * np.asarray(ident.S0)
        out.append(max((1.0 / _core.control.cover_ratio(prior, np.asarray(d.P_W)) for d in library), default=0.0))
    return out[0], out[1]


def _abort_scenario(scn: Scenario, hover: ReferenceTrajectory) -> Scenario:
    """The scenario with the hover as its reference (its designs and settings computed about it)."""
    return dataclasses.replace(scn, reference=hover, xf=hover.x[-1])


def abort_settings(scn: Scenario, library: AbortLibrary, commit_step: int | None = None) -> Any:
    """The supervision's ``_core.control.AbortSettings``: ``[abort]``'s triggers and limits, armed up to the library's
    commit step (or ``commit_step``)."""
    a = scn.config.abort
    s = _core.control.AbortSettings()
    s.commit_step = library.commit_step if commit_step is None else commit_step
    for name in s.field_names():  # the [abort] fields of the C++ names (one name per option)
        if name != "commit_step":
            setattr(s, name, getattr(a, name))
    return s


def command_step(scn: Scenario) -> int:
    """The step of the abort commanded at ``abort.command_time`` (-1: none)."""
    t = scn.config.abort.command_time
    return round(t / scn.config.mpc.dt) if t > 0.0 else -1


def new_abort(scn: Scenario, library: AbortLibrary, commit_step: int | None = None) -> Any:
    """A ``_core.control.SafeAbort`` set up with the library's hover and designs, armed up to its commit step (or
    ``commit_step``) with the triggers of ``[abort]``."""
    abort = _core.control.SafeAbort(
        _core.mpc.LinearizedProximityModel(scn.model.core),
        library.mpc_settings,
        library.controller_settings,
        abort_settings(scn, library, commit_step),
    )
    abort.setup(library.hover.core(), library.designs)
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
    settings = controller_settings(abort_scn, "ffa")
    envelope = design_envelope(designs, settings)
    limit = scn.config.abort.disturbance_limit
    if scn.config.abort.on_disturbance_beyond_limit and limit > min(envelope):
        raise ValueError(
            f"{scn.config.source}: abort.disturbance_limit: {limit:g} is beyond what the abort's designs certify "
            f"({envelope[0]:.3g} x the prior's set in translation, {envelope[1]:.3g} in rotation): the descent would "
            "back away under a disturbance its abort cannot certify"
        )
    partial = AbortLibrary(
        hover=hover,
        designs=designs,
        mpc_settings=mpc_settings(abort_scn),
        controller_settings=settings,
        entries=(),
        commit_step=-1,
        setup_time_s=0.0,
        envelope=envelope,
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
