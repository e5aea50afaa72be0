"""SO(3) bindings against identities, finite differences and scipy.spatial.transform.Rotation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tubempc import so3


def _random_rotvecs(n: int, seed: int, max_angle: float = np.pi) -> np.ndarray:
    rng = np.random.default_rng(seed)
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return axes * rng.uniform(0.0, max_angle, size=(n, 1))


def test_exp_log_and_matrix_agree_with_scipy() -> None:
    for phi in _random_rotvecs(300, seed=10, max_angle=np.pi * 0.9999):
        q = so3.exp_map(phi)
        ref = Rotation.from_rotvec(phi)
        q_ref = ref.as_quat()  # scipy: [x, y, z, w], the same layout
        assert min(np.linalg.norm(q - q_ref), np.linalg.norm(q + q_ref)) < 1e-14
        np.testing.assert_allclose(so3.rotation_matrix(q), ref.as_matrix(), atol=1e-14)
        np.testing.assert_allclose(so3.log_map(q), phi, atol=1e-12)


def test_products_compose_like_scipy() -> None:
    phis = _random_rotvecs(200, seed=11)
    for a, b in zip(phis[:100], phis[100:], strict=True):
        q, p = so3.exp_map(a), so3.exp_map(b)
        composed = Rotation.from_rotvec(a) * Rotation.from_rotvec(b)
        np.testing.assert_allclose(so3.rotation_matrix(so3.quat_mul(q, p)), composed.as_matrix(), atol=1e-13)
        np.testing.assert_allclose(so3.quat_mul_odot(q, p), so3.quat_mul(p, q), atol=1e-15)


def test_matrix_to_quaternion_round_trip() -> None:
    for phi in _random_rotvecs(200, seed=12):
        R = Rotation.from_rotvec(phi).as_matrix()
        np.testing.assert_allclose(so3.rotation_matrix(so3.quat_from_rotation_matrix(R)), R, atol=1e-13)


def test_right_jacobian_against_finite_differences() -> None:
    h = 1e-6
    for phi in _random_rotvecs(50, seed=13, max_angle=3.0):
        R = Rotation.from_rotvec(phi)
        Jr = so3.right_jacobian(phi)
        for j in range(3):
            d = np.zeros(3)
            d[j] = h
            plus = (R.inv() * Rotation.from_rotvec(phi + d)).as_rotvec()
            minus = (R.inv() * Rotation.from_rotvec(phi - d)).as_rotvec()
            np.testing.assert_allclose((plus - minus) / (2 * h), Jr[:, j], atol=1e-8)
        np.testing.assert_allclose(so3.right_jacobian_inverse(phi) @ Jr, np.eye(3), atol=1e-12)


def test_exact_kinematics_match_quaternion_integration() -> None:
    """dphi/dt = Jr(phi)^-1 omega reproduces q' = 1/2 q (x) [omega, 0] (the paper's Eq. 9-11)."""
    phi = np.array([0.3142, 2.925, 0.3142])
    omega = np.array([1e-3, 0.0, 3e-3])
    dt = 1e-3
    q = so3.exp_map(phi)
    q_next = so3.quat_normalize(q + 0.5 * dt * so3.quat_mul(q, np.r_[omega, 0.0]))
    dphi_fd = (so3.log_map(q_next) - phi) / dt
    np.testing.assert_allclose(dphi_fd, so3.right_jacobian_inverse(phi) @ omega, rtol=1e-3, atol=1e-9)


@pytest.mark.parametrize(
    "bad",
    [np.zeros(4), np.array([np.nan, 0.0, 0.0, 1.0]), np.array([0.0, np.inf, 0.0, 1.0])],
)
def test_malformed_quaternions_raise(bad: np.ndarray) -> None:
    with pytest.raises(ValueError, match="quaternion must be"):
        so3.log_map(bad)
    with pytest.raises(ValueError, match="quaternion must be"):
        so3.rotation_matrix(bad)


def test_non_finite_rotation_vector_raises() -> None:
    with pytest.raises(ValueError, match="finite"):
        so3.exp_map(np.array([np.nan, 0.0, 0.0]))
