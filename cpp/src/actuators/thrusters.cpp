// Thruster cluster, faults and remainder carry-over pulse modulation (see thrusters.hpp).
#include "tubempc/actuators/thrusters.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tubempc::actuators {

namespace {

[[noreturn]] void fail(const std::string& what, const char* field, const std::string& why) {
  throw std::invalid_argument(what + "." + field + ": " + why);
}

bool finite3(const Eigen::Vector3d& v) { return v.allFinite(); }

// The truth's direction: direction_B turned by the rotation vector misalignment_B.
Eigen::Vector3d true_direction(const ThrusterSpec& s) {
  const double angle = s.misalignment_B.norm();
  if (angle == 0.0) return s.direction_B;
  return Eigen::AngleAxisd(angle, s.misalignment_B / angle) * s.direction_B;
}

}  // namespace

std::string to_string(FaultKind kind) { return core::enum_name(kind); }
std::string to_string(PulseRounding rounding) { return core::enum_name(rounding); }

FaultKind fault_kind_from_string(const std::string& name) {
  FaultKind kind = FaultKind::None;
  if (!core::enum_from_name(name, kind))
    throw std::invalid_argument("fault: expected one of " + core::enum_names_list<FaultKind>() + ", got '" +
                                name + "'");
  return kind;
}

void ThrusterSpec::validate(const std::string& what) const {
  if (!finite3(position_B)) fail(what, "position_B", "must be finite");
  if (!finite3(direction_B) || std::abs(direction_B.norm() - 1.0) > 1e-9)
    fail(what, "direction_B", "must be a unit vector");
  if (!(std::isfinite(max_thrust) && max_thrust > 0.0))
    fail(what, "max_thrust", "must be finite and > 0 (N)");
  if (!(std::isfinite(min_on_time) && min_on_time >= 0.0))
    fail(what, "min_on_time", "must be finite and >= 0 (s)");
  if (!(std::isfinite(isp) && isp > 0.0)) fail(what, "isp", "must be finite and > 0 (s)");
  if (!(std::isfinite(scale_error_bound) && scale_error_bound >= 0.0 && scale_error_bound < 1.0))
    fail(what, "scale_error_bound", "must be in [0, 1)");
  if (!(std::isfinite(scale_error) && std::abs(scale_error) <= scale_error_bound))
    fail(what, "scale_error", "must be finite with |scale_error| <= scale_error_bound");
  if (!(std::isfinite(misalignment_bound) && misalignment_bound >= 0.0 && misalignment_bound < M_PI))
    fail(what, "misalignment_bound", "must be in [0, pi) (rad)");
  if (!finite3(misalignment_B) || misalignment_B.norm() > misalignment_bound)
    fail(what, "misalignment_B", "must be finite with |misalignment_B| <= misalignment_bound (rad)");
  if (!std::isfinite(fault_time)) fail(what, "fault_time", "must be finite (s)");
}

ThrusterCluster::ThrusterCluster(std::vector<ThrusterSpec> thrusters) : specs_(std::move(thrusters)) {
  const int n = size();
  if (n < 1 || n > kMaxThrusters)
    throw std::invalid_argument("thrusters: expected 1 to " + std::to_string(kMaxThrusters) +
                                " thrusters, got " + std::to_string(n));
  D_.resize(6, n);
  D_true_.resize(6, n);
  f_max_.resize(n);
  for (int j = 0; j < n; ++j) {
    const ThrusterSpec& s = specs_[static_cast<std::size_t>(j)];
    s.validate("thrusters[" + std::to_string(j) + "]");
    D_.col(j) << s.direction_B, s.position_B.cross(s.direction_B);
    const Eigen::Vector3d d = true_direction(s);
    D_true_.col(j) << d, s.position_B.cross(d);
    D_true_.col(j) *= 1.0 + s.scale_error;
    f_max_(j) = s.max_thrust;
  }
}

void ThrusterCluster::set_fault(int i, FaultKind kind, double t_start) {
  if (i < 0 || i >= size())
    throw std::invalid_argument("set_fault.i: thruster index " + std::to_string(i) + " outside [0, " +
                                std::to_string(size()) + ")");
  if (!std::isfinite(t_start)) throw std::invalid_argument("set_fault.t_start: must be finite (s)");
  specs_[static_cast<std::size_t>(i)].fault = kind;
  specs_[static_cast<std::size_t>(i)].fault_time = t_start;
}

FaultKind ThrusterCluster::fault_at(int i, double t) const {
  const ThrusterSpec& s = specs_[static_cast<std::size_t>(i)];
  return (s.fault != FaultKind::None && t >= s.fault_time) ? s.fault : FaultKind::None;
}

int ThrusterCluster::faults_at(double t) const {
  int k = 0;
  for (int i = 0; i < size(); ++i) k += fault_at(i, t) != FaultKind::None;
  return k;
}

void ModulationSettings::validate() const {
  if (!(std::isfinite(period) && period > 0.0))
    throw std::invalid_argument("modulation.period: must be finite and > 0 (s)");
  if (!(std::isfinite(on_time_resolution) && on_time_resolution >= 0.0 && on_time_resolution <= period))
    throw std::invalid_argument("modulation.on_time_resolution: must be in [0, period] (s)");
  if (!core::is_named(rounding)) throw std::invalid_argument("modulation.rounding: not a known rounding");
}

PulseModulator::PulseModulator(const ThrusterCluster& cluster, const ModulationSettings& settings)
    : settings_(settings) {
  settings_.validate();
  const int thrusters = cluster.size();
  for (int j = 0; j < thrusters; ++j)
    if (effective_min_on_time(cluster, j) > settings_.period)
      throw std::invalid_argument(
          "thrusters[" + std::to_string(j) +
          "].min_on_time: longer than the modulation's period (rounded up to its resolution)");
  r_ = Eigen::VectorXd::Zero(thrusters);
  pulses_ = Eigen::VectorXi::Zero(thrusters);
  firing_.on_time = Eigen::VectorXd::Zero(thrusters);
  firing_.impulse = Eigen::VectorXd::Zero(thrusters);
}

void PulseModulator::reset() {
  r_.setZero();
  pulses_.setZero();
  propellant_ = 0.0;
}

double PulseModulator::effective_min_on_time(const ThrusterCluster& cluster, int j) const {
  const double q = settings_.on_time_resolution;
  const double t_min = cluster.thruster(j).min_on_time;
  return q > 0.0 ? std::ceil(t_min / q) * q : t_min;
}

double PulseModulator::remainder_bound(const ThrusterCluster& cluster, int j) const {
  return std::max(effective_min_on_time(cluster, j), settings_.on_time_resolution);
}

double PulseModulator::on_time_error_bound(const ThrusterCluster& cluster, int j) const {
  const double r_max = remainder_bound(cluster, j);
  return settings_.rounding == PulseRounding::Nearest ? 0.5 * r_max : r_max;
}

const Firing& PulseModulator::modulate(const ThrusterCluster& cluster, double t,
                                       const Eigen::Ref<const Eigen::VectorXd>& thrust_cmd) {
  const int n = static_cast<int>(r_.size());
  if (cluster.size() != n || thrust_cmd.size() != n)
    throw std::invalid_argument("modulate: the cluster and thrust_cmd must have the modulator's " +
                                std::to_string(n) + " thrusters");
  const double dt = settings_.period, q = settings_.on_time_resolution;
  const Eigen::VectorXd& f_max = cluster.max_thrust();
  firing_.commanded_B.setZero();
  firing_.delivered_B.setZero();
  firing_.propellant = 0.0;
  firing_.pulses = 0;
  for (int j = 0; j < n; ++j) {
    const double f = std::isfinite(thrust_cmd(j)) ? std::clamp(thrust_cmd(j), 0.0, f_max(j)) : 0.0;
    firing_.commanded_B += cluster.mapping().col(j) * f;
    double tau = 0.0;
    switch (cluster.fault_at(j, t)) {
      case FaultKind::FailedOff:
        r_(j) = 0.0;
        break;
      case FaultKind::StuckOn:
        tau = dt;
        r_(j) = 0.0;
        break;
      case FaultKind::None: {
        const double t_min = effective_min_on_time(cluster, j);
        if (settings_.rounding == PulseRounding::Nearest) {
          const double tau_c = f * dt / f_max(j);
          if (tau_c >= t_min)
            tau = q > 0.0 ? std::max(std::round(tau_c / q) * q, t_min) : tau_c;
          else
            tau = tau_c >= 0.5 * t_min ? t_min : 0.0;
          tau = std::min(tau, dt);
          break;
        }
        const double total = f * dt / f_max(j) + r_(j);
        double fire = q > 0.0 ? std::floor(total / q) * q : total;
        // A floor a rounding short of a whole multiple: take the multiple (keeps the remainder >= 0 exact).
        if (q > 0.0 && total - fire >= q) fire += q;
        if (fire < t_min) fire = 0.0;
        tau = std::min(fire, dt);
        r_(j) = std::max(total - tau, 0.0);
        break;
      }
    }
    firing_.on_time(j) = tau;
    const double impulse =
        cluster.true_mapping().col(j).head<3>().norm() * f_max(j) * tau;  // |(1+s) R d| F tau
    firing_.impulse(j) = impulse;
    firing_.delivered_B += cluster.true_mapping().col(j) * (f_max(j) * tau / dt);
    const double m = impulse / (cluster.thruster(j).isp * kStandardGravity);
    firing_.propellant += m;
    if (tau > 0.0) {
      ++firing_.pulses;
      ++pulses_(j);
    }
  }
  propellant_ += firing_.propellant;
  return firing_;
}

}  // namespace tubempc::actuators
