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
  if (opposed_pairs && rounding != PulseRounding::Nearest)
    throw std::invalid_argument("modulation.opposed_pairs: needs rounding = \"nearest\"");
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
  f_cmd_ = Eigen::VectorXd::Zero(thrusters);
  pulses_ = Eigen::VectorXi::Zero(thrusters);
  partner_ = Eigen::VectorXi::Constant(thrusters, -1);
  if (settings_.opposed_pairs) {
    // Pairs in index order: D_p = -D_j (one line of action), the same thrust and minimum on-time.
    bool any = false;
    for (int j = 0; j < thrusters; ++j)
      for (int p = j + 1; p < thrusters && partner_(j) < 0; ++p) {
        const ThrusterSpec &a = cluster.thruster(j), &b = cluster.thruster(p);
        if (partner_(p) >= 0 ||
            (cluster.mapping().col(j) + cluster.mapping().col(p)).cwiseAbs().maxCoeff() > 1e-9 ||
            a.max_thrust != b.max_thrust || a.min_on_time != b.min_on_time)
          continue;
        if (2.0 * effective_min_on_time(cluster, j) > settings_.period)
          throw std::invalid_argument(
              "modulation.opposed_pairs: thrusters[" + std::to_string(j) + "] and [" + std::to_string(p) +
              "] need twice the minimum on-time (rounded up to the resolution) within "
              "the period");
        partner_(j) = p;
        partner_(p) = j;
        any = true;
      }
    if (!any)
      throw std::invalid_argument(
          "modulation.opposed_pairs: no two thrusters are opposed on one line of action with the same thrust "
          "and minimum on-time");
  }
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

double PulseModulator::on_time_excess_bound(const ThrusterCluster& cluster, int j) const {
  if (partner_(j) < 0) return on_time_error_bound(cluster, j);
  return effective_min_on_time(cluster, j) + 0.5 * settings_.on_time_resolution;
}

double PulseModulator::nearest_level(double tau_c, double t_min) const {
  const double q = settings_.on_time_resolution;
  double tau = 0.0;
  if (tau_c >= t_min)
    tau = q > 0.0 ? std::max(std::round(tau_c / q) * q, t_min) : tau_c;
  else
    tau = tau_c >= 0.5 * t_min ? t_min : 0.0;
  return std::min(tau, settings_.period);
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
    f_cmd_(j) = f;
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
          tau = nearest_level(f * dt / f_max(j), t_min);
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
  }
  // Opposed pairs, both healthy: the net command, fired by the thruster it points along (M34'').
  for (int j = 0; j < n; ++j) {
    const int p = partner_(j);
    if (p < j || cluster.fault_at(j, t) != FaultKind::None || cluster.fault_at(p, t) != FaultKind::None)
      continue;
    const double net = (f_cmd_(j) - f_cmd_(p)) * dt / f_max(j), t_min = effective_min_on_time(cluster, j);
    const int a = net >= 0.0 ? j : p, b = net >= 0.0 ? p : j;
    const double d = std::abs(net);
    if (d >= t_min) {
      firing_.on_time(a) = nearest_level(d, t_min);
      firing_.on_time(b) = 0.0;
    } else {
      const double d_q = q > 0.0 ? std::round(d / q) * q : d;
      firing_.on_time(a) = d_q > 0.0 ? t_min + d_q : 0.0;
      firing_.on_time(b) = d_q > 0.0 ? t_min : 0.0;
    }
  }
  for (int j = 0; j < n; ++j) {
    const double tau = firing_.on_time(j);
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
