// Reaction wheels: limits, momentum state and the dump policy (see reaction_wheels.hpp).
#include "tubempc/actuators/reaction_wheels.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace tubempc::actuators {

void ReactionWheelSpec::validate(const std::string& what) const {
  if (!axis_B.allFinite() || std::abs(axis_B.norm() - 1.0) > 1e-9)
    throw std::invalid_argument(what + ".axis_B: must be a unit vector");
  if (!(std::isfinite(max_torque) && max_torque > 0.0))
    throw std::invalid_argument(what + ".max_torque: must be finite and > 0 (N m)");
  if (!(std::isfinite(max_momentum) && max_momentum > 0.0))
    throw std::invalid_argument(what + ".max_momentum: must be finite and > 0 (N m s)");
}

void MomentumDumpSettings::validate() const {
  if (!(start_fraction > 0.0 && start_fraction <= 1.0))
    throw std::invalid_argument("momentum_dump.start_fraction: must be in (0, 1]");
  if (!(stop_fraction >= 0.0 && stop_fraction < start_fraction))
    throw std::invalid_argument("momentum_dump.stop_fraction: must be in [0, start_fraction)");
  if (!(std::isfinite(time_constant) && time_constant > 0.0))
    throw std::invalid_argument("momentum_dump.time_constant: must be finite and > 0 (s)");
}

ReactionWheels::ReactionWheels(std::vector<ReactionWheelSpec> wheels, const MomentumDumpSettings& dump)
    : specs_(std::move(wheels)), dump_(dump) {
  dump_.validate();
  const int m = size();
  if (m > kMaxWheels)
    throw std::invalid_argument("wheels: at most " + std::to_string(kMaxWheels) + " wheels, got " +
                                std::to_string(m));
  G_.resize(3, m);
  u_max_.resize(m);
  h_max_.resize(m);
  fail_time_ = Eigen::VectorXd::Constant(m, std::numeric_limits<double>::infinity());
  failed_ = Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(m, false);
  for (int j = 0; j < m; ++j) {
    const ReactionWheelSpec& s = specs_[static_cast<std::size_t>(j)];
    s.validate("wheels[" + std::to_string(j) + "]");
    G_.col(j) = s.axis_B;
    u_max_(j) = s.max_torque;
    h_max_(j) = s.max_momentum;
  }
  h_ = Eigen::VectorXd::Zero(m);
  u_applied_ = Eigen::VectorXd::Zero(m);
}

void ReactionWheels::set_momentum(const Eigen::Ref<const Eigen::VectorXd>& h) {
  if (h.size() != size())
    throw std::invalid_argument("wheels.momentum: expected " + std::to_string(size()) + " values");
  for (int j = 0; j < size(); ++j)
    if (!(std::isfinite(h(j)) && std::abs(h(j)) <= h_max_(j)))
      throw std::invalid_argument("wheels.momentum[" + std::to_string(j) +
                                  "]: must be finite with |h| <= max_momentum");
  h_ = h;
  update_dumping();
}

void ReactionWheels::set_failure(int j, double t_start) {
  if (j < 0 || j >= size()) throw std::out_of_range("wheels.set_failure: no wheel " + std::to_string(j));
  if (std::isnan(t_start)) throw std::invalid_argument("wheels[" + std::to_string(j) + "].failure time: NaN");
  fail_time_(j) = t_start;
}

void ReactionWheels::update_failures(double t) noexcept {
  for (int j = 0; j < size(); ++j) failed_(j) = t >= fail_time_(j);
  update_dumping();
}

void ReactionWheels::torque_bounds(double dt, Eigen::VectorXd& lower, Eigen::VectorXd& upper) const {
  const int m = size();
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("wheels.torque_bounds.dt: must be finite and > 0 (s)");
  if (lower.size() != m) lower.resize(m);
  if (upper.size() != m) upper.resize(m);
  for (int j = 0; j < m; ++j) {
    // |h_j - u dt| <= h_max: u in [(h_j - h_max) / dt, (h_j + h_max) / dt], which contains 0.
    lower(j) = failed_(j) ? 0.0 : std::min(0.0, std::max(-u_max_(j), (h_(j) - h_max_(j)) / dt));
    upper(j) = failed_(j) ? 0.0 : std::max(0.0, std::min(u_max_(j), (h_(j) + h_max_(j)) / dt));
  }
}

void ReactionWheels::preferred_torque(Eigen::VectorXd& u_pref) const {
  const int m = size();
  if (u_pref.size() != m) u_pref.resize(m);
  for (int j = 0; j < m; ++j)
    u_pref(j) =
        dumping_ && !failed_(j) ? std::clamp(h_(j) / dump_.time_constant, -u_max_(j), u_max_(j)) : 0.0;
}

Eigen::Vector3d ReactionWheels::apply(const Eigen::Ref<const Eigen::VectorXd>& u, double dt) {
  const int m = size();
  if (u.size() != m) throw std::invalid_argument("wheels.apply: expected " + std::to_string(m) + " torques");
  if (!(std::isfinite(dt) && dt > 0.0))
    throw std::invalid_argument("wheels.apply.dt: must be finite and > 0 (s)");
  Eigen::Vector3d T_B = Eigen::Vector3d::Zero();
  for (int j = 0; j < m; ++j) {
    const double lo = failed_(j) ? 0.0 : std::min(0.0, std::max(-u_max_(j), (h_(j) - h_max_(j)) / dt));
    const double hi = failed_(j) ? 0.0 : std::max(0.0, std::min(u_max_(j), (h_(j) + h_max_(j)) / dt));
    const double uj = std::isfinite(u(j)) ? std::clamp(u(j), lo, hi) : 0.0;
    u_applied_(j) = uj;
    h_(j) = std::clamp(h_(j) - uj * dt, -h_max_(j), h_max_(j));
    T_B += G_.col(j) * uj;
  }
  update_dumping();
  return T_B;
}

void ReactionWheels::update_dumping() {
  if (!dump_.enabled) {
    dumping_ = false;
    return;
  }
  bool above_start = false, above_stop = false;
  for (int j = 0; j < size(); ++j) {
    if (failed_(j)) continue;  // a failed wheel's momentum cannot be dumped
    above_start = above_start || std::abs(h_(j)) > dump_.start_fraction * h_max_(j);
    above_stop = above_stop || std::abs(h_(j)) > dump_.stop_fraction * h_max_(j);
  }
  dumping_ = above_start || (dumping_ && above_stop);
}

}  // namespace tubempc::actuators
