"""What a run flown on navigation shows (issue #30 item 5): the navigation camera's footprint in the 3D
view against an independent ray cast and pinhole, and the touchdown dispersion's ellipse and site map."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tubempc.closed_loop import simulate
from tubempc.config import load_config
from tubempc.scenario import build_scenario
from tubempc.view3d import FootprintCaster, camera_footprint, mission_view_html


@pytest.fixture(scope="module")
def tag_nav(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return build_scenario(load_config(scenario="bennu-tag-nav"), cache_dir=tmp_path_factory.mktemp("cache"))


def _first_hit(origin: np.ndarray, d: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Nearest intersection of the ray origin + s d (s > 0) with the triangles (Moller-Trumbore, numpy)."""
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = origin - a
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    assert np.any(hit)
    return np.asarray(origin + float(np.min(t[hit])) * d)


@pytest.mark.parametrize("tilt_deg", [0.0, 8.0])
def test_the_footprint_is_the_camera_s_view_on_the_shape(tag_nav, tilt_deg: float) -> None:  # type: ignore[no-untyped-def]
    scn = tag_nav
    cfg = scn.config
    t = 40.0
    x = scn.reference.x[20].copy()  # on the descent, boresight down; then turned by tilt_deg about x_B
    C_LB = Rotation.from_rotvec(x[6:9]).as_matrix() @ Rotation.from_euler("x", tilt_deg, degrees=True).as_matrix()
    x[6:9] = Rotation.from_matrix(C_LB).as_rotvec()
    fp = camera_footprint(scn, x, t, n_edge=8)

    # the boresight's hit: an independent ray cast along spacecraft.boresight_B on the shape in A
    C_AL = np.asarray(scn.model.C_AL(t))
    b_B = np.asarray(cfg.spacecraft.boresight_B, dtype=float)
    b_L = C_LB @ b_B / np.linalg.norm(b_B)
    np.testing.assert_allclose(fp.boresight_L, b_L, atol=1e-12)
    hit_A = _first_hit(C_AL @ x[:3], C_AL @ b_L, np.asarray(scn.shape.vertices), np.asarray(scn.shape.faces))
    np.testing.assert_allclose(fp.centre_L, C_AL.T @ hit_A, atol=1e-6)
    np.testing.assert_allclose(fp.apex_L, x[:3])

    # the corners: at the half-diagonal of the (square) field of view from the boresight, one per quadrant
    half_diagonal = np.arctan(np.sqrt(2.0) * np.tan(0.5 * cfg.navigation.camera_fov))
    angles = np.arccos(np.clip(fp.corner_directions_L @ b_L, -1.0, 1.0))
    np.testing.assert_allclose(angles, half_diagonal, rtol=1e-9)
    assert np.linalg.norm(fp.corner_directions_L.sum(axis=0) / 4.0 - np.cos(half_diagonal) * b_L) < 1e-9
    # each corner hit lies on its ray, on the surface (an independent cast along it meets the same point)
    for d, hit in zip(fp.corner_directions_L, fp.corners_L, strict=True):
        ref = _first_hit(C_AL @ x[:3], C_AL @ d, np.asarray(scn.shape.vertices), np.asarray(scn.shape.faces))
        np.testing.assert_allclose(hit, C_AL.T @ ref, atol=1e-6)
    # the outline walks the image border: between the half field of view and the half-diagonal
    rays = fp.outline_L - fp.apex_L
    off = np.arccos(np.clip(rays @ b_L / np.linalg.norm(rays, axis=1), -1.0, 1.0))
    assert fp.outline_L.shape == (4 * 8 + 1, 3) and np.all(np.isfinite(fp.outline_L))
    assert np.all(off >= 0.5 * cfg.navigation.camera_fov - 1e-9) and np.all(off <= half_diagonal + 1e-9)
    np.testing.assert_array_equal(fp.outline_L[0], fp.outline_L[-1])

    # the landmarks in the frame project inside the image by an independent pinhole
    assert fp.landmarks and len(fp.landmarks) <= cfg.navigation.camera_max_landmarks
    cam = FootprintCaster(scn, landmarks=False).settings
    s_C = (fp.landmarks_L - x[:3]) @ (C_LB @ np.asarray(cam.C_BC))
    f, w = cam.focal_length_px, cam.width_px
    u, v = 0.5 * w + f * s_C[:, 0] / s_C[:, 2], 0.5 * w + f * s_C[:, 1] / s_C[:, 2]
    assert np.all(s_C[:, 2] > 0) and np.all((u >= 0) & (u <= w) & (v >= 0) & (v <= w))


def test_looking_past_the_limb_leaves_gaps() -> None:
    """Pointed beside the body, the border rays meet nothing: NaN in the outline, never a fake point."""
    scn = build_scenario(load_config(scenario="bennu-tag-nav"))
    x = scn.reference.x[0].copy()
    C_LB = Rotation.from_rotvec(x[6:9]).as_matrix() @ Rotation.from_euler("x", 40.0, degrees=True).as_matrix()
    x[6:9] = Rotation.from_matrix(C_LB).as_rotvec()
    fp = camera_footprint(scn, x, 0.0, caster=FootprintCaster(scn, landmarks=False))
    missed = np.isnan(fp.outline_L[:, 0])
    assert missed.any() and not missed.all()
    assert fp.landmarks == [] and fp.landmarks_L.shape == (0, 3)


def test_the_view_of_a_navigation_run_has_the_footprints(tag_nav) -> None:  # type: ignore[no-untyped-def]
    rec = simulate(tag_nav, "ffa", seed=1, max_steps=6, design_worker="none")
    assert rec.navigation is not None
    html = mission_view_html(tag_nav, {"ffa": rec}, footprints=3)
    assert html.count("camera footprint at t = ") == 3 and "navigation camera at t = " in html
    for k in (0, 3, 6):  # the frames' landmarks are the record's count (the C++ camera's, no dropout)
        fp = camera_footprint(tag_nav, rec.x[k], float(rec.t[k]))
        assert len(fp.landmarks) == rec.navigation.landmarks[k]
        assert f"{len(fp.landmarks)} landmarks in the frame" in html
    assert "camera footprint" not in mission_view_html(tag_nav, {"ffa": rec}, footprints=0)
