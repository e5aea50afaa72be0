/// @file propagator.hpp
/// Truth propagation of the 13-state [r_L, v_L, q_B/L, omega_BL_B] (ProximityModel::truth_derivative)
/// over one control interval with a zero-order-hold input and an additive disturbance: fixed-step
/// classical RK4 with substeps, or adaptive Dormand-Prince 5(4) with error control. The quaternion is
/// renormalised after every accepted step.
#pragma once

#include <Eigen/Dense>
#include <functional>

#include "tubempc/core/fields.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/expansion_hold.hpp"

namespace tubempc::dynamics {

using Disturbance6 =
    Eigen::Matrix<double, 6, 1>;  ///< [acceleration in L (m/s^2); angular accel. in B (rad/s^2)]

/// Additive disturbance on v' and w': constant + function(t, truth state) (function optional).
struct Disturbance {
  /// Constant part: [acceleration in L (m/s^2); angular acceleration in B (rad/s^2)].
  Disturbance6 constant{Disturbance6::Zero()};
  /// Time- and state-dependent part (same units), called at every derivative evaluation; empty: none.
  std::function<Disturbance6(double, const TruthState&)> function;

  /// The disturbance at a time and state.
  /// @param t time (s).
  /// @param s truth state [r_L (m), v_L (m/s), q_B/L, omega_BL_B (rad/s)].
  /// @return constant + function(t, s) (m/s^2 in L; rad/s^2 in B).
  Disturbance6 operator()(double t, const TruthState& s) const {
    return function ? Disturbance6(constant + function(t, s)) : constant;
  }
};

/// Integration method of the truth propagation.
enum class Integrator {
  RK4,     ///< classical fourth-order Runge-Kutta, `substeps` equal steps
  DOPRI5,  ///< Dormand-Prince 5(4), FSAL, local extrapolation, adaptive steps
};
/// Name of an integration method.
/// @param m the method.
/// @return "rk4" or "dopri5".
const char* to_string(Integrator m);

/// Settings of propagate().
struct PropagatorSettings {
  Integrator method{Integrator::RK4};  ///< integration method
  int substeps{20};                    ///< RK4 steps per call, >= 1
  double rtol{1e-10};                  ///< DOPRI5 relative tolerance, > 0
  double atol{1e-12};                  ///< DOPRI5 absolute tolerance (state units), > 0
  int max_steps{100000};               ///< DOPRI5 step budget (accepted + rejected), >= 1
  double initial_step{0.0};            ///< DOPRI5 first step (s); 0: Hairer's automatic choice
  /// The truth's gravity as its first-order expansion held over a distance (m/s^2, >= 0; docs/model.md
  /// M42 with d_min = 0): the field is evaluated, with its gradient, only where the truth leaves the
  /// hold distance sqrt(2 tol / c) of the last evaluation point, the hold carried from call to call by
  /// the run's gravity::ExpansionHold given to propagate(). 0: the field at every evaluation (the default
  /// of a scenario file without the record).
  double gravity_expansion_tolerance{0.0};

  /// Checks the ranges given above.
  /// @throws std::invalid_argument naming the first bad field.
  void validate() const;

  /// Calls visit(core::FieldInfo, member pointer) once per field, in scenario-file order: the
  /// scenario file's propagator records and the Python attributes ("One field table", docs/decisions.md).
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// Outcome of propagate().
enum class PropagationStatus {
  Success,
  MaxStepsReached,  ///< DOPRI5 used max_steps without reaching t0 + dt
  StepTooSmall,     ///< DOPRI5 step fell below 1e-14 |t| (tolerance unreachable)
  NonFinite,        ///< input, disturbance or state became non-finite
};
/// Name of a propagation status.
/// @param s the status.
/// @return its name ("success", ...).
const char* to_string(PropagationStatus s);

/// Result of propagate().
struct PropagationResult {
  PropagationStatus status{PropagationStatus::Success};  ///< outcome
  TruthState state{TruthState::Zero()};  ///< at t (unit quaternion); last good state on failure
  double t{0.0};                         ///< time reached (s)
  int steps{0};                          ///< accepted steps
  int rejected_steps{0};                 ///< DOPRI5 rejected steps
  int evaluations{0};                    ///< derivative evaluations
};

/// Propagates a truth state over one interval with the input held constant (zero-order hold).
/// @param model       the truth model (ProximityModel::truth_derivative).
/// @param t0          start time (s).
/// @param state       truth state at t0: [r_L (m), v_L (m/s), q_B/L (unit), omega_BL_B (rad/s)].
/// @param u           input held over the interval: [u_p (m/s^2, in L), T (N m, in B)].
/// @param dt          interval length (s), >= 0.
/// @param disturbance additive disturbance on v' and w' (default: none).
/// @param settings    integration method and its parameters.
/// @param gravity_hold the run's held gravity expansion, carried from call to call (its d_min and tol
///                    must be 0 and settings.gravity_expansion_tolerance); nullptr: a hold of this call
///                    alone. Unused when that tolerance is 0.
/// @return the state at t0 + dt (quaternion renormalised) and the integration's statistics; numerical
///         failures are statuses, not exceptions (a gravity the hold cannot evaluate: NonFinite).
/// @throws std::invalid_argument for invalid settings, a negative or non-finite dt, a non-unit or
///         zero quaternion, or a gravity_hold of another d_min or tolerance.
PropagationResult propagate(const ProximityModel& model, double t0, const TruthState& state,
                            const InputVector& u, double dt, const Disturbance& disturbance = {},
                            const PropagatorSettings& settings = {},
                            gravity::ExpansionHold* gravity_hold = nullptr);

}  // namespace tubempc::dynamics

namespace tubempc::core {

/// Names of dynamics::Integrator.
template <>
struct EnumNames<dynamics::Integrator> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<dynamics::Integrator>, 2> values{
      {{dynamics::Integrator::RK4, "RK4", "rk4"}, {dynamics::Integrator::DOPRI5, "DOPRI5", "dopri5"}}};
};
/// Names of dynamics::PropagationStatus.
template <>
struct EnumNames<dynamics::PropagationStatus> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<dynamics::PropagationStatus>, 4> values{
      {{dynamics::PropagationStatus::Success, "Success", "success"},
       {dynamics::PropagationStatus::MaxStepsReached, "MaxStepsReached", "max_steps_reached"},
       {dynamics::PropagationStatus::StepTooSmall, "StepTooSmall", "step_too_small"},
       {dynamics::PropagationStatus::NonFinite, "NonFinite", "non_finite"}}};
};

}  // namespace tubempc::core

namespace tubempc::dynamics {

// The table of PropagatorSettings::for_each_field.
template <typename V>
void PropagatorSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = PropagatorSettings;
  constexpr bool req = false, opt = true, finite = false;
  constexpr Dim one = Dim::One;
  visit(FieldInfo{"method", "", req, finite, one, one, ""}, &S::method);
  visit(FieldInfo{"substeps", "", req, finite, one, one, "RK4 steps per call, >= 1"}, &S::substeps);
  visit(FieldInfo{"rtol", "", req, finite, one, one, "DOPRI5 relative tolerance"}, &S::rtol);
  visit(FieldInfo{"atol", "state units", req, finite, one, one, "DOPRI5 absolute tolerance (state units)"},
        &S::atol);
  visit(FieldInfo{"max_steps", "", req, finite, one, one, "DOPRI5 step budget"}, &S::max_steps);
  visit(FieldInfo{"initial_step", "s", req, finite, one, one, "DOPRI5 first step (s); 0: automatic"},
        &S::initial_step);
  visit(
      FieldInfo{
          "gravity_expansion_tolerance", "m/s^2", opt, finite, one, one,
          "the truth's gravity as an expansion held to this error (m/s^2); 0: the field at every evaluation"},
      &S::gravity_expansion_tolerance);
}

}  // namespace tubempc::dynamics
