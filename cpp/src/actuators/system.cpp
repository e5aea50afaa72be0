// The per-period actuation call (see system.hpp).
#include "tubempc/actuators/system.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace tubempc::actuators {

void ActuationSettings::validate() const {
  if (!(std::isfinite(mass) && mass > 0.0))
    throw std::invalid_argument("actuation.mass: must be finite and > 0 (kg)");
  modulation.validate();
  allocation.validate();
  if (allocation.period != modulation.period)
    throw std::invalid_argument(
        "actuation.allocation.period: must equal modulation.period (the control period, s)");
}

namespace {

ActuationSettings validated(const ActuationSettings& s) {
  s.validate();
  return s;
}

}  // namespace

ActuationSystem::ActuationSystem(const ThrusterCluster& cluster, const ReactionWheels& wheels,
                                 const ActuationSettings& settings)
    : settings_(validated(settings)),
      cluster_(cluster),
      wheels_(wheels),
      allocator_(cluster_, wheels_, settings_.allocation),
      modulator_(cluster_, settings_.modulation) {
  const int n = cluster_.size(), m = wheels_.size();
  out_.thrust = Eigen::VectorXd::Zero(n);
  out_.on_time = Eigen::VectorXd::Zero(n);
  out_.impulse = Eigen::VectorXd::Zero(n);
  out_.wheel_torque = Eigen::VectorXd::Zero(m);
  out_.wheel_momentum = wheels_.momentum();
}

void ActuationSystem::reset(const Eigen::Ref<const Eigen::VectorXd>& wheel_momentum) {
  wheels_.set_momentum(wheel_momentum);
  modulator_.reset();
  totals_ = ActuationTotals{};
  out_.wheel_momentum = wheels_.momentum();
}

const ActuationStep& ActuationSystem::step(double t, const Vector6& u, const Eigen::Matrix3d& C_BL) noexcept {
  const auto t0 = std::chrono::steady_clock::now();
  const double dt = settings_.modulation.period, mass = settings_.mass;
  const bool attitude_ok = C_BL.allFinite();
  out_.u_commanded = u;
  out_.commanded_B = attitude_ok ? wrench_from_input(u, C_BL, mass)
                                 : Vector6::Constant(std::numeric_limits<double>::quiet_NaN());
  wheels_.update_failures(t);  // a wheel failed by t gives no torque from this period on
  // M35: a non-finite wrench is the allocation's InvalidCommand (no thrust, no wheel torque).
  const AllocationResult& a = allocator_.solve(cluster_, wheels_, t, out_.commanded_B);
  out_.allocation = a.info;
  out_.status = a.info.status;
  out_.thrust = a.thrust;
  out_.allocated_B = a.wrench_B;
  out_.remainder_B = out_.commanded_B.allFinite() ? Vector6(out_.commanded_B - a.wrench_B) : Vector6::Zero();
  // M34 with the truth's thrusters, then the wheels (exact torques, momentum limits kept).
  const Firing& f = modulator_.modulate(cluster_, t, a.thrust);
  const Eigen::Vector3d T_wheels_B = wheels_.apply(a.wheel_torque, dt);
  out_.on_time = f.on_time;
  out_.impulse = f.impulse;
  out_.wheel_torque = wheels_.applied_torque();
  out_.wheel_momentum = wheels_.momentum();
  out_.delivered_B = f.delivered_B;
  out_.delivered_B.tail<3>() += T_wheels_B;
  out_.error_B = out_.allocated_B - out_.delivered_B;
  // Without a finite attitude the force cannot be put in L: none is reported (the status says why).
  out_.u_delivered = attitude_ok ? input_from_wrench(out_.delivered_B, C_BL, mass) : Vector6::Zero();
  if (!attitude_ok) out_.u_delivered.tail<3>() = out_.delivered_B.tail<3>();
  out_.impulse_total = f.impulse.sum();
  out_.delta_v = out_.impulse_total / mass;
  out_.propellant = f.propellant;
  out_.pulses = f.pulses;
  out_.failed_thrusters = cluster_.faults_at(t);
  out_.failed_wheels = wheels_.failed();

  totals_.impulse += out_.impulse_total;
  totals_.delta_v += out_.delta_v;
  totals_.propellant += out_.propellant;
  totals_.pulses += out_.pulses;
  ++totals_.steps;
  if (out_.status == AllocationStatus::Saturated || out_.status == AllocationStatus::Infeasible ||
      out_.status == AllocationStatus::InvalidCommand)
    ++totals_.not_delivered;
  const int m = wheels_.size();
  for (int j = 0; j < m; ++j)
    totals_.max_wheel_momentum_fraction = std::max(
        totals_.max_wheel_momentum_fraction, std::abs(out_.wheel_momentum(j)) / wheels_.max_momentum()(j));
  out_.step_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out_;
}

}  // namespace tubempc::actuators
