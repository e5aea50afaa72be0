#include "tubempc/gravity/expansion_hold.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>

namespace tubempc::gravity {

ExpansionHold::ExpansionHold(double min_distance, double tolerance)
    : ExpansionHold(min_distance, tolerance, Unchecked{}) {
  if (!(std::isfinite(min_distance) && min_distance >= 0.0))
    throw std::invalid_argument("ExpansionHold: min_distance must be finite and >= 0 (m), got " +
                                std::to_string(min_distance));
  if (!(std::isfinite(tolerance) && tolerance >= 0.0))
    throw std::invalid_argument("ExpansionHold: tolerance must be finite and >= 0 (m/s^2), got " +
                                std::to_string(tolerance));
}

bool ExpansionHold::hold(const GravityModel& field, const Eigen::Vector3d& r_A) noexcept {
  if (valid_ && (r_A - r0_A_).norm() < hold_) return true;
  if (!r_A.allFinite()) return false;
  GravitySample g;
  try {
    field.evaluate(r_A, g);
  } catch (const std::exception&) {  // the field's singular point (a point mass's r = 0)
    return false;
  }
  if (!g.acceleration.allFinite() || !g.gradient.allFinite()) return false;
  // M42: the hold distance from the tolerance and the gradient's change since the last evaluation.
  double hold = min_distance_;
  if (valid_) {
    const Eigen::Vector3d step = r_A - r0_A_;
    const double d = step.norm();
    const Eigen::Vector3d error = g.acceleration - a0_A_ - G0_A_ * step;
    if (d < 2.0 * hold_) largest_error_ = std::max(largest_error_, error.norm());
    const double c = (g.gradient - G0_A_).norm() / d;
    if (tolerance_ > 0.0 && d > 0.0 && std::isfinite(c)) {
      const double by_tolerance =
          c > 0.0 ? std::sqrt(2.0 * tolerance_ / c) : std::numeric_limits<double>::infinity();
      hold = std::max(hold, std::min(by_tolerance, r_A.norm() / 8.0));
    }
  }
  r0_A_ = r_A;
  a0_A_ = g.acceleration;
  G0_A_ = g.gradient;
  hold_ = hold;
  valid_ = true;
  ++evaluations_;
  return true;
}

}  // namespace tubempc::gravity
