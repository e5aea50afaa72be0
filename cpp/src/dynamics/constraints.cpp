#include "tubempc/dynamics/constraints.hpp"

#include <cmath>
#include <stdexcept>

#include "tubempc/math/so3.hpp"

namespace tubempc::dynamics {
namespace {

double checked_norm(const StateVector& x, const char* where) {
  if (!x.allFinite()) throw std::domain_error(std::string(where) + ": state is not finite");
  const double rn = x.head<3>().norm();
  if (!(rn > 0.0)) throw std::domain_error(std::string(where) + ": undefined at r = 0");
  return rn;
}

}  // namespace

double glide_slope_constraint(const StateVector& x, double glide_slope_angle, const Eigen::Vector3d& apex_L,
                              const Eigen::Vector3d& axis_L, StateVector* grad) {
  if (!x.allFinite()) throw std::domain_error("glide_slope_constraint: state is not finite");
  const Eigen::Vector3d d = x.head<3>() - apex_L;
  const double dn = d.norm();
  if (!(dn > 0.0)) throw std::domain_error("glide_slope_constraint: undefined at the cone's apex");
  const double c = std::cos(glide_slope_angle);
  if (grad) {
    grad->setZero();
    grad->head<3>() = (c / dn) * d - axis_L;
  }
  return dn * c - d.dot(axis_L);
}

double line_of_sight_constraint(const StateVector& x, double los_angle, const Eigen::Vector3d& boresight_B,
                                StateVector* grad) {
  const double rn = checked_norm(x, "line_of_sight_constraint");
  const double bn = boresight_B.norm();
  if (!std::isfinite(bn) || !(bn > 0.0)) {
    throw std::domain_error("line_of_sight_constraint: boresight_B must be finite and nonzero");
  }
  const Eigen::Vector3d b = boresight_B / bn;
  const Eigen::Vector3d r = x.head<3>();
  const Eigen::Vector3d phi = x.segment<3>(6);
  const Eigen::Matrix3d C_LB = math::rotation_matrix(math::exp_map(phi));
  const Eigen::Vector3d b_L = C_LB * b;
  const double c = std::cos(los_angle);
  if (grad) {
    grad->setZero();
    grad->head<3>() = (c / rn) * r + b_L;
    grad->segment<3>(6) = math::right_jacobian(phi).transpose() * (math::skew(b) * (C_LB.transpose() * r));
  }
  return rn * c + r.dot(b_L);
}

}  // namespace tubempc::dynamics
