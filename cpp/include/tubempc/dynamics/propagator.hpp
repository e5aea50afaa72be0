/// @file propagator.hpp
/// Truth propagation of the 13-state [r_L, v_L, q_B/L, omega_BL_B] (ProximityModel::truth_derivative)
/// over one control interval with a zero-order-hold input and an additive disturbance: fixed-step
/// classical RK4 with substeps, or adaptive Dormand-Prince 5(4) with error control. The quaternion is
/// renormalised after every accepted step.
#pragma once

#include <Eigen/Dense>
#include <functional>

#include "tubempc/dynamics/proximity_model.hpp"

namespace tubempc::dynamics {

using Disturbance6 =
    Eigen::Matrix<double, 6, 1>;  ///< [acceleration in L (m/s^2); angular accel. in B (rad/s^2)]

/// Additive disturbance on v' and w': constant + function(t, truth state) (function optional).
struct Disturbance {
  Disturbance6 constant{Disturbance6::Zero()};
  std::function<Disturbance6(double, const TruthState&)> function;  ///< empty: none

  Disturbance6 operator()(double t, const TruthState& s) const {
    return function ? Disturbance6(constant + function(t, s)) : constant;
  }
};

enum class Integrator {
  RK4,     ///< classical fourth-order Runge-Kutta, `substeps` equal steps
  DOPRI5,  ///< Dormand-Prince 5(4), FSAL, local extrapolation, adaptive steps
};
const char* to_string(Integrator m);

struct PropagatorSettings {
  Integrator method{Integrator::RK4};
  int substeps{20};          ///< RK4 steps per call, >= 1
  double rtol{1e-10};        ///< DOPRI5 relative tolerance, > 0
  double atol{1e-12};        ///< DOPRI5 absolute tolerance (state units), > 0
  int max_steps{100000};     ///< DOPRI5 step budget (accepted + rejected), >= 1
  double initial_step{0.0};  ///< DOPRI5 first step (s); 0: Hairer's automatic choice

  /// Throws std::invalid_argument naming the first bad field.
  void validate() const;
};

enum class PropagationStatus {
  Success,
  MaxStepsReached,  ///< DOPRI5 used max_steps without reaching t0 + dt
  StepTooSmall,     ///< DOPRI5 step fell below 1e-14 |t| (tolerance unreachable)
  NonFinite,        ///< input, disturbance or state became non-finite
};
const char* to_string(PropagationStatus s);

struct PropagationResult {
  PropagationStatus status{PropagationStatus::Success};
  TruthState state{TruthState::Zero()};  ///< at t (unit quaternion); last good state on failure
  double t{0.0};                         ///< time reached (s)
  int steps{0};                          ///< accepted steps
  int rejected_steps{0};                 ///< DOPRI5 rejected steps
  int evaluations{0};                    ///< derivative evaluations
};

/// Propagates `state` from t0 over dt >= 0 (s) with input u held constant. Invalid settings or a
/// non-unit/zero quaternion throw std::invalid_argument; numerical outcomes are statuses.
PropagationResult propagate(const ProximityModel& model, double t0, const TruthState& state,
                            const InputVector& u, double dt, const Disturbance& disturbance = {},
                            const PropagatorSettings& settings = {});

}  // namespace tubempc::dynamics
