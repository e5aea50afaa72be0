"""What a run flown on navigation shows (issue #30 item 5): the navigation camera's footprint in the 3D
view against an independent ray cast and pinhole, and the touchdown dispersion's ellipse and site map."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np
import pytest
from matplotlib.path import Path as Polygon
from scipy.spatial.transform import Rotation

import tubempc.analysis.studies
from tubempc.analysis import figures, touchdown_offsets
from tubempc.analysis.view3d import FootprintCaster, camera_footprint, mission_view_html
from tubempc.cli import main
from tubempc.config import load_config
from tubempc.results.campaign_store import CampaignStore
from tubempc.scenario import build_scenario
from tubempc.scenario.sites import site_map, tangent_axes
from tubempc.sim.closed_loop import simulate


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
    # a smaller site map and a larger frame: the frames hold fewer landmarks than they could
    cfg = tag_nav.config.with_overrides({"navigation.site_landmarks": 12, "navigation.camera_max_landmarks": 32})
    scn = dataclasses.replace(tag_nav, config=cfg)
    rec = simulate(scn, "ffa", seed=1, max_steps=6, design_worker="none")
    assert rec.navigation is not None
    html = mission_view_html(scn, {"ffa": rec}, footprints=3)
    assert html.count("camera footprint at t = ") == 3 and "navigation camera at t = " in html
    for k in (0, 3, 6):  # the frame's landmarks are as many as the run's C++ camera saw (no dropout)
        fp = camera_footprint(scn, rec.x[k], float(rec.t[k]))
        assert 0 < len(fp.landmarks) < 32 and len(fp.landmarks) == rec.navigation.landmarks[k]
        assert f"{len(fp.landmarks)} landmarks in the frame" in html
    assert "camera footprint" not in mission_view_html(scn, {"ffa": rec}, footprints=0)


def _line(fig, label: str) -> np.ndarray:  # type: ignore[no-untyped-def]
    lines = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label() == label]
    assert lines, label
    return np.asarray(lines[-1].get_xydata(), dtype=float)


def test_the_dispersion_ellipse_holds_its_probability_of_a_known_gaussian() -> None:
    rng = np.random.default_rng(30)
    mean, L = np.array([0.2, -0.1]), np.array([[0.30, 0.0], [0.12, 0.08]])  # correlated, elongated
    fig = figures.touchdown_dispersion(mean + rng.standard_normal((4000, 2)) @ L.T, "test", 0.997, 1.0)
    ring = _line(fig, "99.7 % ellipse")
    fresh = mean + rng.standard_normal((200_000, 2)) @ L.T
    coverage = float(np.mean(Polygon(ring).contains_points(fresh)))
    assert abs(coverage - 0.997) < 1.5e-3, coverage  # a 1-dof quantile would give 0.988, sigma instead of c: 0.39
    # its semi-axes against the closed form of the 2-dof quantile, c^2 = -2 ln(1 - p), on the true covariance
    lam, V = np.linalg.eigh(L @ L.T)
    for k in range(2):
        half = 0.5 * np.ptp((ring - ring.mean(axis=0)) @ V[:, k])
        assert half == pytest.approx(np.sqrt(-2.0 * np.log(0.003) * lam[k]), rel=0.05)
    goal = _line(fig, "goal: 1 m")
    np.testing.assert_allclose(np.linalg.norm(goal, axis=1), 1.0)
    figures.plt.close(fig)


def test_the_site_map_lies_in_the_site_s_tangent_plane(tag_nav) -> None:  # type: ignore[no-untyped-def]
    site = tag_nav.site
    east, north = tangent_axes(site.normal_A)
    np.testing.assert_allclose(
        np.array([east, north, site.normal_A]) @ np.array([east, north, site.normal_A]).T, np.eye(3), atol=1e-12
    )
    assert abs(east[2]) < 1e-12 and north[2] > 0  # east is horizontal, north towards +z_A (the spin axis)
    lm = np.array([site.surface_A + 3.0 * east - 4.0 * north + 0.5 * site.normal_A, site.surface_A + 50.0 * east])
    m = site_map(tag_nav.shape, site, 20.0, lm)
    np.testing.assert_allclose(m.landmarks, [[3.0, -4.0]], atol=1e-9)  # the second is outside the map
    np.testing.assert_allclose(m.project(site.target_A - site.surface_A), [0.0, 0.0], atol=1e-9)
    assert len(m.facets) > 0 and np.all(np.abs(m.heights) < 20.0)
    # the facet holding the site: a triangle around the origin of the plane
    assert any(Polygon(f).contains_point((0.0, 0.0)) for f in m.facets)


def test_montecarlo_of_a_navigation_campaign_draws_the_touchdown_dispersion(
    tag_nav, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:  # type: ignore[no-untyped-def]
    # short runs: the command's own path, each run cut after 5 steps
    monkeypatch.setattr(
        tubempc.analysis.studies, "montecarlo", functools.partial(tubempc.analysis.studies.montecarlo, max_steps=5)
    )
    out = tmp_path / "mc"
    args = ["montecarlo", "--scenario", "bennu-tag-nav", "--runs", "3", "--workers", "1", "--method", "ffa"]
    assert main([*args, "--out", str(out), "--quiet"]) == 0
    assert (out / "fig21_touchdown_ffa.png").stat().st_size > 10_000
    offsets = touchdown_offsets(tag_nav, out, "ffa")
    assert offsets.shape == (3, 2) and np.all(np.isfinite(offsets))
    store = CampaignStore(out)
    for i, (e, n) in enumerate(offsets):  # the horizontal part of each run's terminal position error
        run = store.result(i)
        assert np.hypot(e, n) <= run["ffa"]["terminal_error"]["position"] + 1e-9
        assert len(run["nav_touchdown_error"]["ffa"]) == 12
    other = tmp_path / "paper"  # without navigation: no dispersion figure
    assert main(["montecarlo", "--runs", "1", "--workers", "1", "--method", "ffa", "--out", str(other), "--quiet"]) == 0
    assert (other / "summary.json").exists() and not list(other.glob("fig21*"))


def test_the_report_of_a_navigation_run_shows_its_figures(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import tubempc.analysis.runner
    from tubempc.analysis.report import write_report

    monkeypatch.setattr(tubempc.analysis.runner, "simulate", functools.partial(simulate, max_steps=8, design_worker="none"))
    out = tmp_path / "run"
    assert main(["run", "--scenario", "bennu-tag-nav", "--method", "ffa", "--out", str(out), "--quiet"]) == 0
    html, md = write_report(out)
    text, page = md.read_text(), html.read_text()
    for stem in ("fig19_navigation_errors", "fig20_landmarks"):
        assert f"![{stem}]" in text and f"{stem}.png: Navigation: " in text
    assert "the navigation camera's footprint" in text and "camera footprint at t = " in page
