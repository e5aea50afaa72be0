"""The paper scenario on navigation (`bennu-paper-nav`, docs/decisions.md "The paper scenario on
navigation"): where the sensors look (navigation.altimeter_boresight_B, camera_boresight_B) and what they
see along the paper's reference, checked against an independent numpy geometry (brute-force ray casting
of every face, the pinhole projection, the emission and incidence tests)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from scipy.spatial.transform import Rotation

from tubempc import _core
from tubempc.config import load_config
from tubempc.scenario import Scenario, build_scenario
from tubempc.scenario.navigation import navigation_settings

Array = npt.NDArray[np.float64]

#: Reference steps checked (the paper's 300 steps: start, every 50th, end).
STEPS = (0, 50, 100, 150, 200, 250, 300)


@pytest.fixture(scope="module")
def paper_nav(tmp_path_factory: pytest.TempPathFactory) -> Scenario:
    return build_scenario(load_config(scenario="bennu-paper-nav"), cache_dir=tmp_path_factory.mktemp("cache"))


def _first_hit(shape: _core.gravity.Shape, origins: Array, directions: Array) -> Array:
    """Distance along each unit ray to the first face (Moller-Trumbore over every face; inf: none)."""
    V, F = np.asarray(shape.vertices), np.asarray(shape.faces)
    p0, e1, e2 = V[F[:, 0]], V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    p = np.cross(directions[:, None, :], e2[None])
    det = np.einsum("mfk,fk->mf", p, e1)
    tv = origins[:, None, :] - p0[None]
    q = np.cross(tv, e1[None])
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.einsum("mfk,mfk->mf", tv, p) / det
        v = np.einsum("mk,mfk->mf", directions, q) / det
        s = np.einsum("mfk,fk->mf", q, e2) / det
    hit = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (s > 1e-6)
    out: Array = np.where(hit, s, np.inf).min(axis=1)
    return out


def _frames(scn: Scenario, k: int) -> tuple[Array, Array]:
    """C_AL and C_LB = Exp(phi) of the reference at step k."""
    return np.asarray(scn.model.C_AL(k * scn.config.mpc.dt)), Rotation.from_rotvec(scn.reference.x[k, 6:9]).as_matrix()


def test_sensor_boresights_follow_the_spacecraft_boresight_unless_given(tmp_path: Path) -> None:
    paper = load_config().navigation
    assert paper.altimeter_boresight_B.tolist() == paper.camera_boresight_B.tolist() == [0.0, 0.0, 1.0]
    path = tmp_path / "own.toml"
    path.write_text("[spacecraft]\nboresight_B = [1.0, 0.0, 0.0]\n[navigation]\ncamera_boresight_B = [0.0, 1.0, 0.0]\n")
    cfg = load_config(path)
    assert cfg.navigation.altimeter_boresight_B.tolist() == [1.0, 0.0, 0.0]  # left out: the boresight
    assert cfg.navigation.camera_boresight_B.tolist() == [0.0, 1.0, 0.0]
    moved = cfg.with_overrides({"spacecraft.boresight_B": [0.0, 0.0, -2.0]})
    assert moved.navigation.altimeter_boresight_B.tolist() == [0.0, 0.0, -2.0]
    assert moved.navigation.camera_boresight_B.tolist() == [0.0, 1.0, 0.0]
    s = navigation_settings(load_config(scenario="bennu-paper-nav"))
    n = load_config(scenario="bennu-paper-nav").navigation
    C_BC = np.asarray(s.camera.C_BC)
    assert C_BC.T @ C_BC == pytest.approx(np.eye(3), abs=1e-12) and np.linalg.det(C_BC) == pytest.approx(1.0)
    assert C_BC[:, 2] == pytest.approx(n.camera_boresight_B / np.linalg.norm(n.camera_boresight_B), abs=1e-12)
    assert np.asarray(s.filter.altimeter.boresight_B) == pytest.approx(n.altimeter_boresight_B)


def test_bennu_paper_nav_keeps_the_papers_mission(paper_nav: Scenario) -> None:
    """Only [navigation] differs from the paper scenario (its disturbance growth included)."""
    paper, own = load_config().to_dict(), paper_nav.config.to_dict()
    assert [name for name in paper if paper[name] != own[name]] == ["navigation"]
    assert own["navigation"]["enabled"] and not paper["navigation"]["enabled"]


def test_the_altimeter_ranges_the_body_along_the_papers_reference(paper_nav: Scenario) -> None:
    """The mounted beam meets the surface within its range at every step; the paper's +z_B beam misses
    the body for most of the approach (why the paper scenario flew blind)."""
    n, X = paper_nav.config.navigation, paper_nav.reference.x
    b_B = n.altimeter_boresight_B / np.linalg.norm(n.altimeter_boresight_B)
    origins, beams, plus_z = [], [], []
    for k in range(0, len(X), 10):
        C_AL, C_LB = _frames(paper_nav, k)
        origins.append(C_AL @ X[k, :3])
        beams.append(C_AL @ C_LB @ b_B)
        plus_z.append(C_AL @ C_LB[:, 2])
    ranges = _first_hit(paper_nav.shape, np.array(origins), np.array(beams))
    assert np.all(ranges <= n.altimeter_max_range)
    missed = np.isinf(_first_hit(paper_nav.shape, np.array(origins), np.array(plus_z)))
    assert missed[:20].all()  # the first 200 steps: 400 s of the 600 s
    caster = _core.nav.RayCaster(paper_nav.shape)
    for o, b, r in zip(origins, beams, ranges, strict=True):  # the core's ray caster agrees
        assert caster.cast(o, b, 1e4).distance == pytest.approx(r, abs=1e-6)


def _visible_numpy(scn: Scenario, k: int, P: Array, N: Array, sun_cos: float) -> set[int]:
    """Landmarks the camera sees at reference step k: in the image, within range, facing the camera,
    lit (cos of the incidence >= sun_cos, the Sun along -x_L) and not occluded."""
    n, s = scn.config.navigation, navigation_settings(scn.config).camera
    C_AL, C_LB = _frames(scn, k)
    r_A = C_AL @ scn.reference.x[k, :3]
    view = r_A - P
    dist = np.linalg.norm(view, axis=1)
    s_C = -view @ (C_AL @ C_LB @ np.asarray(s.C_BC))
    f, w = s.focal_length_px, s.width_px
    with np.errstate(divide="ignore", invalid="ignore"):
        u, v = w / 2 + f * s_C[:, 0] / s_C[:, 2], w / 2 + f * s_C[:, 1] / s_C[:, 2]
    ok = (dist >= n.camera_min_range) & (dist <= n.camera_max_range) & (s_C[:, 2] > 0)
    ok &= np.einsum("ik,ik->i", N, view) >= np.cos(n.camera_max_emission_angle) * dist
    ok &= (N @ -C_AL[:, 0] >= sun_cos) & (u >= 0) & (u <= w) & (v >= 0) & (v <= w)
    idx = np.flatnonzero(ok)
    if idx.size:
        idx = idx[_first_hit(scn.shape, P[idx], view[idx] / dist[idx, None]) >= dist[idx] - 1e-6]
    return {int(i) for i in idx}


def test_the_camera_sees_landmarks_along_the_papers_reference_and_none_lit(paper_nav: Scenario) -> None:
    """The mounted thermal camera holds at least half a frame of landmarks until contact, the same
    landmarks as the core's NavCamera; a camera that needs sunlight (incidence <= 80 deg) sees none at
    any step: the approach is over the night side."""
    cfg = paper_nav.config
    landmarks = _core.nav.generate_landmarks(_core.nav.RayCaster(paper_nav.shape), cfg.navigation.landmarks)
    P = np.array([lm.p_A for lm in landmarks])
    N = np.array([lm.normal_A for lm in landmarks])
    settings, lit = navigation_settings(cfg).camera, navigation_settings(cfg).camera
    lit.max_incidence_angle = np.radians(80.0)
    caster = _core.nav.RayCaster(paper_nav.shape)
    cameras = [_core.nav.NavCamera(caster, landmarks, s, 0) for s in (settings, lit)]
    for k in STEPS:
        thermal = _visible_numpy(paper_nav, k, P, N, -1.0)
        if k < 300:  # at contact (the last step) the field holds a few square metres
            assert len(thermal) >= cfg.navigation.camera_max_landmarks // 2
        assert _visible_numpy(paper_nav, k, P, N, np.cos(np.radians(80.0))) == set()
        truth = _core.nav.SensorTruth()
        C_AL, _ = _frames(paper_nav, k)
        truth.t, truth.r_L, truth.C_AL = k * cfg.mpc.dt, paper_nav.reference.x[k, :3], C_AL
        truth.q_BL = Rotation.from_rotvec(paper_nav.reference.x[k, 6:9]).as_quat()  # [x, y, z, w]: q_B/L = exp(phi)
        for camera, expected in zip(cameras, (thermal, set()), strict=True):
            assert {i for i in range(len(landmarks)) if camera.visible(i, truth)[0]} == expected
