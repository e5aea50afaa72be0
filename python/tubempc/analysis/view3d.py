"""Interactive 3D view of a run for the HTML report (plotly; self-contained: plotly.js is inlined,
nothing is fetched when the page opens).

In the orbital frame L (m): the asteroid at t_f, the glide-slope cone at t_f (apex at the site,
axis along the cone's axis), the reference and the actual trajectory of each method, the
translational tubes (the position block of Pe_p, true scale, centred on the plan's nominal state z)
every ``tube_every`` steps, and the landing site. The camera is plotly's: drag to turn, scroll to zoom.

A run flown on navigation also shows the navigation camera's footprint (:func:`camera_footprint`) at a
few sampled times, chosen with a slider: the asteroid as it was at that time, the image border's rays
cast on the shape (the outline on the surface), the frustum's corner edges from the spacecraft, the
boresight's hit and the landmarks the camera sees in that frame.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from ..results.records import RunRecord
from ..scenario.build import Scenario, landing_geometry
from ..scenario.navigation import landmark_catalogue, navigation_settings, sensor_caster
from ..scenario.sites import cone_grid

__all__ = ["CameraFootprint", "FootprintCaster", "camera_footprint", "mission_view_html"]

Array = npt.NDArray[np.float64]

_NAMES = {"tbmpc": "TBMPC", "ffa": "TBMPC-FFA"}


def _ellipsoid(center: Array, P: Array, n: int = 10) -> tuple[Array, Array, Array, Array, Array, Array]:
    """A triangulated ellipsoid {c + L s : |s| = 1}, P = L L^T: vertex coordinates and faces i, j, k."""
    L = np.linalg.cholesky(0.5 * (P + P.T))
    th, ph = np.meshgrid(np.linspace(0.0, np.pi, n), np.linspace(0.0, 2.0 * np.pi, 2 * n))
    s = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1).reshape(-1, 3)
    v = center + s @ L.T
    rows, cols = ph.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    a, b = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    c, d = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return v[:, 0], v[:, 1], v[:, 2], np.r_[a, a], np.r_[b, c], np.r_[c, d]


@dataclass(frozen=True)
class CameraFootprint:
    """The navigation camera's field of view on the body at one time ``t`` (s), in the orbital frame L
    at ``t`` (m; the body as it is at ``t``: vertices_A @ C_AL(t)).

    The image border is sampled by rays through its pixels (the four corners first, then
    ``n_edge`` points per side), each cast on the shape from the camera; a ray that meets no
    surface within the camera's ``max_range`` (the limb in view) has NaN in ``outline_L``."""

    t: float  #: time (s)
    apex_L: Array  #: camera position (3,) (m): the spacecraft's centre of mass, as the C++ camera
    boresight_L: Array  #: unit boresight z_C in L (3,)
    centre_L: Array  #: hit of the boresight ray (3,) (m), NaN when it misses
    corner_directions_L: Array  #: unit rays through the image corners (4, 3), pixel (0, 0), (W, 0), (W, H), (0, H)
    corners_L: Array  #: their hits (4, 3) (m), NaN rows for misses
    outline_L: Array  #: hits along the image border, closed ((4 n_edge + 1), 3) (m), NaN rows for misses
    landmarks: list[int]  #: catalogue indices of the landmarks in the frame (the C++ camera's selection)
    landmarks_L: Array  #: their positions (len(landmarks), 3) (m)


class FootprintCaster:
    """What :func:`camera_footprint` needs of a scenario, built once: the C++ camera settings of the
    run's configuration (``navigation_settings``: the same C_BC, focal length and image size the
    run's camera had), the sensors' ray caster and, with ``landmarks``, a C++ ``NavCamera`` on the
    run's landmark catalogue (for its visibility tests: range, emission, Sun incidence, occlusion)."""

    def __init__(self, scn: Scenario, *, landmarks: bool = True) -> None:
        self.scn = scn
        self.settings = navigation_settings(scn.config).camera
        self.caster = sensor_caster(scn)
        self.camera = _core.nav.NavCamera(self.caster, landmark_catalogue(scn), self.settings, 0) if landmarks else None


def _border_pixels(width: float, height: float, n_edge: int) -> Array:
    """Pixels (u, v) of the image border: the four corners, then a closed walk of n_edge points per side."""
    corners = np.array([[0.0, 0.0], [width, 0.0], [width, height], [0.0, height]])
    s = np.linspace(0.0, 1.0, n_edge, endpoint=False)[:, None]
    walk = [corners[i] + s * (corners[(i + 1) % 4] - corners[i]) for i in range(4)]
    return np.concatenate([corners, *walk, corners[:1]])


def camera_footprint(
    scn: Scenario, x: npt.ArrayLike, t: float, *, n_edge: int = 16, caster: FootprintCaster | None = None
) -> CameraFootprint:
    """The navigation camera's footprint at time ``t`` (s) for the 12-state ``x`` = [r_L (m), v_L (m/s),
    phi (rad), omega_BL_B (rad/s)] (``phi = log(q_B/L)``), in L at ``t``. A pixel (u, v) is seen
    along d_C = ((u - W/2) / f, (v - H/2) / f, 1) (the C++ camera's pinhole), d_A = C_AL(t) C_LB C_BC d_C,
    cast from r_A = C_AL(t) r_L on the sensors' shape up to the camera's ``max_range``. The landmarks
    are those the C++ camera's visibility test passes at (t, x), the first ``max_landmarks`` in catalogue
    order as a frame holds them (without the random dropout)."""
    if n_edge < 1:
        raise ValueError(f"n_edge must be >= 1, got {n_edge}")
    x = np.asarray(x, dtype=float)
    if x.shape != (12,) or not np.all(np.isfinite(x)):
        raise ValueError(f"x must be a finite 12-state, got shape {x.shape}")
    fc = caster if caster is not None else FootprintCaster(scn)
    cam = fc.settings
    C_AL = np.asarray(scn.model.C_AL(t))
    q_BL = _core.so3.exp_map(x[6:9])
    C_AC = C_AL @ np.asarray(_core.so3.rotation_matrix(q_BL)) @ np.asarray(cam.C_BC)
    r_A = C_AL @ x[:3]
    pixels = _border_pixels(float(cam.width_px), float(cam.height_px), n_edge)
    f = float(cam.focal_length_px)
    d_C = np.column_stack(
        [(pixels[:, 0] - 0.5 * cam.width_px) / f, (pixels[:, 1] - 0.5 * cam.height_px) / f, np.ones(len(pixels))]
    )
    d_C = np.vstack([[0.0, 0.0, 1.0], d_C])  # the boresight first
    d_A = d_C @ C_AC.T
    d_A /= np.linalg.norm(d_A, axis=1, keepdims=True)
    dist, _ = fc.caster.cast_batch(np.broadcast_to(r_A, d_A.shape), d_A, float(cam.max_range))
    hits_A = r_A + np.where(np.isfinite(dist), dist, np.nan)[:, None] * d_A
    to_L = C_AL.T
    hits_L, d_L = hits_A @ to_L.T, d_A @ to_L.T
    seen: list[int] = []
    catalogue = fc.camera.landmarks if fc.camera is not None else []
    if fc.camera is not None:
        truth = _core.nav.SensorTruth()
        truth.t, truth.r_L, truth.q_BL, truth.C_AL = t, x[:3], q_BL, C_AL
        for i in range(len(catalogue)):
            if len(seen) == cam.max_landmarks:
                break
            if fc.camera.visible(i, truth)[0]:
                seen.append(i)
    p_A = np.array([catalogue[i].p_A for i in seen]).reshape(-1, 3)
    return CameraFootprint(
        t=float(t),
        apex_L=x[:3].copy(),
        boresight_L=d_L[0],
        centre_L=hits_L[0],
        corner_directions_L=d_L[1:5],
        corners_L=hits_L[1:5],
        outline_L=hits_L[5:],
        landmarks=seen,
        landmarks_L=p_A @ to_L.T,
    )


def mission_view_html(
    scn: Scenario,
    records: Mapping[str, RunRecord],
    *,
    tube_every: int = 30,
    div_id: str = "mission-view",
    footprints: int = 4,
) -> str:
    """An HTML fragment (a div with the figure and plotly.js inlined) of the mission's 3D view. A run
    flown on navigation adds the camera's footprint at ``footprints`` times spread evenly over the run
    (0: none), one shown at a time, picked with a slider (:func:`_add_footprints`)."""
    import plotly.graph_objects as go
    from matplotlib.colors import to_hex

    from .figures import EVENT_MARKERS, METHOD_COLORS, fault_events

    cfg = scn.config
    t_f = cfg.mpc.t_f
    vertices, faces, apex, axis = landing_geometry(scn, t_f)
    fig = go.Figure()
    fig.add_trace(
        go.Mesh3d(
            x=vertices[:, 0],
            y=vertices[:, 1],
            z=vertices[:, 2],
            i=faces[:, 0],
            j=faces[:, 1],
            k=faces[:, 2],
            color="#9a9a9a",
            opacity=1.0,
            flatshading=True,
            name="asteroid at t_f",
            showlegend=True,
            hoverinfo="skip",
        )
    )
    first = next(iter(records.values()))
    ref = first.zbar[:, :3]
    # The cone up to the trajectories' reach, its rim within the scene's extent (as in Figure 3).
    scene = np.concatenate([vertices, ref, *(r.x[:, :3] for r in records.values())])
    half = 0.55 * float(np.max(scene.max(axis=0) - scene.min(axis=0)))
    reach = float(np.max(np.linalg.norm(ref - apex, axis=1)))
    height = min(reach, half / np.tan(cfg.constraints.glide_slope_angle))
    cx, cy, cz = cone_grid(apex, axis, cfg.constraints.glide_slope_angle, height, n_height=8, n_turn=40)
    fig.add_trace(
        go.Surface(
            x=cx,
            y=cy,
            z=cz,
            opacity=0.15,
            showscale=False,
            colorscale=[[0.0, "#2ca02c"], [1.0, "#2ca02c"]],
            name="glide-slope cone at t_f",
            showlegend=True,
            hoverinfo="skip",
        )
    )
    fig.add_trace(
        go.Scatter3d(
            x=ref[:, 0],
            y=ref[:, 1],
            z=ref[:, 2],
            mode="lines",
            name="reference",
            line={"color": "black", "width": 3, "dash": "dot"},
        )
    )
    for method, rec in records.items():
        color, name = to_hex(METHOD_COLORS.get(method, "0.35")), _NAMES.get(method, method)
        x = rec.x[:, :3]
        fig.add_trace(
            go.Scatter3d(
                x=x[:, 0], y=x[:, 1], z=x[:, 2], mode="lines", name=f"{name} actual", line={"color": color, "width": 5}
            )
        )
        for event, k in fault_events(rec).items():  # the fault's onset, its detection, the abort
            _, marker_color = EVENT_MARKERS[event]
            fig.add_trace(
                go.Scatter3d(
                    x=[x[k, 0]],
                    y=[x[k, 1]],
                    z=[x[k, 2]],
                    mode="markers",
                    name=f"{name}: {event} ({rec.t[k]:.0f} s)",
                    marker={"color": to_hex(marker_color), "size": 6, "symbol": "cross"},
                )
            )
        first_tube = True
        for k in range(0, rec.Pe_p.shape[0], tube_every):
            ex, ey, ez, i, j, kk = _ellipsoid(rec.z[k, :3], rec.Pe_p[k, :3, :3])
            fig.add_trace(
                go.Mesh3d(
                    x=ex,
                    y=ey,
                    z=ez,
                    i=i,
                    j=j,
                    k=kk,
                    color=color,
                    opacity=0.35,
                    name=f"{name} tube (true scale)",
                    legendgroup=f"{method}-tube",
                    showlegend=first_tube,
                    hoverinfo="skip",
                )
            )
            first_tube = False
    site = first.zbar[-1, :3]
    fig.add_trace(
        go.Scatter3d(
            x=[site[0]],
            y=[site[1]],
            z=[site[2]],
            mode="markers",
            name="landing site at t_f",
            marker={"color": "#ff7f0e", "size": 6, "symbol": "diamond"},
        )
    )
    flown = [m for m in ("ffa", *records) if m in records and records[m].navigation is not None]
    if footprints > 0 and flown and scn.config.navigation.enabled:
        _add_footprints(fig, scn, flown[0], records[flown[0]], footprints)
    fig.update_layout(
        scene={
            "xaxis_title": "x_L (m)",
            "yaxis_title": "y_L (m)",
            "zaxis_title": "z_L (m)",
            "aspectmode": "data",
        },
        legend={"itemsizing": "constant"},
        margin={"l": 0, "r": 0, "t": 30, "b": 0},
        height=700,
        title={"text": "Mission in the orbital frame L (drag to turn, scroll to zoom)", "font": {"size": 14}},
    )
    if fig.layout.sliders:  # room for the footprints' slider below the scene
        fig.update_layout(margin={"b": 70}, height=770)
    return str(fig.to_html(full_html=False, include_plotlyjs=True, div_id=div_id))


def _add_footprints(fig: Any, scn: Scenario, method: str, rec: RunRecord, count: int) -> None:
    """Adds ``count`` camera footprints of ``rec`` (the asteroid at each time, the outline, the frustum's
    corner edges, the boresight's hit, the landmarks in the frame) and a slider showing one at a time;
    the asteroid at t_f (the figure's first trace) is hidden while a footprint is shown."""
    import plotly.graph_objects as go

    fc = FootprintCaster(scn)
    n_base = len(fig.data)
    steps_k = np.unique(np.round(np.linspace(0, len(rec.t) - 1, count)).astype(int))
    groups: list[list[int]] = []
    name = _NAMES.get(method, method)
    for k in steps_k:
        t = float(rec.t[k])
        fp = camera_footprint(scn, rec.x[k], t, caster=fc)
        vertices_L, faces = landing_geometry(scn, t)[:2]
        first = len(fig.data)
        fig.add_trace(
            go.Mesh3d(
                x=vertices_L[:, 0],
                y=vertices_L[:, 1],
                z=vertices_L[:, 2],
                i=faces[:, 0],
                j=faces[:, 1],
                k=faces[:, 2],
                color="#9a9a9a",
                flatshading=True,
                name=f"asteroid at t = {t:g} s",
                showlegend=True,
                hoverinfo="skip",
            )
        )
        o = fp.outline_L
        fig.add_trace(
            go.Scatter3d(
                x=o[:, 0],
                y=o[:, 1],
                z=o[:, 2],
                mode="lines",
                connectgaps=False,
                name=f"camera footprint at t = {t:g} s ({name})",
                line={"color": "#d62728", "width": 6},
            )
        )
        reach = float(np.nanmax(np.linalg.norm(fp.corners_L - fp.apex_L, axis=1), initial=0.0))
        reach = reach if reach > 0.0 else float(np.linalg.norm(fp.apex_L))
        edges: list[Array] = []
        for d, hit in zip(fp.corner_directions_L, fp.corners_L, strict=True):
            end = hit if np.all(np.isfinite(hit)) else fp.apex_L + reach * d
            edges += [fp.apex_L, end, np.full(3, np.nan)]
        e = np.array(edges)
        fig.add_trace(
            go.Scatter3d(
                x=e[:, 0],
                y=e[:, 1],
                z=e[:, 2],
                mode="lines",
                connectgaps=False,
                name="field-of-view edges",
                line={"color": "#d62728", "width": 2, "dash": "dash"},
            )
        )
        points = np.vstack([fp.apex_L, fp.centre_L])
        fig.add_trace(
            go.Scatter3d(
                x=points[:, 0],
                y=points[:, 1],
                z=points[:, 2],
                mode="markers",
                name="spacecraft and boresight hit",
                marker={"color": ["#1f77b4", "#d62728"], "size": 5, "symbol": ["circle", "cross"]},
            )
        )
        lm = fp.landmarks_L
        fig.add_trace(
            go.Scatter3d(
                x=lm[:, 0],
                y=lm[:, 1],
                z=lm[:, 2],
                mode="markers",
                name=f"{len(fp.landmarks)} landmarks in the frame",
                marker={"color": "#ffd700", "size": 3, "line": {"color": "black", "width": 1}},
            )
        )
        groups.append(list(range(first, len(fig.data))))
    n = len(fig.data)
    steps: list[dict[str, Any]] = []
    for g, k in zip(groups, steps_k, strict=True):
        visible = [True] * n_base + [False] * (n - n_base)
        visible[0] = False  # the asteroid at t_f
        for i in g:
            visible[i] = True
        steps.append({"method": "restyle", "args": [{"visible": visible}], "label": f"{float(rec.t[k]):g} s"})
    steps.append({"method": "restyle", "args": [{"visible": [True] * n_base + [False] * (n - n_base)}], "label": "none"})
    active = max(0, len(groups) - 2)  # late in the descent: the body has turned little since t_f
    for i, v in enumerate(steps[active]["args"][0]["visible"]):
        fig.data[i].visible = v
    fig.update_layout(
        sliders=[
            {
                "active": active,
                "currentvalue": {"prefix": "navigation camera at t = "},
                "pad": {"t": 10},
                "steps": steps,
            }
        ]
    )
