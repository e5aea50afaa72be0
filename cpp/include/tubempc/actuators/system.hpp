/// @file system.hpp
/// The actuators of a spacecraft as one per-period call (docs/model.md "Actuators", M37-M38): the MPC's
/// command u = [u_p (m/s^2, L); T (N m, B)] becomes a wrench in B (M32), is allocated to thrusts and wheel
/// torques (M35), the thrusts are pulse-modulated (M34) and fired by the truth's thrusters (with their
/// scale and misalignment errors and faults), the wheels apply their torques and dump momentum; the call
/// returns the input actually delivered over the period, in the MPC's coordinates, with the period's
/// accounting (impulse, propellant, pulses, wheel momentum).
///
/// Lifecycle: construct (copies the actuators, sizes every buffer, validates), then `step` once per
/// control period; `reset` starts a mission again. `step` allocates no memory and has no unbounded loop
/// (the allocation's iteration cap); every numerical outcome is a status, never an exception or a NaN.
#pragma once

#include <Eigen/Dense>
#include <string>

#include "tubempc/actuators/allocation.hpp"
#include "tubempc/actuators/reaction_wheels.hpp"
#include "tubempc/actuators/thrusters.hpp"

namespace tubempc::actuators {

/// Settings of the actuation system.
struct ActuationSettings {
  double mass = 1.0;  ///< The spacecraft's mass for M32 (kg, > 0; propellant use does not change it).
  /// Pulse modulation; its period is the control period.
  ModulationSettings modulation;
  /// Allocation; its period must equal modulation.period.
  AllocationSettings allocation;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);

  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// One period's actuation (buffers sized at construction, overwritten by every step).
struct ActuationStep {
  /// Outcome: the allocation's (a non-finite attitude, like a non-finite command, is InvalidCommand).
  AllocationStatus status = AllocationStatus::Ok;
  AllocationInfo allocation;              ///< The allocation's counters.
  Vector6 u_commanded = Vector6::Zero();  ///< The command [u_p (m/s^2, L); T (N m, B)] as received.
  /// The input delivered over the period (period average), [u_p (m/s^2, L); T (N m, B)]; always finite.
  Vector6 u_delivered = Vector6::Zero();
  Vector6 commanded_B = Vector6::Zero();  ///< The commanded wrench (M32; N, N m).
  Vector6 allocated_B = Vector6::Zero();  ///< The allocated nominal wrench M x (N, N m).
  Vector6 delivered_B = Vector6::Zero();  ///< The truth's period-average delivered wrench (N, N m).
  /// The actuation error allocated_B - delivered_B (M36's e; N, N m).
  Vector6 error_B = Vector6::Zero();
  /// What the allocation could not deliver, commanded_B - allocated_B (N, N m).
  Vector6 remainder_B = Vector6::Zero();
  Eigen::VectorXd thrust;          ///< Allocated period-average thrusts (N, n).
  Eigen::VectorXd on_time;         ///< Modulated on-times (s, n).
  Eigen::VectorXd impulse;         ///< Impulse of each thruster, truth (N s, n).
  Eigen::VectorXd wheel_torque;    ///< Wheel torques applied on the spacecraft (N m, m).
  Eigen::VectorXd wheel_momentum;  ///< Wheel momenta after the period (N m s, m).
  double impulse_total = 0.0;      ///< Sum of the thrusters' impulse magnitudes in the period (N s).
  double delta_v = 0.0;            ///< impulse_total / mass: the period's thruster delta-v (m/s).
  double propellant = 0.0;         ///< Propellant spent in the period (kg).
  int pulses = 0;                  ///< Thrusters fired in the period.
  int failed_thrusters = 0;        ///< Thrusters failed (off or stuck on) at the period's start.
  int failed_wheels = 0;           ///< Wheels failed at the period's start (ReactionWheels::set_failure).
  double step_time = 0.0;          ///< Wall-clock time of the call (s).
};

/// Totals of a mission since construction or the last reset.
struct ActuationTotals {
  double impulse = 0.0;                      ///< Sum of thruster impulse magnitudes (N s).
  double delta_v = 0.0;                      ///< impulse / mass (m/s).
  double propellant = 0.0;                   ///< Propellant (kg).
  long pulses = 0;                           ///< Thruster firings.
  int steps = 0;                             ///< Periods actuated.
  int not_delivered = 0;                     ///< Periods with status Saturated, Infeasible or InvalidCommand.
  double max_wheel_momentum_fraction = 0.0;  ///< Largest |h_j| / h_max_j reached.
};

/// The actuation system: thrusters (the truth's, with its errors and faults; the allocation knows their
/// nominal geometry and the faults at each period's start), wheels, allocator and modulator.
class ActuationSystem {
 public:
  /// @param cluster the thrusters as the truth has them (nominal geometry, truth errors, faults).
  /// @param wheels the wheels (their momentum is the initial one).
  /// @param settings the settings (validated).
  ActuationSystem(const ThrusterCluster& cluster, const ReactionWheels& wheels,
                  const ActuationSettings& settings);

  /// Actuates one period. Allocation-free; a non-finite command or attitude gives InvalidCommand.
  /// @param t the period's start time (s; faults are read at it).
  /// @param u the command [u_p (m/s^2, L); T (N m, B)].
  /// @param C_BL the rotation from L to B over the period (C_BL = Exp(phi)^T).
  /// @return the period's actuation (valid until the next call).
  const ActuationStep& step(double t, const Vector6& u, const Eigen::Matrix3d& C_BL) noexcept;

  /// Back to the start of a mission: remainders, totals and wheel momenta (to `wheel_momentum`, N m s).
  /// @param wheel_momentum the wheels' momenta (m; |h_j| <= h_max_j).
  void reset(const Eigen::Ref<const Eigen::VectorXd>& wheel_momentum);

  /// @return the mission's totals.
  const ActuationTotals& totals() const { return totals_; }
  /// @return the thrusters (the truth's).
  const ThrusterCluster& cluster() const { return cluster_; }
  /// @return the wheels and their momentum.
  const ReactionWheels& wheels() const { return wheels_; }
  /// @return the allocator (its last problem: Allocator::last_problem).
  const Allocator& allocator() const { return allocator_; }
  /// @return the modulator (its remainders and counts).
  const PulseModulator& modulator() const { return modulator_; }
  /// @return the settings.
  const ActuationSettings& settings() const { return settings_; }

 private:
  ActuationSettings settings_;
  ThrusterCluster cluster_;
  ReactionWheels wheels_;
  Allocator allocator_;
  PulseModulator modulator_;
  ActuationStep out_;
  ActuationTotals totals_;
};

}  // namespace tubempc::actuators

namespace tubempc::actuators {

// The table of ActuationSettings::for_each_field.
template <typename V>
void ActuationSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = ActuationSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One;
  visit(FieldInfo{"mass", "kg", req, finite, one, one, "the spacecraft's mass for M32 (kg), > 0"}, &S::mass);
  visit(FieldInfo{"modulation", "", req, finite, one, one,
                  "pulse modulation; its period is the control period"},
        &S::modulation);
  visit(FieldInfo{"allocation", "", req, finite, one, one,
                  "allocation; its period must equal modulation.period"},
        &S::allocation);
}

}  // namespace tubempc::actuators
