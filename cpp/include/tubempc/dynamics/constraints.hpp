/// @file constraints.hpp
/// State constraints of the approach (docs/model.md, "Constraints"), each written g(x) <= 0 with
/// its gradient and its tangent (first-order) linearisation used by the QP.
///
/// - Glide slope (a cone with apex p and unit axis a in L; the paper's: p = 0, a = z_L):
///       g_gs(x) = |r - p| cos(phi_gs) - (r - p) . a <= 0.
///   g_gs is positively homogeneous in r - p, so its tangent plane passes through the apex and the
///   linearisation (the paper's Eq. 36) is an outer approximation of the cone. A cone fixed in the
///   asteroid frame A (a landing site off the spin axis) gives p and a as functions of time
///   (ProximityModel::glide_slope_cone_L).
/// - Line of sight (the project's reading): r_B = -C_BL r_L is the vector from the spacecraft to the
///   asteroid centre in B and b_B the unit boresight (default +z_B):
///       g_los(x) = |r| cos(theta_LOS) - r_B . b_B = |r| cos(theta_LOS) + r_L . (Exp(phi) b_B) <= 0.
///   Its gradient in phi uses Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d):
///       d g_los / d phi = Jr(phi)^T [b_B]x Exp(phi)^T r_L.
/// Gradients are undefined at r = 0 (std::domain_error there and for non-finite input).
#pragma once

#include <Eigen/Dense>

#include "tubempc/dynamics/proximity_model.hpp"

namespace tubempc::dynamics {

/// Glide-slope constraint g_gs(x) = |r - p| cos(phi_gs) - (r - p) . a (<= 0 feasible).
/// @param x                 model state [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)].
/// @param glide_slope_angle phi_gs (rad).
/// @param apex_L            cone apex p in L (m).
/// @param axis_L            cone axis a in L (unit vector).
/// @param grad              if non-null, receives d g_gs / d x (12; m per state unit).
/// @return g_gs(x) (m).
/// @throws std::domain_error at r = p or for a non-finite x.
double glide_slope_constraint(const StateVector& x, double glide_slope_angle, const Eigen::Vector3d& apex_L,
                              const Eigen::Vector3d& axis_L, StateVector* grad = nullptr);

/// The paper's glide-slope constraint: apex at the asteroid's centre, axis z_L.
/// @param x                 model state (see above).
/// @param glide_slope_angle phi_gs (rad).
/// @param grad              if non-null, receives d g_gs / d x (12; m per state unit).
/// @return g_gs(x) = |r| cos(phi_gs) - r . z_L (m).
/// @throws std::domain_error at r = 0 or for a non-finite x.
inline double glide_slope_constraint(const StateVector& x, double glide_slope_angle,
                                     StateVector* grad = nullptr) {
  return glide_slope_constraint(x, glide_slope_angle, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(),
                                grad);
}

/// Line-of-sight constraint g_los(x) = |r| cos(theta_LOS) - r_B . b_B (<= 0 feasible).
/// @param x           model state (see glide_slope_constraint).
/// @param los_angle   theta_LOS (rad).
/// @param boresight_B boresight b_B in B (normalised here).
/// @param grad        if non-null, receives d g_los / d x (12; m per state unit).
/// @return g_los(x) (m).
/// @throws std::domain_error at r = 0 or for a non-finite x.
double line_of_sight_constraint(const StateVector& x, double los_angle, const Eigen::Vector3d& boresight_B,
                                StateVector* grad = nullptr);

/// Tangent linearisation of g(x) <= 0 at x_ref from its value and gradient there:
/// grad^T x <= b with b = grad . x_ref - g(x_ref).
/// @param g_ref g(x_ref) (m).
/// @param grad  d g / d x at x_ref.
/// @param x_ref linearisation state.
/// @return the bound b (m).
inline double linearized_bound(double g_ref, const StateVector& grad, const StateVector& x_ref) {
  return grad.dot(x_ref) - g_ref;
}

}  // namespace tubempc::dynamics
