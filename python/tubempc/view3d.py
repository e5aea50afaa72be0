"""Interactive 3D view of a run for the HTML report (plotly; self-contained: plotly.js is inlined,
nothing is fetched when the page opens).

In the orbital frame L (m): the asteroid at t_f, the glide-slope cone at t_f (apex at the site,
axis along the cone's axis), the reference and the actual trajectory of each method, the
translational tubes (the position block of Pe_p, true scale, centred on the plan's nominal state z)
every ``tube_every`` steps, and the landing site. The camera is plotly's: drag to turn, scroll to zoom.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from .landing_site import cone_grid
from .results import RunRecord
from .scenario import Scenario, landing_geometry

__all__ = ["mission_view_html"]

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


def mission_view_html(
    scn: Scenario, records: Mapping[str, RunRecord], *, tube_every: int = 30, div_id: str = "mission-view"
) -> str:
    """An HTML fragment (a div with the figure and plotly.js inlined) of the mission's 3D view."""
    import plotly.graph_objects as go
    from matplotlib.colors import to_hex

    from .figures import METHOD_COLORS

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
    return str(fig.to_html(full_html=False, include_plotlyjs=True, div_id=div_id))
