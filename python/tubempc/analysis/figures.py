"""Figures equivalent to the paper's Figures 3-18, drawn with matplotlib (Agg) from result arrays.

Every function takes closed-loop records by method (:class:`tubempc.results.RunRecord`, which
declares each array's shape and unit) and returns a Figure, which :func:`save` writes as PNG. Units
are SI and written on every axis.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from ..results.records import RunRecord
from ..scenario.sites import SiteMap, cone_grid
from .metrics import ConvergenceFit, prior_bound_exceedances

__all__ = [
    "EVENT_MARKERS",
    "METHOD_COLORS",
    "ROTATION",
    "TRANSLATION",
    "actuation",
    "constraints",
    "controls",
    "convergence",
    "disturbances",
    "errors",
    "exceedances",
    "fault_events",
    "fault_timeline",
    "lambda_sensitivity",
    "landmarks_visible",
    "montecarlo_envelopes",
    "navigation_errors",
    "save",
    "states",
    "touchdown_dispersion",
    "trajectory_3d",
    "tube_projections",
]

_STATE_LABELS = [
    ("x (m)", "y (m)", "z (m)"),
    ("vx (m/s)", "vy (m/s)", "vz (m/s)"),
    ("phi_x (rad)", "phi_y (rad)", "phi_z (rad)"),
    ("omega_x (rad/s)", "omega_y (rad/s)", "omega_z (rad/s)"),
]
_GROUP_TITLES = ["position r_L", "velocity v_L", "attitude phi (Lie algebra)", "angular velocity omega_BL_B"]
#: Colour of each method (and the reference) in every figure and the report's 3D view.
METHOD_COLORS = {"tbmpc": "tab:orange", "ffa": "tab:blue", "ref": "k"}
# Both methods are drawn in the same axes and often nearly coincide: TBMPC wide and solid underneath,
# TBMPC-FFA narrow and dashed on top, so that every legend entry stays visible.
_STYLE = {"tbmpc": {"lw": 2.4, "ls": "-", "zorder": 2}, "ffa": {"lw": 1.0, "ls": "--", "zorder": 3}}


def _style(name: str, **extra: Any) -> dict[str, Any]:
    return {"color": METHOD_COLORS.get(name), **_STYLE.get(name, {"lw": 1.2}), **extra}


def fault_timeline(results: Mapping[str, RunRecord], heights: Mapping[str, np.ndarray], commit_time: float | None) -> Figure:
    """The fault timeline of each run: its height above the site (``heights``, m, per step) against time, with the
    fault's onset, its detection and the abort's entry or refusal (:func:`fault_events`), the abort's commit time
    (None: not armed) and, flown on navigation, the navigation's latched fault flag."""
    fig, (ax, ax_flag) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    for name, r in results.items():
        ax.plot(r.t, heights[name], **_style(name), label=f"{name} height above the site")
        for event, k in fault_events(r).items():
            marker, color = EVENT_MARKERS[event]
            ax.scatter(r.t[k], heights[name][k], marker=marker, color=color, s=60, zorder=3, label=f"{name}: {event}")
            ax.axvline(r.t[k], color=color, lw=0.8, ls=":")
        if r.navigation is not None:
            ax_flag.step(r.t, r.navigation.fault_detected, where="post", **_style(name), label=f"{name} fault detected")
    if commit_time is not None:
        ax.axvline(commit_time, color="k", lw=1.0, ls="--", label=f"commit ({commit_time:.0f} s)")
    ax.set_ylabel("height above the site (m)")
    ax.set_title("Fault timeline: onset, detection and abort", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    ax_flag.set_ylabel("detected")
    ax_flag.set_yticks([0, 1])
    ax_flag.set_xlabel("t (s)")
    fig.tight_layout()
    return fig


def save(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Writes the figure as PNG and closes it."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return p


def _cone_surface(
    ax: Any, half_angle: float, apex: np.ndarray, axis: np.ndarray, height: float, color: str, label: str
) -> None:
    ax.plot_surface(*cone_grid(apex, axis, half_angle, height), color=color, alpha=0.07, linewidth=0)
    ax.plot([], [], color=color, alpha=0.4, label=label)


#: The markers of a run's fault and abort events (:func:`fault_events`): label -> (matplotlib marker, colour).
EVENT_MARKERS = {
    "fault onset": ("X", "tab:red"),
    "fault detected": ("D", "tab:orange"),
    "abort entered": ("^", "tab:purple"),
    "abort refused (committed)": ("v", "tab:brown"),
}


def fault_events(rec: RunRecord) -> dict[str, int]:
    """A run's fault and abort events as steps of its record: the injected fault's onset, the navigation's first
    detection, the abort's entry or a refused trigger (``applied``'s ``fault``, ``fault_detection``, ``abort``);
    empty for a run without them. A time falls on the first step at or after it."""
    applied = rec.applied or {}
    dt = float(rec.t[1] - rec.t[0]) if len(rec.t) > 1 else 1.0
    last = len(rec.t) - 1

    def step(t: float) -> int:
        return min(last, int(np.ceil(t / dt - 1e-9)))

    out: dict[str, int] = {}
    fault = applied.get("fault")
    if fault is not None:
        out["fault onset"] = step(float(fault["start"]))
    det = applied.get("fault_detection") or {}
    if det.get("detected"):
        t = (det.get("detected_at") or {}).get(det.get("cause"))
        if t is not None:
            out["fault detected"] = step(float(t))
    abort = applied.get("abort") or {}
    if abort.get("entered_at_step") is not None:
        out["abort entered"] = int(abort["entered_at_step"])
    if abort.get("refused_at_step") is not None:
        out["abort refused (committed)"] = int(abort["refused_at_step"])
    return out


def trajectory_3d(
    results: Mapping[str, RunRecord],
    glide_slope_rad: float,
    every: int = 25,
    *,
    body_L: tuple[np.ndarray, np.ndarray] | None = None,
    cone_L: tuple[np.ndarray, np.ndarray] | None = None,
) -> Figure:
    """Fig. 3: actual trajectories in L with the asteroid (``body_L``: vertices in L at t_f (m) and
    faces), the glide-slope cone at t_f (``cone_L``: apex (m) and axis in L; default the paper's)
    and predicted horizons. The axes span the trajectories and the body, not the cone."""
    fig = plt.figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    ref = next(iter(results.values())).zbar
    pts = [ref[:, :3], *(r.x[:, :3] for r in results.values())]
    if body_L is not None:
        v, f = body_L
        ax.plot_trisurf(v[:, 0], v[:, 1], v[:, 2], triangles=f, color="0.6", alpha=0.35, linewidth=0)
        ax.plot([], [], color="0.6", lw=6, alpha=0.5, label="asteroid at t_f")
        pts.append(v)
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    apex, axis = cone_L if cone_L is not None else (np.zeros(3), np.array([0.0, 0.0, 1.0]))
    centre, half = 0.5 * (lo + hi), 0.55 * float(np.max(hi - lo))
    reach = float(np.max(np.linalg.norm(ref[:, :3] - apex, axis=1)))
    height = min(reach, half / np.tan(glide_slope_rad))  # the cone's rim stays inside the axes
    _cone_surface(ax, glide_slope_rad, apex, axis, height, "tab:green", "glide-slope cone at t_f")
    ax.plot(ref[:, 0], ref[:, 1], ref[:, 2], "k:", lw=1.2, label="reference")
    for name, r in results.items():
        x = r.x
        ax.plot(x[:, 0], x[:, 1], x[:, 2], **_style(name), label=f"{name} actual")
        for k in range(0, r.z_plan.shape[0], every):
            zp = r.z_plan[k]
            ax.plot(zp[:, 0], zp[:, 1], zp[:, 2], color=METHOD_COLORS.get(name), lw=0.6, alpha=0.5)
        for event, k in fault_events(r).items():
            marker, color = EVENT_MARKERS[event]
            ax.scatter(*x[k, :3], marker=marker, color=color, s=45, label=f"{name}: {event} ({r.t[k]:.0f} s)")
    ax.scatter(*ref[0, :3], color="g", s=30, label="start")
    ax.scatter(*ref[-1, :3], color="r", s=30, label="target at t_f")
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_xlabel("x_L (m)")
    ax.set_ylabel("y_L (m)")
    ax.set_zlabel("z_L (m)")
    ax.set_title(
        f"Trajectory in L (TBMPC solid, TBMPC-FFA dashed), predicted horizons (thin) every {every} steps", fontsize=9
    )
    ax.legend(loc="upper left", fontsize=8)
    return fig


#: State groups of the paper's figure pairs: position and velocity (Figs. 4, 6, 9), attitude and
#: angular velocity (Figs. 5, 7, 10).
TRANSLATION, ROTATION = (0, 1), (2, 3)


def _state_grid(groups: Sequence[int] = (0, 1, 2, 3)) -> tuple[Figure, Any]:
    """A grid of one row per state group in ``groups`` and one column per axis."""
    fig, axes = plt.subplots(len(groups), 3, figsize=(12, 2.75 * len(groups) + 0.5), sharex=True, squeeze=False)
    return fig, axes


def _finish_state_grid(
    fig: Figure,
    axes: Any,
    ylabel_prefix: str = "",
    title_prefix: str | None = None,
    suptitle: str = "",
    legend_size: int = 8,
    groups: Sequence[int] = (0, 1, 2, 3),
) -> Figure:
    for row, g in enumerate(groups):
        for i in range(3):
            axes[row, i].set_ylabel(ylabel_prefix + _STATE_LABELS[g][i])
            axes[row, i].grid(alpha=0.3)
        if title_prefix is not None:
            axes[row, 1].set_title(title_prefix + _GROUP_TITLES[g])
    for i in range(3):
        axes[-1, i].set_xlabel("t (s)")
    axes[0, 0].legend(fontsize=legend_size)
    if suptitle:
        fig.suptitle(suptitle)
    fig.tight_layout()
    return fig


def states(results: Mapping[str, RunRecord], groups: Sequence[int] = TRANSLATION) -> Figure:
    """Fig. 4 (``groups`` = TRANSLATION) or Fig. 5 (ROTATION): the states against the reference."""
    fig, axes = _state_grid(groups)
    ref = next(iter(results.values()))
    for row, g in enumerate(groups):
        for i in range(3):
            j = 3 * g + i
            for name, r in results.items():
                axes[row, i].plot(r.t, r.x[:, j], **_style(name), label=name)
            axes[row, i].plot(ref.t, ref.zbar[:, j], "k:", lw=1.0, label="reference", zorder=4)
    return _finish_state_grid(fig, axes, "", "", "States (TBMPC solid, TBMPC-FFA dashed, reference dotted)", groups=groups)


def errors(results: Mapping[str, RunRecord], groups: Sequence[int] = TRANSLATION) -> Figure:
    """Fig. 6 (``groups`` = TRANSLATION) or Fig. 7 (ROTATION): tracking errors x - zbar."""
    fig, axes = _state_grid(groups)
    for name, r in results.items():
        e = r.x - r.zbar
        for row, g in enumerate(groups):
            for i in range(3):
                axes[row, i].plot(r.t, e[:, 3 * g + i], **_style(name), label=name)
    return _finish_state_grid(fig, axes, "error ", "tracking error, ", groups=groups)


def controls(results: Mapping[str, RunRecord], u_max: float, T_max: float) -> Figure:
    """Fig. 8: commanded acceleration (L) and torque (B) with their limits."""
    fig, axes = plt.subplots(2, 3, figsize=(12, 6), sharex=True)
    labels = [("u_x (m/s^2)", "u_y (m/s^2)", "u_z (m/s^2)"), ("T_x (N m)", "T_y (N m)", "T_z (N m)")]
    for name, r in results.items():
        t = r.t[:-1]
        for g in range(2):
            for i in range(3):
                axes[g, i].step(t, r.u[:, 3 * g + i], where="post", color=METHOD_COLORS.get(name), lw=1.0, label=name)
    for g, lim in enumerate((u_max, T_max)):
        for i in range(3):
            ax = axes[g, i]
            ax.axhline(lim, color="r", ls=":", lw=0.8)
            ax.axhline(-lim, color="r", ls=":", lw=0.8)
            ax.set_ylabel(labels[g][i])
            ax.grid(alpha=0.3)
    for i in range(3):
        axes[-1, i].set_xlabel("t (s)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Inputs (dotted: limits)")
    fig.tight_layout()
    return fig


def actuation(results: Mapping[str, RunRecord], thrusters: int) -> Figure:
    """Fig. 15 (the project's): each method's thruster firings (on-time per thruster and period), the
    cumulative thruster delta-v and propellant, and the wheels' total momentum (docs/model.md M37)."""
    n = len(results)
    fig, axes = plt.subplots(n + 2, 1, figsize=(10, 2.6 * (n + 2)), sharex=True, squeeze=False)
    for row, (name, r) in enumerate(results.items()):
        ax = axes[row, 0]
        t = r.t[:-1]
        dt = float(t[1] - t[0]) if len(t) > 1 else 1.0
        on = r.thruster_on_time[:, :thrusters].T / dt
        im = ax.imshow(on, aspect="auto", origin="lower", extent=(t[0], t[-1] + dt, -0.5, thrusters - 0.5), cmap="viridis")
        ax.set_ylabel(f"{name}: thruster")
        fig.colorbar(im, ax=ax, label="on-time / period")
    for name, r in results.items():
        t, color = r.t[:-1], METHOD_COLORS.get(name)
        axes[n, 0].plot(t, np.cumsum(r.delta_v), color=color, label=f"{name} thruster delta-v (m/s)")
        axes[n, 0].plot(t, np.cumsum(r.propellant), color=color, ls="--", label=f"{name} propellant (kg)")
        axes[n + 1, 0].plot(t, np.linalg.norm(r.wheel_momentum, axis=1), color=color, label=name)
    axes[n, 0].set_ylabel("cumulative")
    axes[n + 1, 0].set_ylabel("|h_wheels| (N m s)")
    axes[n + 1, 0].set_xlabel("t (s)")
    for ax in axes[n:, 0]:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Actuators: firings, delta-v, propellant and wheel momentum")
    fig.tight_layout()
    return fig


def disturbances(
    results: Mapping[str, RunRecord],
    pw_scale: float = 9.0,
    prior_variances: np.ndarray | None = None,
    groups: Sequence[int] = TRANSLATION,
) -> Figure:
    """Fig. 9 (``groups`` = TRANSLATION) or Fig. 10 (ROTATION): measured exogenous inputs w with
    sqrt(pw_scale) sigma bounds: TBMPC-FFA's identified (mean and covariance after each step) and
    TBMPC's fixed ones from the prior variances (12,) when given (TBMPC designs its tube from the
    prior only)."""
    fig, axes = _state_grid(groups)
    k_sigma = float(np.sqrt(pw_scale))
    for name, r in results.items():
        t = r.t[1:]
        S = np.concatenate([np.diagonal(r.S_p, axis1=1, axis2=2), np.diagonal(r.S_r, axis1=1, axis2=2)], axis=1)
        w_hat = r.w_hat
        if name == "tbmpc" and prior_variances is not None:
            S = np.broadcast_to(np.asarray(prior_variances, dtype=float), S.shape)
            w_hat = np.zeros_like(w_hat)
        for row, g in enumerate(groups):
            for i in range(3):
                j = 3 * g + i
                _disturbance_axis(axes[row, i], name, t, r.w[:, j], w_hat[:, j], np.sqrt(S[:, j]), k_sigma)
    return _finish_state_grid(
        fig,
        axes,
        "w ",
        None,
        "Exogenous inputs per step and identified bounds (TBMPC: wide solid, FFA: dashed)",
        7,
        groups=groups,
    )


def _disturbance_axis(
    ax: Any, name: str, t: np.ndarray, w: np.ndarray, w_hat: np.ndarray, sigma: np.ndarray, k_sigma: float
) -> None:
    c = METHOD_COLORS.get(name)
    if name == "tbmpc":  # dots under the FFA's line: the two w nearly coincide (same disturbance)
        ax.plot(t, w, ".", color=c, ms=2.5, zorder=2, label=f"{name} w")
    else:
        ax.plot(t, w, color=c, lw=0.6, alpha=0.8, zorder=3, label=f"{name} w")
    style = _style(name, lw=_STYLE.get(name, {}).get("lw", 1.0))
    ax.plot(t, w_hat + k_sigma * sigma, **style, label=f"{name} ±{k_sigma:.0f} sigma")
    ax.plot(t, w_hat - k_sigma * sigma, **style)


def exceedances(record: RunRecord, prior_variances: np.ndarray, pw_scale: float = 9.0) -> Figure:
    """Fig. 11: TBMPC's measured attitude and angular-velocity exogenous inputs against its fixed
    sqrt(pw_scale)-sigma bounds from the prior variances (12,), the steps outside them marked."""
    fig, axes = _state_grid(ROTATION)
    k_sigma = float(np.sqrt(pw_scale))
    t = record.t[1:]
    outside = prior_bound_exceedances(record.w, prior_variances, pw_scale)
    for row, g in enumerate(ROTATION):
        for i in range(3):
            j, ax = 3 * g + i, axes[row, i]
            bound = k_sigma * float(np.sqrt(prior_variances[j]))
            out = outside[:, j]
            ax.plot(t, record.w[:, j], color=METHOD_COLORS["tbmpc"], lw=0.7, label="w (TBMPC)")
            ax.axhline(bound, color="k", ls="--", lw=1.0, label=f"TBMPC ±{k_sigma:.0f} sigma (prior)")
            ax.axhline(-bound, color="k", ls="--", lw=1.0)
            ax.plot(t[out], record.w[out, j], "rx", ms=5, label="outside the bound")
            ax.set_title(f"{int(out.sum())} of {out.size} steps outside", fontsize=8)
    return _finish_state_grid(
        fig,
        axes,
        "w ",
        None,
        "TBMPC's attitude exogenous inputs against its fixed bounds (paper Fig. 11)",
        7,
        groups=ROTATION,
    )


def tube_projections(results: Mapping[str, RunRecord]) -> Figure:
    """Fig. 12 (and 10): error x - z against the tube's half-widths sqrt(Pe_ii) per state."""
    fig, axes = _state_grid()
    for name, r in results.items():
        t = r.t[:-1]
        e = r.x[:-1] - r.z
        half = np.sqrt(
            np.concatenate([np.diagonal(r.Pe_p, axis1=1, axis2=2), np.diagonal(r.Pe_r, axis1=1, axis2=2)], axis=1)
        )
        for j in range(12):
            ax = axes[j // 3, j % 3]
            c = METHOD_COLORS.get(name)
            ax.plot(t, e[:, j], color=c, lw=1.0, label=f"{name} x - z")
            ax.fill_between(t, -half[:, j], half[:, j], color=c, alpha=0.12, label=f"{name} tube")
    return _finish_state_grid(fig, axes, "", None, "Actual minus nominal state inside the tube projections", 7)


def constraints(results: Mapping[str, RunRecord]) -> Figure:
    """Fig. 13: glide-slope and line-of-sight constraint values g (feasible when g <= 0)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for name, r in results.items():
        for j, title in enumerate(("glide slope", "line of sight")):
            axes[j].plot(r.t, r.g[:, j], **_style(name), label=name)
            axes[j].set_title(f"{title}: g(x) <= 0 (TBMPC solid, FFA dashed)")
    for ax in axes:
        ax.axhline(0.0, color="r", ls=":")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("g (m)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def convergence(
    t: np.ndarray, err: np.ndarray, fit: ConvergenceFit, label: str, unit: str = "m/s", title: str = ""
) -> Figure:
    """Fig. 14: error norm with the fitted envelope C rho^k ||e_0|| + ebar (Theorem 2); when no envelope
    exists (``fit.no_fit``), the error alone with ebar and the reason, no curve drawn as if fitted."""
    fig, ax = plt.subplots(figsize=(7, 4))
    k = np.arange(err.size)
    ax.semilogy(t[: err.size], err, label=f"||{label}||")
    if fit.exists:
        ax.semilogy(
            t[: err.size],
            fit.bound(k),
            "r--",
            label=f"C rho^k ||e0|| + ebar (C||e0||={fit.C * fit.e0:.3g} {unit}, rho={fit.rho:.4f} per step, "
            f"ebar={fit.ebar:.3g} {unit})",
        )
    else:
        ax.axhline(fit.ebar, color="r", ls=":", label=f"ebar = {fit.ebar:.3g} {unit}; no Theorem 2 envelope fitted")
        ax.text(0.02, 0.02, f"no fit: {fit.no_fit}", transform=ax.transAxes, fontsize=7, wrap=True, va="bottom")
    ax.set_title(title or f"Convergence of ||{label}|| (Theorem 2 envelope fitted from t = {t[0]:g} s)")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(f"||{label}|| ({unit})")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return fig


def lambda_sensitivity(
    t: np.ndarray, errors_by_lambda: Mapping[str, np.ndarray], tube_by_lambda: Mapping[str, np.ndarray], state_label: str
) -> Figure:
    """Figs. 15-16: error of one state and the tube half-width against the forgetting factor."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    for lam, e in errors_by_lambda.items():
        axes[0].plot(t[: e.size], e, lw=1.0, label=lam)
    for lam, h in tube_by_lambda.items():
        axes[1].plot(t[: h.size], h, lw=1.0, label=lam)
    axes[0].set_title(f"error {state_label}")
    axes[1].set_title(f"tube half-width sqrt(Pe_ii), {state_label}")
    for ax in axes:
        ax.set_xlabel("t (s)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def montecarlo_envelopes(
    t: np.ndarray, errors: Sequence[np.ndarray], half_width: np.ndarray, labels: Sequence[str], title: str
) -> Figure:
    """Figs. 17-18: Monte Carlo error trajectories (x - z) against the tube half-widths."""
    n = len(labels)
    fig, axes = plt.subplots(1, n, figsize=(4 * n, 3.6), sharex=True)
    for j, ax in enumerate(np.atleast_1d(axes)):
        for e in errors:
            ax.plot(t[: e.shape[0]], e[:, j], color="tab:blue", lw=0.4, alpha=0.35)
        ax.plot(t[: half_width.shape[0]], half_width[:, j], "r--", lw=1.0, label="largest tube half-width")
        ax.plot(t[: half_width.shape[0]], -half_width[:, j], "r--", lw=1.0)
        ax.set_title(labels[j])
        ax.set_xlabel("t (s)")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def navigation_errors(results: Mapping[str, RunRecord], groups: Sequence[int] = (0, 1, 2)) -> Figure:
    """Estimation error x - x^ per axis with the filter's 3-sigma bounds (runs flown on navigation)."""
    fig, axes = _state_grid(groups)
    for m, r in results.items():
        nav = r.navigation
        if nav is None:
            continue
        for row, g in enumerate(groups):
            for j in range(3):
                ax, i = axes[row, j], 3 * g + j
                ax.plot(r.t, nav.error[:, i], color=METHOD_COLORS.get(m, "k"), lw=0.9, label=f"{m}: x - x^")
                ax.plot(r.t, 3 * nav.sigma[:, i], color=METHOD_COLORS.get(m, "k"), ls=":", lw=0.9, label=f"{m}: 3 sigma")
                ax.plot(r.t, -3 * nav.sigma[:, i], color=METHOD_COLORS.get(m, "k"), ls=":", lw=0.9)
                ax.set_ylabel(_STATE_LABELS[g][j])
                ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("Estimation error and its 3-sigma bounds")
    fig.tight_layout()
    return fig


def landmarks_visible(results: Mapping[str, RunRecord]) -> Figure:
    """Landmarks in the last camera frame of each control period, with the navigation status."""
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for m, r in results.items():
        nav = r.navigation
        if nav is None:
            continue
        ax.step(r.t, nav.landmarks, where="post", label=m, **_style(m))
        bad = [k for k, s in enumerate(nav.status) if s != "ok"]
        if bad:
            ax.plot(r.t[bad], nav.landmarks[bad], "rx", label=f"{m}: not ok")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("landmarks in view")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _ellipse(offsets: np.ndarray, probability: float, n: int = 240) -> np.ndarray | None:
    """The closed curve ((n, 2), m) bounding ``probability`` of the Gaussian fitted to ``offsets``
    (sample mean and covariance): {m + L s : ``||s||`` = c}, P = L L^T, c^2 the chi-square quantile
    with 2 degrees of freedom; None for fewer than 3 points."""
    from scipy.stats import chi2

    if len(offsets) < 3:
        return None
    mean, cov = offsets.mean(axis=0), np.cov(offsets.T)
    w, V = np.linalg.eigh(cov)
    a = np.linspace(0.0, 2 * np.pi, n)
    c = np.sqrt(chi2.ppf(probability, 2))
    return np.asarray(mean + (c * np.sqrt(np.maximum(w, 0.0)) * np.column_stack([np.cos(a), np.sin(a)])) @ V.T)


def touchdown_dispersion(
    offsets: np.ndarray,
    site_label: str,
    probability: float = 0.997,
    goal_radius: float | None = None,
    *,
    site_map: SiteMap | None = None,
) -> Figure:
    """Touchdown dispersion on the site map: the runs' horizontal offsets from the target (m, (n, 2),
    (east, north) in the site's tangent plane, :func:`tubempc.scenario.sites.tangent_axes`), the ellipse
    holding ``probability`` of a Gaussian fitted to them and the goal circle of ``goal_radius`` (m)
    about the target. With ``site_map`` (:func:`tubempc.scenario.sites.site_map`), a first panel draws
    them over the site's surroundings (the shape's facets coloured by their height above the tangent
    plane, the camera's landmarks) and a second one zooms on the touchdowns."""
    from matplotlib.collections import PolyCollection

    offsets = np.asarray(offsets, dtype=float).reshape(-1, 2)
    ring = _ellipse(offsets, probability)
    a = np.linspace(0.0, 2 * np.pi, 200)
    reach = max(
        [goal_radius or 0.0, float(np.max(np.abs(offsets), initial=0.0))]
        + ([float(np.max(np.abs(ring)))] if ring is not None else [])
    )
    zoom = 1.25 * reach if reach > 0.0 else 1.0
    panels = 2 if site_map is not None else 1
    fig, axes = plt.subplots(1, panels, figsize=(5.5 * panels + (1.0 if site_map is not None else 0.0), 5.5), squeeze=False)
    for j, ax in enumerate(axes[0]):
        extent = site_map.radius if site_map is not None and j == 0 else zoom
        if site_map is not None:
            facets = PolyCollection(
                list(site_map.facets), array=site_map.heights, cmap="copper", edgecolors="0.35", linewidths=0.4, zorder=1
            )
            ax.add_collection(facets)
            if j == 0:
                fig.colorbar(facets, ax=ax, shrink=0.8, label="facet height above the tangent plane (m)")
            if len(site_map.landmarks):
                ax.plot(*site_map.landmarks.T, "^", color="w", mec="k", mew=0.5, ms=3.5, zorder=2, label="landmarks")
        ax.plot(offsets[:, 0], offsets[:, 1], ".", ms=3, color="tab:blue", zorder=3, label=f"{len(offsets)} runs")
        if ring is not None:
            ax.plot(ring[:, 0], ring[:, 1], "r-", lw=1.4, zorder=4, label=f"{100 * probability:.1f} % ellipse")
        if goal_radius is not None:
            ax.plot(
                goal_radius * np.cos(a), goal_radius * np.sin(a), "k--", lw=1.0, zorder=4, label=f"goal: {goal_radius:g} m"
            )
        ax.plot(0.0, 0.0, "k+", ms=12, mew=1.5, zorder=5, label="target")
        ax.set_xlim(-extent, extent)
        ax.set_ylim(-extent, extent)
        ax.set_aspect("equal")
        ax.set_xlabel("east (m)")
        ax.set_ylabel("north (m)")
        ax.grid(alpha=0.3)
        ax.set_title(("site map" if j == 0 else "zoom on the touchdowns") if site_map is not None else "")
    axes[0, -1].legend(fontsize=8, loc="upper right")
    fig.suptitle(f"Touchdown dispersion, {site_label}")
    fig.tight_layout()
    return fig
