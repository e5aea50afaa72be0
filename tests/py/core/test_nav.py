"""Navigation sensors and filter (tubempc._core.nav) against independent computations: the random
stream against a Python implementation of its definition, ray casting against a numpy brute force over
every face, the camera's pixels and visibility against numpy, the altimeter against numpy, and NEES /
NIS inside their 95 % chi-square bounds over a Monte Carlo set."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from tubempc import PolyhedronGravity, _core, bennu_like_shape

nav = _core.nav
MASK = (1 << 64) - 1


def _splitmix(x: int) -> tuple[int, int]:
    x = (x + 0x9E3779B97F4A7C15) & MASK
    z = x
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return x, z ^ (z >> 31)


def _rotl(x: int, k: int) -> int:
    return ((x << k) | (x >> (64 - k))) & MASK


class _Xoshiro:
    """xoshiro256** seeded by SplitMix64 with Box-Muller normals, written from the definitions."""

    def __init__(self, seed: int) -> None:
        self.s = []
        x = seed
        for _ in range(4):
            x, z = _splitmix(x)
            self.s.append(z)
        self.spare: float | None = None

    def next(self) -> int:
        s = self.s
        result = (_rotl((s[1] * 5) & MASK, 7) * 9) & MASK
        t = (s[1] << 17) & MASK
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = _rotl(s[3], 45)
        return result

    def uniform(self) -> float:
        return (self.next() >> 11) * 2.0**-53

    def normal(self) -> float:
        if self.spare is not None:
            value, self.spare = self.spare, None
            return value
        u1 = 1.0 - self.uniform()
        u2 = self.uniform()
        radius = math.sqrt(-2.0 * math.log(u1))
        self.spare = radius * math.sin(2.0 * math.pi * u2)
        return radius * math.cos(2.0 * math.pi * u2)


def test_random_stream_follows_its_definition() -> None:
    for seed in (0, 1, 2**63 + 12345):
        ours, ref = nav.Random(seed), _Xoshiro(seed)
        assert [ours.next_u64() for _ in range(20)] == [ref.next() for _ in range(20)]
        assert [ours.uniform() for _ in range(5)] == [ref.uniform() for _ in range(5)]
        np.testing.assert_allclose([ours.normal() for _ in range(11)], [ref.normal() for _ in range(11)], rtol=1e-14)


@pytest.fixture(scope="module")
def body() -> tuple[object, object, np.ndarray, np.ndarray]:
    shape = bennu_like_shape(n_subdivisions=8)
    caster = nav.RayCaster(shape)
    return shape, caster, np.asarray(shape.vertices), np.asarray(shape.faces)


def _brute_force(v: np.ndarray, f: np.ndarray, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Nearest positive intersection distance of each ray with every triangle (numpy, Moller-Trumbore)."""
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    e1, e2 = b - a, c - a
    out = np.full(len(origins), np.inf)
    for i, (o, d) in enumerate(zip(origins, dirs / np.linalg.norm(dirs, axis=1)[:, None], strict=True)):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            t = o - a
            u = np.einsum("ij,ij->i", t, p) * inv
            q = np.cross(t, e1)
            w = (q @ d) * inv
            s = np.einsum("ij,ij->i", e2, q) * inv
        ok = (det != 0) & (u >= 0) & (u <= 1) & (w >= 0) & (u + w <= 1) & (s > 0)
        if ok.any():
            out[i] = s[ok].min()
    return out


def test_ray_casting_matches_numpy_brute_force(body: tuple[object, object, np.ndarray, np.ndarray]) -> None:
    _, caster, v, f = body
    rng = np.random.default_rng(4)
    u = rng.normal(size=(400, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    origins = 600.0 * u
    dirs = -origins + 150.0 * rng.normal(size=(400, 3))
    dist, faces = caster.cast_batch(origins, dirs)
    ref = _brute_force(v, f, origins, dirs)
    assert np.isfinite(ref).sum() > 200 and np.isinf(ref).sum() > 20
    np.testing.assert_array_equal(np.isinf(dist), np.isinf(ref))
    hit = np.isfinite(ref)
    np.testing.assert_allclose(dist[hit], ref[hit], rtol=1e-10)
    assert (faces[~hit] == -1).all() and (faces[hit] >= 0).all()
    same, _ = caster.cast_batch(origins, dirs, brute_force=True)
    np.testing.assert_array_equal(same, dist)


def _world(shape: object) -> tuple[object, object, list[object]]:
    gravity = PolyhedronGravity(shape, 1260.0)
    model = _core.dynamics.ProximityModel(gravity, _core.dynamics.ModelParams())
    caster = nav.RayCaster(shape)
    return model, caster, nav.generate_landmarks(caster, 600)


def _nadir(r_L: np.ndarray) -> np.ndarray:
    z = -r_L / np.linalg.norm(r_L)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    C_LB = np.column_stack([x, np.cross(z, x), z])
    return Rotation.from_matrix(C_LB).as_quat()  # [x, y, z, w], R(q) = C_LB


def _truth(model: object, t: float, r_L: np.ndarray, q_BL: np.ndarray, w: np.ndarray | None = None) -> object:
    st = nav.SensorTruth()
    st.t = t
    st.r_L = r_L
    st.q_BL = q_BL
    st.omega_BL_B = np.zeros(3) if w is None else w
    st.omega_LI_L = np.array([0.0, 0.0, model.mean_motion])
    params = model.params
    st.accel_nongrav_L = np.array([params.beta_srp / params.orbit_radius**2, 0.0, 0.0])
    st.C_AL = model.C_AL(t)
    return st


def test_camera_pixels_and_visibility_match_numpy(body: tuple[object, object, np.ndarray, np.ndarray]) -> None:
    shape, _, v, f = body
    model, caster, landmarks = _world(shape)
    settings = nav.CameraSettings()
    settings.pixel_sigma = 0.0
    settings.max_landmarks = nav.MAX_LANDMARKS_PER_FRAME
    settings.C_BC = Rotation.from_rotvec([0.0, 0.0, 0.3]).as_matrix()
    camera = nav.NavCamera(caster, landmarks, settings, 1)
    t = 1500.0
    r_L = np.array([-520.0, 80.0, 150.0])
    q = (Rotation.from_quat(_nadir(r_L)) * Rotation.from_rotvec([0.02, -0.03, 0.0])).as_quat()
    truth = _truth(model, t, r_L, q)
    C_AL = model.C_AL(t)
    C_LB = Rotation.from_quat(q).as_matrix()
    r_A = C_AL @ r_L
    sun_A = -C_AL[:, 0]
    expected = []
    for i, lm in enumerate(landmarks):
        p_A, n_A = np.asarray(lm.p_A), np.asarray(lm.normal_A)
        view = r_A - p_A
        s_C = settings.C_BC.T @ C_LB.T @ C_AL.T @ (p_A - r_A)
        if s_C[2] <= 0:
            continue
        pixel = 512.0 + settings.focal_length_px * s_C[:2] / s_C[2]
        in_image = (pixel >= 0).all() and (pixel <= 1024).all()
        facing = n_A @ view >= math.cos(settings.max_emission_angle) * np.linalg.norm(view)
        lit = n_A @ sun_A >= math.cos(settings.max_incidence_angle)
        if not (in_image and facing and lit):
            continue
        d = view / np.linalg.norm(view)
        margin = 1e-9 * caster.size
        free = _brute_force(v, f, (p_A + margin * d)[None, :], d[None, :])[0] >= np.linalg.norm(view) - 2 * margin
        seen, px = camera.visible(i, truth)
        assert seen == free, i
        if free:
            np.testing.assert_allclose(px, pixel, atol=1e-9)
            expected.append(i)
    assert len(expected) > 10
    frame = camera.measure(truth)
    assert frame.status == nav.SensorStatus.Ok
    assert frame.landmarks == expected[: nav.MAX_LANDMARKS_PER_FRAME]


def test_altimeter_matches_numpy_range(body: tuple[object, object, np.ndarray, np.ndarray]) -> None:
    shape, _, v, f = body
    model, caster, _ = _world(shape)
    s = nav.AltimeterSettings()
    s.sigma = 0.0
    s.max_range = 2000.0
    altimeter = nav.Altimeter(caster, s, 3)
    rng = np.random.default_rng(8)
    for k in range(20):
        t = 300.0 * k
        r_L = 500.0 * rng.normal(size=3)
        r_L *= (400.0 + 200.0 * rng.uniform()) / np.linalg.norm(r_L)
        q = (Rotation.from_quat(_nadir(r_L)) * Rotation.from_rotvec(0.2 * rng.normal(size=3))).as_quat()
        m = altimeter.measure(_truth(model, t, r_L, q))
        C_AL = model.C_AL(t)
        beam_A = C_AL @ Rotation.from_quat(q).as_matrix() @ np.array([0.0, 0.0, 1.0])
        ref = _brute_force(v, f, (C_AL @ r_L)[None, :], beam_A[None, :])[0]
        if np.isfinite(ref):
            assert m.status == nav.SensorStatus.Ok
            assert m.range == pytest.approx(ref, rel=1e-10)
        else:
            assert m.status == nav.SensorStatus.OutOfRange


def test_settings_errors_name_the_field() -> None:
    s = nav.CameraSettings()
    s.max_landmarks = 0
    with pytest.raises(ValueError, match=r"camera\.max_landmarks"):
        s.validate()
    imu = nav.ImuSettings()
    imu.gyro_noise_density = -1.0
    with pytest.raises(ValueError, match=r"imu\.gyro_noise_density"):
        nav.Imu(imu, 1)


def test_nees_and_nis_inside_chi_square_bounds(body: tuple[object, object, np.ndarray, np.ndarray]) -> None:
    """A Monte Carlo set of 20 s runs above the Bennu-like body's day side (IMU at 5 Hz, star tracker and
    altimeter at 1 Hz, camera at 0.5 Hz): the average NEES at the end and the NIS of every update lie in
    their two-sided 95 % chi-square intervals; the filter keeps the state finite."""
    shape = body[0]
    model, caster, landmarks = _world(shape)
    imu_s = nav.ImuSettings()
    imu_s.period = 0.2
    fs = nav.FilterSettings()
    fs.imu = imu_s
    sigma0 = np.array([2.0] * 3 + [0.01] * 3 + [1e-3] * 3)
    runs, steps = 16, 100
    nees_sum = 0.0
    nis = {"camera": [0.0, 0], "star_tracker": [0.0, 0], "altimeter": [0.0, 0]}

    def add(kind: str, r: object) -> None:
        nis[kind][0] += r.nis
        nis[kind][1] += r.dof

    for run in range(runs):
        altimeter = nav.Altimeter(caster, nav.AltimeterSettings(), 10 * run + 1)
        camera = nav.NavCamera(caster, landmarks, fs.camera, 10 * run + 2)
        imu = nav.Imu(imu_s, 10 * run + 3)
        star = nav.StarTracker(fs.star_tracker, 10 * run + 4)
        filt = nav.NavigationFilter(model, caster, landmarks, fs)
        rng = np.random.default_rng(run)
        r0 = np.array([-500.0, 60.0, 90.0])
        state = np.concatenate([r0, [0.02, -0.01, 0.01], _nadir(r0), [1e-4, -1e-4, 5e-5]])
        e = sigma0 * rng.normal(size=9)
        x0 = nav.NavState()
        x0.r_L = r0 - e[:3]
        x0.v_L = state[3:6] - e[3:6]
        x0.q_BL = (Rotation.from_quat(state[6:10]) * Rotation.from_rotvec(-e[6:9])).as_quat()
        P0 = np.diag(np.concatenate([sigma0**2, [imu_s.gyro_bias_sigma**2] * 3, [imu_s.accel_bias_sigma**2] * 3]))
        assert filt.initialize(x0, P0) == nav.FilterStatus.Ok
        for k in range(steps + 1):
            t = k * imu_s.period
            truth = _truth(model, t, state[:3], state[6:10], state[10:13])
            if k > 0 and k % 5 == 0:
                add("star_tracker", filt.update_star_tracker(star.measure(truth)))
                add("altimeter", filt.update_altimeter(altimeter.measure(truth)))
            if k > 0 and k % 10 == 0:
                r = filt.update_camera(camera.measure(truth))
                assert r.status == nav.FilterStatus.Ok
                add("camera", r)
            if k == steps:
                break
            assert filt.propagate(t + imu_s.period, imu.measure(truth)) == nav.FilterStatus.Ok
            settings = _core.dynamics.PropagatorSettings()
            settings.substeps = 2
            result = model.propagate(t, state, np.zeros(6), imu_s.period, settings, np.zeros(6), None, None)
            state = np.asarray(result.state)
        true = nav.NavState()
        true.t = steps * imu_s.period
        true.r_L, true.v_L, true.q_BL = state[:3], state[3:6], state[6:10]
        true.gyro_bias_B, true.accel_bias_B = imu.gyro_bias, imu.accel_bias
        assert np.isfinite(filt.covariance).all()
        nees_sum += nav.nees(filt.state, filt.covariance, true)
    lo, hi = chi2.ppf([0.025, 0.975], nav.N_STATES * runs)
    assert lo < nees_sum < hi, nees_sum / (nav.N_STATES * runs)
    for kind in ("camera", "star_tracker"):
        total, dof = nis[kind]
        lo, hi = chi2.ppf([0.025, 0.975], dof)
        assert lo < total < hi, (kind, total / dof)
    total, dof = nis["altimeter"]  # its terrain noise is deliberately conservative: bounded above only
    assert total < chi2.ppf(0.975, dof), total / dof
