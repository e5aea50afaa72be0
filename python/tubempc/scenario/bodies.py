"""Generated small bodies for user missions: a rough triaxial ellipsoid and a two-lobed contact binary.

Both are star-shaped about their construction origin: a geodesic sphere (20 n^2 faces, 10 n^2 + 2
vertices for ``subdivisions`` = n) whose vertex in direction u sits at the body's radius r(u), times
a seeded smooth roughness 1 + roughness * s(u) with s a sum of random low-order waves (``|s| <= 1``).
The result is translated so that its centre of mass (constant density) is the origin of the frame A,
with z the intended spin axis (the axis of largest extent in x). Units: metres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from .._core.gravity import Shape
from .shapes import geodesic_sphere

__all__ = ["contact_binary_shape", "ellipsoid_shape"]

Array = npt.NDArray[np.float64]


def _axes(name: str, axes: Sequence[float]) -> Array:
    a = np.asarray(axes, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a <= 0.0):
        raise ValueError(f"{name}: expected three finite semi-axes > 0 (m), got {list(np.ravel(a))}")
    return a


def _roughness(u: Array, roughness: float, seed: int, waves: int = 12) -> Array:
    """1 + roughness * s(u), s a normalised sum of ``waves`` random waves cos(k d.u + phase)."""
    if not (math.isfinite(roughness) and 0.0 <= roughness < 0.5):
        raise ValueError(f"roughness must lie in [0, 0.5), got {roughness!r}")
    if roughness == 0.0:
        return np.ones(len(u))
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(waves, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    k = rng.uniform(1.0, 5.0, size=waves)
    phase = rng.uniform(0.0, 2.0 * np.pi, size=waves)
    s = np.cos((u @ d.T) * k + phase).sum(axis=1) / waves
    return np.asarray(1.0 + roughness * s / max(1e-12, float(np.max(np.abs(s)))), dtype=np.float64)


def _ray_exit(u: Array, centre: Array, axes: Array) -> Array:
    """Distance t > 0 at which the rays t u (unit u) leave the ellipsoid ((x - c) / axes)^2 <= 1,
    which must contain the origin."""
    a = u / axes
    b = -centre / axes
    qa = np.sum(a * a, axis=1)
    qb = 2.0 * (a @ b)
    qc = float(b @ b) - 1.0
    if qc >= 0.0:
        raise ValueError("a lobe must contain the construction origin (the lobes must overlap)")
    return np.asarray((-qb + np.sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa), dtype=np.float64)


def _centred(vertices: Array, faces: npt.NDArray[np.int64]) -> Shape:
    raw = Shape(vertices, faces)
    return Shape(vertices - raw.center_of_mass, faces)


def ellipsoid_shape(axes: Sequence[float], subdivisions: int = 12, roughness: float = 0.0, seed: int = 0) -> Shape:
    """A triaxial ellipsoid with semi-axes ``axes`` (m, along x, y, z of A), optionally rough."""
    ax = _axes("axes", axes)
    u, faces = geodesic_sphere(subdivisions)
    r = 1.0 / np.sqrt(np.sum((u / ax) ** 2, axis=1))
    return _centred(u * (r * _roughness(u, roughness, seed))[:, None], faces)


def contact_binary_shape(
    body_axes: Sequence[float],
    head_axes: Sequence[float],
    separation: float,
    subdivisions: int = 12,
    roughness: float = 0.0,
    seed: int = 0,
) -> Shape:
    """Two overlapping ellipsoidal lobes along x: the body (semi-axes ``body_axes``, m) and the head
    (``head_axes``) whose centres lie ``separation`` (m) apart, head at +x. The lobes must overlap
    along x; the union is built about a point of the overlap (so it is star-shaped about it)."""
    body, head = _axes("body_axes", body_axes), _axes("head_axes", head_axes)
    if not (math.isfinite(separation) and 0.0 < separation < body[0] + head[0]):
        raise ValueError(f"separation must lie in (0, {body[0] + head[0]}) m so that the lobes overlap, got {separation!r}")
    # construction origin: the middle of the overlap [sep - a_head, a_body] on the x axis
    x0 = 0.5 * (max(0.0, separation - head[0]) + min(body[0], separation))
    c_body, c_head = np.array([-x0, 0.0, 0.0]), np.array([separation - x0, 0.0, 0.0])
    u, faces = geodesic_sphere(subdivisions)
    r = np.maximum(_ray_exit(u, c_body, body), _ray_exit(u, c_head, head))
    return _centred(u * (r * _roughness(u, roughness, seed))[:, None], faces)
