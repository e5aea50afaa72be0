#include <cmath>
#include <stdexcept>
#include <string>

#include "tubempc/gravity/gravity_model.hpp"

namespace tubempc::gravity {

PointMassGravity::PointMassGravity(double gm) : gm_(gm) {
  if (!std::isfinite(gm) || gm <= 0.0) {
    throw std::invalid_argument("PointMassGravity: gm must be finite and > 0 (m^3/s^2), got " +
                                std::to_string(gm));
  }
}

void PointMassGravity::evaluate(const Eigen::Vector3d& r_A, GravitySample& out) const {
  const double r2 = r_A.squaredNorm();
  if (!(r2 > 0.0) || !std::isfinite(r2)) {
    throw std::domain_error("PointMassGravity: position must be finite and nonzero");
  }
  const double r = std::sqrt(r2);
  const double mu_r3 = gm_ / (r2 * r);
  out.potential = gm_ / r;
  out.acceleration = -mu_r3 * r_A;
  out.gradient = mu_r3 * (3.0 * r_A * r_A.transpose() / r2 - Eigen::Matrix3d::Identity());
}

}  // namespace tubempc::gravity
