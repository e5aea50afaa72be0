/// @file so3.hpp
/// Quaternion and rotation utilities (docs/model.md, "Frames" and "Attitude").
///
/// Conventions
/// - A quaternion is stored as [x, y, z, w] = [vector; scalar] (the paper's convention).
/// - `quat_mul(q, p)` is the paper's q (x) p (Eq. 8):   [p0 q + q0 p + q x p; q0 p0 - q.p]
///   (the Hamilton product); `quat_mul_odot(q, p)` is the paper's q (.) p:
///   [p0 q + q0 p - q x p; q0 p0 - q.p] = quat_mul(p, q).
/// - `rotation_matrix(q)` is the matrix R with R v = vec(q (x) [v; 0] (x) q*). For q_B/L whose
///   kinematics are dq_B/L/dt = 1/2 q_B/L (x) [omega_BL_B; 0], R(q_B/L) = C_LB maps body-frame
///   components into L; for q_A/L used as r_A = q_A/L (x) r_L (x) q_A/L*, R(q_A/L) = C_AL.
/// - `exp_map(phi)` = [sin(|phi|/2) phi/|phi|; cos(|phi|/2)] and `log_map` its inverse with
///   |phi| <= pi; R(exp_map(phi)) = Exp(phi) = expm([phi]x).
/// - Right Jacobian of SO(3): Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d); for R = Exp(phi) with
///   dR/dt = R [omega]x, dphi/dt = Jr(phi)^-1 omega.
///
/// Functions taking a quaternion throw std::invalid_argument for a non-finite or (near) zero
/// input; functions taking a rotation vector throw for a non-finite input.
#pragma once

#include <Eigen/Dense>

namespace tubempc::math {

using Quaternion = Eigen::Vector4d;  ///< [x, y, z, w], vector part first.

/// Skew-symmetric cross-product matrix: skew(a) b = a x b.
/// @param a vector (any unit).
/// @return the 3 x 3 matrix [a]x (unit of a).
Eigen::Matrix3d skew(const Eigen::Vector3d& a);

/// The paper's q (x) p (Hamilton product). Inputs need not be unit.
/// @param q left factor [x, y, z, w].
/// @param p right factor [x, y, z, w].
/// @return q (x) p.
Quaternion quat_mul(const Quaternion& q, const Quaternion& p);

/// The paper's q (.) p = p (x) q.
/// @param q left factor [x, y, z, w].
/// @param p right factor [x, y, z, w].
/// @return q (.) p.
Quaternion quat_mul_odot(const Quaternion& q, const Quaternion& p);

/// Conjugate [-v; w]; the inverse of a unit quaternion.
/// @param q quaternion [x, y, z, w].
/// @return q* = [-x, -y, -z, w].
Quaternion quat_conj(const Quaternion& q);

/// Unit quaternion q/|q|.
/// @param q quaternion [x, y, z, w].
/// @return q / |q|.
/// @throws std::invalid_argument if q is non-finite or |q| < 1e-12.
Quaternion quat_normalize(const Quaternion& q);

/// Identity quaternion.
/// @return [0, 0, 0, 1].
Quaternion quat_identity();

/// Rotation matrix R(q) with R v = vec(q (x) [v;0] (x) q*); q is normalised first.
/// @param q quaternion [x, y, z, w], non-zero.
/// @return the orthonormal 3 x 3 matrix R(q) (for q_B/L: C_LB).
/// @throws std::invalid_argument if q is non-finite or (near) zero.
Eigen::Matrix3d rotation_matrix(const Quaternion& q);

/// Unit quaternion of a rotation matrix (Shepperd's method), scalar part >= 0.
/// @param R rotation matrix (orthonormal, determinant +1, within 1e-6).
/// @return q with rotation_matrix(q) = R and q_w >= 0.
/// @throws std::invalid_argument if R is non-finite or not a rotation within 1e-6.
Quaternion quat_from_rotation_matrix(const Eigen::Matrix3d& R);

/// Exponential map: rotation vector -> unit quaternion. Accurate for |phi| -> 0 (series).
/// @param phi rotation vector (rad), finite.
/// @return [sin(|phi|/2) phi/|phi|; cos(|phi|/2)], scalar part >= 0 for |phi| <= pi.
/// @throws std::invalid_argument if phi is non-finite.
Quaternion exp_map(const Eigen::Vector3d& phi);

/// Logarithmic map: unit quaternion -> rotation vector; q and -q give the same result. Accurate
/// near the identity and near a half turn (atan2 form).
/// @param q quaternion [x, y, z, w], normalised here.
/// @return the rotation vector phi (rad) with |phi| <= pi and exp_map(phi) = +-q/|q|.
/// @throws std::invalid_argument if q is non-finite or (near) zero.
Eigen::Vector3d log_map(const Quaternion& q);

/// The rotation vector of the same rotation as phi nearest to phi_ref: among phi + 2 pi n phi/|phi|,
/// n in {-1, 0, 1}, those with a norm below 2 pi - 1e-3 (where right_jacobian_inverse, and with it the
/// attitude model, is defined), the one nearest to phi_ref in the Euclidean norm (phi on a tie). This
/// is the one chart in which the model state, the navigation's estimate and the controller's prediction
/// compare attitudes (docs/model.md "Attitude"): a trajectory crossing |phi| = pi stays continuous
/// when phi_ref is its previous value. Allocation-free.
/// @param phi     rotation vector (rad).
/// @param phi_ref rotation vector (rad) the result is taken nearest to.
/// @return the representative (rad); phi itself when phi = 0 or either input is non-finite.
Eigen::Vector3d nearest_representative(const Eigen::Vector3d& phi, const Eigen::Vector3d& phi_ref) noexcept;

/// Right Jacobian of SO(3): Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d).
/// @param phi rotation vector (rad), finite.
/// @return Jr(phi) (dimensionless 3 x 3).
/// @throws std::invalid_argument if phi is non-finite.
Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& phi);

/// Inverse of the right Jacobian, defined for |phi| < 2 pi.
/// @param phi rotation vector (rad), finite, |phi| < 2 pi - 1e-6.
/// @return Jr(phi)^-1 (dimensionless 3 x 3).
/// @throws std::invalid_argument for a non-finite phi or |phi| >= 2 pi - 1e-6 (singular).
Eigen::Matrix3d right_jacobian_inverse(const Eigen::Vector3d& phi);

}  // namespace tubempc::math
