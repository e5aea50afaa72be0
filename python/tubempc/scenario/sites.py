"""Landing sites on a rotating body: surface points by ray casting, local normals, inside tests and
the terminal state of a site fixed in the body frame A (docs/model.md "Frames"; README "your own mission").

A site is a surface point s_A of the shape (frame A, m) with its outward normal n_A. The target is
p_A = s_A + h n_A, ``h`` (m) above the surface. The body turns about z_L = z_A at the rate
(spin_rate - n) relative to L, so at time t the target sits at r_L(t) = C_AL(t)^T p_A and moves with
v_L(t) = (spin_rate - n) z_L x r_L(t). Touching down means arriving there at rest relative to the
surface: the terminal attitude points the boresight b_B along -n_L(t_f) and turns with the body,
omega_BL_B = C_BL (spin_rate - n) z_L.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._core import so3
from .._core.gravity import GRAVITATIONAL_CONSTANT, PolyhedronGravity, Shape
from .._core.nav import RayCaster

__all__ = [
    "Site",
    "SiteMap",
    "cone_grid",
    "inside",
    "ray_cast",
    "site_from_lat_lon",
    "site_from_vector",
    "site_map",
    "surface_normal",
    "tangent_axes",
    "terminal_state",
]

Array = npt.NDArray[np.float64]


def cone_grid(
    apex: npt.ArrayLike, axis: npt.ArrayLike, half_angle: float, height: float, n_height: int = 12, n_turn: int = 48
) -> tuple[Array, Array, Array]:
    """Surface grid (x, y, z, each (n_turn, n_height)) of the glide-slope cone with ``apex`` (m),
    ``axis`` (any length), ``half_angle`` (rad) from the axis, up to ``height`` (m) along it (for plots)."""
    c = np.asarray(apex, dtype=np.float64)
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    h, t = np.meshgrid(np.linspace(0.0, height, n_height), np.linspace(0.0, 2.0 * np.pi, n_turn))
    r = h * np.tan(half_angle)
    x, y, z = (c[i] + h * a[i] + r * (np.cos(t) * e1[i] + np.sin(t) * e2[i]) for i in range(3))
    return x, y, z


def _triangles(shape: Shape) -> tuple[Array, Array, Array]:
    v = np.asarray(shape.vertices, dtype=np.float64)
    f = np.asarray(shape.faces, dtype=np.int64)
    return v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]


def ray_cast(shape: Shape, direction_A: npt.ArrayLike) -> Array:
    """The outermost point where the ray from the origin along ``direction_A`` meets the surface (m, A):
    the first face the core's ray caster (``_core.nav.RayCaster``, the sensors' own) meets coming in
    from outside the shape's bounding sphere towards the origin. ValueError if the ray misses (not a
    closed body around 0)."""
    d = np.asarray(direction_A, dtype=np.float64)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0.0:
        raise ValueError(f"direction must be a finite nonzero 3-vector, got {d}")
    d = d / np.linalg.norm(d)
    far = 2.0 * float(np.max(np.linalg.norm(np.asarray(shape.vertices), axis=1))) + 1.0
    hit = RayCaster(shape).cast(far * d, -d, far)
    if not hit.hit:
        raise ValueError(f"the ray from the centre along {d} does not meet the surface")
    return np.asarray(hit.point_A, dtype=np.float64)


def surface_normal(shape: Shape, point_A: npt.ArrayLike, radius: float) -> Array:
    """Outward unit normal at a surface point: the area-weighted mean normal of the faces whose
    centroids lie within ``radius`` (m) of it (the nearest face if none)."""
    x = np.asarray(point_A, dtype=np.float64)
    a, b, c = _triangles(shape)
    area_n = 0.5 * np.cross(b - a, c - a)  # outward for the project's shapes (positive volume)
    dist = np.linalg.norm((a + b + c) / 3.0 - x, axis=1)
    near = dist <= radius
    n = area_n[near].sum(axis=0) if np.any(near) else area_n[int(np.argmin(dist))]
    return np.asarray(n / np.linalg.norm(n), dtype=np.float64)


def inside(shape: Shape, points_A: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Whether each point (m, A) lies inside the closed shape: its winding number, the sum of the faces'
    signed solid angles over 4 pi, exceeds 1/2. The solid angles are the core's polyhedral gravity's:
    its Laplacian is -4 pi G rho times the winding number (``PolyhedronGravity.laplacian``)."""
    pts = np.atleast_2d(np.asarray(points_A, dtype=np.float64))
    laplacian = np.asarray(PolyhedronGravity(shape, 1.0).laplacian(pts), dtype=np.float64)
    return np.asarray(-laplacian / (4.0 * np.pi * GRAVITATIONAL_CONSTANT) > 0.5)


@dataclass(frozen=True)
class Site:
    """A landing site: surface point ``surface_A`` (m), outward unit ``normal_A`` and the target
    ``target_A`` = surface + altitude * normal (m), all in the body frame A."""

    surface_A: Array
    normal_A: Array
    target_A: Array


def _normal_radius(shape: Shape) -> float:
    """Twice the mean edge length: the patch the local normal averages over (m)."""
    a, b, _ = _triangles(shape)
    return 2.0 * float(np.mean(np.linalg.norm(b - a, axis=1)))


def site_from_vector(shape: Shape, point_A: npt.ArrayLike, altitude: float) -> Site:
    """The site below ``point_A`` (m, A): its radial projection onto the surface, ``altitude`` (m) above."""
    s = ray_cast(shape, point_A)
    n = surface_normal(shape, s, _normal_radius(shape))
    return Site(s, n, s + altitude * n)


def site_from_lat_lon(shape: Shape, latitude: float, longitude: float, altitude: float) -> Site:
    """The site at planetocentric ``latitude``, ``longitude`` (rad, about z_A from x_A), ``altitude`` (m)
    above the surface along the local normal."""
    d = np.array([np.cos(latitude) * np.cos(longitude), np.cos(latitude) * np.sin(longitude), np.sin(latitude)])
    return site_from_vector(shape, d, altitude)


def terminal_state(
    target_A: npt.ArrayLike,
    normal_A: npt.ArrayLike,
    C_AL: npt.ArrayLike,
    rate_AL: float,
    boresight_B: npt.ArrayLike,
    attitude_hint: npt.ArrayLike,
) -> Array:
    """The touchdown state x_f = [r_L, v_L, phi, omega_BL_B] at the time where C_AL (A from L) holds:
    at the target, at rest relative to the surface (``rate_AL`` = spin_rate - n, rad/s, about z_L),
    boresight along -n_L, turning with the body. Of the attitudes with that boresight, the one nearest
    to exp(``attitude_hint``) (rad) is taken (the minimal rotation from it)."""
    C = np.asarray(C_AL, dtype=np.float64)
    r_L = C.T @ np.asarray(target_A, dtype=np.float64)
    n_L = C.T @ np.asarray(normal_A, dtype=np.float64)
    w_AL_L = np.array([0.0, 0.0, rate_AL])
    v_L = np.cross(w_AL_L, r_L)
    b = np.asarray(boresight_B, dtype=np.float64)
    b = b / np.linalg.norm(b)
    R0 = np.asarray(so3.rotation_matrix(so3.exp_map(np.asarray(attitude_hint, dtype=np.float64))))
    have, want = R0 @ b, -n_L / np.linalg.norm(n_L)
    axis = np.cross(have, want)
    s, c = float(np.linalg.norm(axis)), float(np.clip(have @ want, -1.0, 1.0))
    if s < 1e-12:  # parallel (no turn) or anti-parallel (half turn about any perpendicular)
        perp = np.cross(have, [1.0, 0.0, 0.0] if abs(have[0]) < 0.9 else [0.0, 1.0, 0.0])
        align = np.eye(3) if c > 0 else np.asarray(so3.rotation_matrix(so3.exp_map(np.pi * perp / np.linalg.norm(perp))))
    else:
        align = np.asarray(so3.rotation_matrix(so3.exp_map(axis / s * np.arctan2(s, c))))
    R_LB = align @ R0
    phi = np.asarray(so3.log_map(so3.quat_from_rotation_matrix(R_LB)), dtype=np.float64)
    w_BL_B = R_LB.T @ w_AL_L
    return np.concatenate([r_L, v_L, phi, w_BL_B])


def tangent_axes(normal_A: npt.ArrayLike) -> tuple[Array, Array]:
    """Unit east and north of a site's tangent plane (frame A) for its outward ``normal_A``: east along
    z_A x n (the spin axis z_A; x_A at a pole, where east is undefined), north = n x east."""
    n = np.asarray(normal_A, dtype=np.float64)
    n = n / np.linalg.norm(n)
    east = np.cross([0.0, 0.0, 1.0], n)
    if np.linalg.norm(east) < 1e-9:
        east = np.array([1.0, 0.0, 0.0]) - n * n[0]
    east /= np.linalg.norm(east)
    return east, np.cross(n, east)


@dataclass(frozen=True)
class SiteMap:
    """A landing site's surroundings on its tangent plane (east, north; m), the plane through the
    site's surface point ``site.surface_A`` normal to ``site.normal_A``: the shape's facets within
    ``radius`` (m) of the site facing outward (their corners' (east, north) and their centroids' height
    above the plane, m) and the landmarks among ``landmarks_A`` that lie there."""

    site: Site
    radius: float
    east_A: Array  #: unit east in A
    north_A: Array  #: unit north in A
    facets: Array  #: (m, 3, 2) facet corners (east, north) (m)
    heights: Array  #: (m,) height of each facet's centroid above the tangent plane (m)
    landmarks: Array  #: (k, 2) landmarks (east, north) (m)

    def project(self, d_A: npt.ArrayLike) -> Array:
        """(east, north) (m) of displacements ``d_A`` ((n, 3) or (3,), m, frame A) from the site."""
        d = np.asarray(d_A, dtype=np.float64)
        return np.asarray(np.stack([d @ self.east_A, d @ self.north_A], axis=-1), dtype=np.float64)


def site_map(shape: Shape, site: Site, radius: float, landmarks_A: npt.ArrayLike | None = None) -> SiteMap:
    """The :class:`SiteMap` of ``site`` within ``radius`` (m, > 0) on ``shape`` (frame A): the faces with
    a corner within ``radius`` of the site's surface point (distance along the tangent plane) whose
    outward normal faces the site's side, and the ``landmarks_A`` ((n, 3), m) within it."""
    if not radius > 0.0:
        raise ValueError(f"radius must be > 0, got {radius}")
    east, north = tangent_axes(site.normal_A)
    n = np.asarray(site.normal_A, dtype=np.float64)
    a, b, c = _triangles(shape)
    corners = np.stack([a, b, c], axis=1) - site.surface_A  # (m, 3, 3)
    en = np.stack([corners @ east, corners @ north], axis=-1)  # (m, 3, 2)
    up = np.cross(b - a, c - a) @ n > 0.0
    height = corners.mean(axis=1) @ n
    near = up & (np.min(np.linalg.norm(en, axis=2), axis=1) <= radius) & (np.abs(height) < radius)
    marks = np.zeros((0, 2))
    if landmarks_A is not None:
        d = np.asarray(landmarks_A, dtype=np.float64).reshape(-1, 3) - site.surface_A
        p = np.stack([d @ east, d @ north], axis=-1)
        marks = p[(np.linalg.norm(p, axis=1) <= radius) & (np.abs(d @ n) < radius)]
    return SiteMap(site, float(radius), east, north, en[near], height[near], marks)
