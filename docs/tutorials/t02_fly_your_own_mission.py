"""
Fly your own mission
====================

A landing on a body of your own (here a generated rough ellipsoid, written as an OBJ file in metres),
at a site given by latitude and longitude on its surface, with your spacecraft's inertia and actuator
limits. A scenario file states only what differs from the paper's; every other field is the packaged
scenario's (the run says which ones it took).
"""

# %%
# The body
# --------
# :func:`tubempc.scenario.bodies.ellipsoid_shape` makes a closed, consistently oriented mesh (the same checks
# as every loaded shape); ``tubempc make-body ellipsoid --axes 300,220,180 --out body.obj`` is the
# command-line equivalent. Any OBJ, PDS v/f table, ICQ, PLY or STL file can take its place.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from tubempc.analysis.runner import run_methods
from tubempc.config import load_config
from tubempc.scenario.bodies import ellipsoid_shape
from tubempc.scenario.shapes import save_shape

work = Path(tempfile.mkdtemp(prefix="tubempc_tutorial2_"))
shape = ellipsoid_shape([300.0, 220.0, 180.0], subdivisions=10, roughness=0.02, seed=1)
save_shape(work / "body.obj", shape, unit="m")
print(f"body: {shape.faces.shape[0]} faces, volume {shape.volume:.4g} m^3")

# %%
# The scenario file
# -----------------
# The site is 20 deg north, 40 deg east on the body; the spacecraft hovers 400 m above it and lands
# 5 m above the surface, at rest relative to it, camera down, inside a glide-slope cone whose apex is
# the site and whose axis is the local surface normal (the cone turns with the body). The shape path
# is relative to the scenario file.
(work / "mission.toml").write_text(
    """
[asteroid]
shape = "body.obj"
shape_unit = "m"
density = "2000 kg/m^3"
spin_period = "6 h"

[spacecraft]
J = { value = [[900.0, 0.0, 0.0], [0.0, 900.0, 0.0], [0.0, 0.0, 700.0]], unit = "kg m^2" }
u_max = "0.4 m/s^2"
T_max = "2 N m"

[constraints]
glide_slope_apex = "site"
glide_slope_axis = "normal"

[boundary]
terminal = "site"
site = "lat_lon"
site_latitude = "20 deg"
site_longitude = "40 deg"
terminal_altitude = "5 m"
terminal_attitude = "boresight_down"
initial = "hover"
hover_altitude = "400 m"
"""
)
cfg = load_config(work / "mission.toml")
print(f"{len(cfg.defaulted)} fields taken from the paper scenario, e.g. {', '.join(cfg.defaulted[:4])}")

# %%
# Fly it
# ------
summary = run_methods(cfg, ["tbmpc", "ffa"], 0, work / "run", progress=False, cache_dir=work / "cache")
for method, s in summary.methods.items():
    print(
        f"{method:6s} J_p = {s.J_p:.4g}, terminal position error {1e3 * s.terminal_error.position:.2f} mm, "
        f"steps outside the tube {s.steps_outside_tube}, glide-slope violations "
        f"{s.constraint_violations.glide_slope_steps}"
    )

# %%
# The descent in the orbital frame L
# ----------------------------------
# The site moves in L as the body turns; the trajectory ends on it.
from tubempc.results import load_record  # noqa: E402

rec, _ = load_record(work / "run" / "ffa.h5")
fig, ax = plt.subplots(figsize=(5, 4))
ax.plot(rec.zbar[:, 0], rec.zbar[:, 1], "k--", lw=1, label="reference")
ax.plot(rec.x[:, 0], rec.x[:, 1], label="TBMPC-FFA")
ax.plot(*rec.zbar[-1, :2], "r*", ms=10, label="site at t_f")
ax.set_xlabel("x_L (m)")
ax.set_ylabel("y_L (m)")
ax.axis("equal")
ax.legend(fontsize=8)
fig.tight_layout()
# %%
# Did it land on the site?
# ------------------------
# Measured against the site itself, not against the reference's end (which a wrong site would share):
# the surface point at 20 deg N, 40 deg E of the body, found again here by ray casting on the mesh, and
# the final position turned into the body frame A at t_f.
from tubempc.scenario import build_scenario  # noqa: E402
from tubempc.scenario.sites import site_from_lat_lon  # noqa: E402

scn = build_scenario(load_config(work / "run" / "config.toml"), cache_dir=work / "cache")
site = site_from_lat_lon(scn.shape, np.radians(20.0), np.radians(40.0), 0.0)
r_A = np.asarray(scn.model.C_AL(cfg.mpc.t_f)) @ rec.x[-1, :3]
offset = r_A - site.surface_A
height = float(offset @ site.normal_A)
print(f"final position: {height:.3f} m above the site's surface point along its normal (target 5 m), ")
print(f"{np.linalg.norm(offset - height * site.normal_A) * 1e3:.2f} mm beside it")
