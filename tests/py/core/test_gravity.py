"""tubempc.PolyhedronGravity against polyhedral-gravity, Laplace/Poisson, pickling and the Python API."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import tubempc
from tubempc import GRAVITATIONAL_CONSTANT, PolyhedronGravity, bennu_like_shape, load_shape

pg = pytest.importorskip("polyhedral_gravity")

SHARED_DATA = Path(__file__).parents[3].parent / "shared" / "data"
RADAR = SHARED_DATA / "101955bennu.tab"
RHO = 1260.0


def _points(radius: float, seed: int) -> np.ndarray:
    """Points near (1-1.3 R), far (3-30 R) and inside (0-0.5 R) in random directions."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(90, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = np.concatenate([rng.uniform(1.0, 1.3, 30), rng.uniform(3.0, 30.0, 30), rng.uniform(0.0, 0.5, 30)])
    return d * (r * radius)[:, None]


def _reference(vertices: np.ndarray, faces: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, ...]:
    # polyhedral-gravity with a mesh in metres and density in kg/m^3 returns SI values with the same
    # convention as ours (U > 0, a = grad U); its second derivatives are xx, yy, zz, xy, xz, yz.
    poly = pg.Polyhedron((vertices, faces), RHO, integrity_check=pg.PolyhedronIntegrity.DISABLE)
    out = pg.evaluate(poly, pts.tolist(), parallel=False)
    U = np.array([o[0] for o in out])
    a = np.array([o[1] for o in out])
    h = np.array([o[2] for o in out])
    H = np.stack([h[:, 0], h[:, 3], h[:, 4], h[:, 3], h[:, 1], h[:, 5], h[:, 4], h[:, 5], h[:, 2]], 1)
    return U, a, H.reshape(-1, 3, 3)


def _shapes() -> list:
    params = [pytest.param("generated", id="bennu_like_shape")]
    params.append(pytest.param("radar", id="radar", marks=pytest.mark.skipif(not RADAR.exists(), reason="no radar model")))
    return params


@pytest.fixture(params=_shapes())
def shape(request: pytest.FixtureRequest) -> tubempc.Shape:
    return load_shape(RADAR) if request.param == "radar" else bennu_like_shape()


def test_agrees_with_polyhedral_gravity(shape: tubempc.Shape) -> None:
    model = PolyhedronGravity(shape.vertices, shape.faces, RHO)
    pts = _points(shape.mean_radius, seed=1)
    U, a, H = model.evaluate(pts)
    U_ref, a_ref, H_ref = _reference(shape.vertices, shape.faces, pts)
    assert np.max(np.abs(U - U_ref) / U_ref) < 1e-9
    assert np.max(np.linalg.norm(a - a_ref, axis=1) / np.linalg.norm(a_ref, axis=1)) < 1e-9
    assert np.max(np.linalg.norm(H - H_ref, axis=(1, 2)) / np.linalg.norm(H_ref, axis=(1, 2))) < 1e-6
    assert np.all(U > 0)
    # a points towards the body outside it
    far = np.linalg.norm(pts, axis=1) > 2 * shape.mean_radius
    assert np.all(np.einsum("ij,ij->i", a[far], pts[far]) < 0)


def test_agrees_with_basilisk(shape: tubempc.Shape) -> None:
    """Basilisk's PolyhedralGravityModel (an independent implementation of the same formulas; vertices in
    m, facets 1-based, muBody = G M) gives our U and a, at near, far and interior points."""
    polyhedral = pytest.importorskip("Basilisk.simulation.polyhedralGravityModel")
    model = PolyhedronGravity(shape.vertices, shape.faces, RHO)
    poly = polyhedral.PolyhedralGravityModel()
    poly.xyzVertex = shape.vertices.tolist()
    poly.orderFacet = (shape.faces + 1).tolist()
    poly.muBody = model.gm
    poly.initializeParameters()
    pts = _points(shape.mean_radius, seed=2)
    U, a, _ = model.evaluate(pts)
    a_bsk = np.array([np.asarray(poly.computeField(p), dtype=float).ravel() for p in pts])
    U_bsk = np.array([poly.computePotentialEnergy(p) for p in pts])
    assert np.max(np.abs(U - U_bsk) / U) < 1e-10
    # relative to the largest |a|: the interior points come close to the centre of mass, where a -> 0
    assert np.max(np.linalg.norm(a - a_bsk, axis=1)) < 1e-11 * np.max(np.linalg.norm(a, axis=1))


def _extended_precision_reference(shape: tubempc.Shape, p: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Werner and Scheeres' formulas evaluated directly (vertex-relative vectors, triple product,
    ln of the ratio) in numpy's 80-bit long double: an independent implementation whose own
    rounding is ~2000 times smaller than double's."""
    LD = np.longdouble
    V = shape.vertices.astype(LD) - p.astype(LD)
    F, E = shape.faces, shape.edges
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n /= np.sqrt((n * n).sum(-1, keepdims=True))
    d = V[E[:, 1]] - V[E[:, 0]]
    length = np.sqrt((d * d).sum(-1))
    u = d / length[:, None]
    na, nb = n[E[:, 2]], n[E[:, 3]]
    Ee = np.einsum("ki,kj->kij", na, np.cross(u, na)) + np.einsum("ki,kj->kij", nb, np.cross(-u, nb))
    rn = np.sqrt((V * V).sum(-1))
    ab = rn[E[:, 0]] + rn[E[:, 1]]
    L = np.log((ab + length) / (ab - length))
    r = V[E[:, 0]]
    Er = np.einsum("kij,kj->ki", Ee, r)
    r1, r2, r3 = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    a1, a2, a3 = rn[F[:, 0]], rn[F[:, 1]], rn[F[:, 2]]
    den = a1 * a2 * a3 + a1 * (r2 * r3).sum(-1) + a2 * (r3 * r1).sum(-1) + a3 * (r1 * r2).sum(-1)
    w = 2 * np.arctan2((r1 * np.cross(r2, r3)).sum(-1), den)
    h = (n * r1).sum(-1)
    g_rho = LD(GRAVITATIONAL_CONSTANT) * LD(RHO)
    U = g_rho / 2 * (((r * Er).sum(-1) * L).sum() - (h * h * w).sum())
    a = -g_rho * ((Er * L[:, None]).sum(0) - (n * (h * w)[:, None]).sum(0))
    H = g_rho * ((Ee * L[:, None, None]).sum(0) - np.einsum("ki,kj->ij", n * w[:, None], n))
    return float(U), a.astype(float), H.astype(float)


@pytest.mark.skipif(np.finfo(np.longdouble).eps > 1e-18, reason="long double is not extended precision here")
def test_accuracy_against_extended_precision_near_and_far(shape: tubempc.Shape) -> None:
    model = PolyhedronGravity(shape, RHO)
    R = shape.mean_radius
    rng = np.random.default_rng(7)
    for dist in (0.3 * R, 1.2 * R, 4 * R, 20 * R, 80 * R):
        u = rng.normal(size=3)
        p = dist * u / np.linalg.norm(u)
        U, a, H = model.evaluate(p)
        U_ref, a_ref, H_ref = _extended_precision_reference(shape, p)
        # the formula's own cancellation grows like (|r|/R)^2 (documented in polyhedron_gravity.hpp)
        tol = 2e-14 + 2e-15 * (dist / R) ** 2
        assert abs(U - U_ref) <= tol * U_ref, dist
        assert np.linalg.norm(a - a_ref) <= tol * np.linalg.norm(a_ref), dist
        assert np.linalg.norm(H - H_ref) <= 10 * tol * np.linalg.norm(H_ref), dist


def test_poisson_inside_laplace_outside_and_trace(shape: tubempc.Shape) -> None:
    model = PolyhedronGravity(shape, RHO)
    pts = _points(shape.mean_radius, seed=2)
    lap = model.laplacian(pts)
    four_pi_g_rho = 4 * np.pi * GRAVITATIONAL_CONSTANT * RHO
    r = np.linalg.norm(pts, axis=1)
    outside = r > np.linalg.norm(shape.vertices - shape.center_of_mass, axis=1).max() + np.linalg.norm(shape.center_of_mass)
    inside = slice(60, 90)  # within 0.5 R: inside both bodies
    assert outside.sum() >= 35
    np.testing.assert_allclose(lap[inside], -four_pi_g_rho, rtol=1e-12)
    np.testing.assert_allclose(lap[outside], 0.0, atol=1e-12 * four_pi_g_rho)
    _, _, H = model.evaluate(pts)
    np.testing.assert_allclose(np.trace(H, axis1=1, axis2=2), lap, atol=1e-9 * four_pi_g_rho)


def test_properties_and_single_point_api() -> None:
    shape = bennu_like_shape(n_subdivisions=6)
    model = PolyhedronGravity(shape, RHO)
    assert model.volume == pytest.approx(6.2266e7, rel=1e-12)
    assert model.mass == pytest.approx(RHO * 6.2266e7, rel=1e-12)
    assert model.gm == pytest.approx(GRAVITATIONAL_CONSTANT * model.mass, rel=1e-15)
    np.testing.assert_allclose(model.inertia, shape.inertia(RHO), rtol=1e-15)
    assert model.n_faces == 720 and model.mean_radius == pytest.approx(shape.mean_radius)
    r = np.array([300.0, -120.0, 80.0])
    U, a, H = model.evaluate(r)
    assert isinstance(U, float) and a.shape == (3,) and H.shape == (3, 3)
    U1, a1, H1 = model.evaluate_point(r)
    Ub, ab, Hb = model.evaluate(r[None, :], threads=1)
    assert U == U1 == Ub[0]
    np.testing.assert_array_equal(a, a1)
    np.testing.assert_array_equal(a, ab[0])
    np.testing.assert_array_equal(H, H1)
    np.testing.assert_array_equal(H, Hb[0])
    assert isinstance(model.laplacian(r), float)
    with pytest.raises(ValueError, match="shape"):
        model.evaluate(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="not finite"):
        model.evaluate(np.array([[0.0, np.nan, 1.0]]))
    with pytest.raises(ValueError, match="threads"):
        model.evaluate(r, threads=-1)
    with pytest.raises(ValueError, match="density"):
        PolyhedronGravity(shape, -1.0)


def test_threads_do_not_change_results() -> None:
    model = PolyhedronGravity(bennu_like_shape(n_subdivisions=6), RHO)
    pts = _points(model.mean_radius, seed=3)
    one = model.evaluate(pts, threads=1)
    for many in (
        model.evaluate(pts, threads=2),
        model.evaluate(pts, threads=None),
        model.evaluate(pts, threads=5),
    ):
        for x, y in zip(one, many, strict=True):
            np.testing.assert_array_equal(x, y)


def test_pickle_round_trip_is_identical() -> None:
    shape = bennu_like_shape(n_subdivisions=5)
    model = PolyhedronGravity(shape, RHO)
    clone = pickle.loads(pickle.dumps(model))
    pts = _points(model.mean_radius, seed=4)
    for x, y in zip(model.evaluate(pts), clone.evaluate(pts), strict=True):
        np.testing.assert_array_equal(x, y)
    assert clone.density == RHO
    shape_clone = pickle.loads(pickle.dumps(shape))
    np.testing.assert_array_equal(shape_clone.vertices, shape.vertices)
    np.testing.assert_array_equal(shape_clone.faces, shape.faces)
