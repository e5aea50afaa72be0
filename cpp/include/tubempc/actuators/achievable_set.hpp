/// @file achievable_set.hpp
/// The sets the tube design needs from the actuators (docs/model.md "Actuators"): an inner box of the
/// wrenches the thrusters and wheels can always deliver, and a box containing every actuation error
/// (commanded minus delivered wrench), each also in the MPC's input coordinates [u_p (m/s^2, L); T (N m, B)].
/// Both are set-up computations (they allocate).
#pragma once

#include <Eigen/Dense>
#include <limits>

#include "tubempc/actuators/allocation.hpp"
#include "tubempc/actuators/reaction_wheels.hpp"
#include "tubempc/actuators/thrusters.hpp"

namespace tubempc::actuators {

/// An inner box of the achievable wrenches: every w_B with |w_i| <= half_width_B_i is allocated with a
/// remainder within the allocation's tolerance, for every wheel momentum with |h_j| <= momentum_fraction
/// h_max_j, with the cluster's faults at AchievableBoxSettings::time and (if asked) any one more thruster
/// failed off.
struct AchievableBox {
  /// Half-widths of the box of [F_B (N); T_B (N m)].
  Vector6 half_width_B = Vector6::Zero();
  /// The box in MPC input coordinates, valid at every attitude: |u_p,i| <= min_k a_F,k / (m sqrt 3)
  /// (m/s^2, L) and |T_i| <= a_T,i (N m), a = half_width_B.
  Vector6 input_half_width = Vector6::Zero();
  double scale = 0.0;         ///< The box is scale diag(shape) (the largest verified scale).
  int limiting_failure = -1;  ///< The additional failed thruster that limits the box (-1: none).
  bool empty = false;         ///< Not even the zero wrench is delivered: no inner box (all half-widths 0).
  int vertices_checked = 0;  ///< Allocations run on the box's vertices (64 per scale tried and failure case).
};

/// Settings of the inner-box computation.
struct AchievableBoxSettings {
  Vector6 shape = Vector6::Ones();  ///< The box's aspect: half-widths proportional to it (N, N m; > 0).
  /// Wheel momenta up to this fraction of their limit are covered (in [0, 1)).
  double momentum_fraction = 0.8;
  bool tolerate_one_failure = true;  ///< Whether the box must hold with any one thruster failed off.
  int bisection_steps = 40;          ///< Bisection steps on the scale (>= 1).
  double time = 0.0;                 ///< Time at which the cluster's faults are read (s).

  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// The largest box scale diag(shape) whose 64 vertices are all allocated within tolerance (the achievable set
/// of a box-constrained linear map is convex, so the vertices suffice), found by bisection; the result is the
/// last scale verified, a deterministic inner approximation up to the allocation's remainder tolerance.
/// The wheels' torque box is the one of the worst momentum within momentum_fraction: |u_j| <=
/// min(u_max_j, (1 - momentum_fraction) h_max_j / period).
/// @param cluster the thrusters, with their faults at settings.time (none configured: the healthy cluster).
/// @param wheels the wheels (their momentum is ignored).
/// @param allocation the allocation settings (its period and tolerances).
/// @param mass the spacecraft's mass (kg, > 0), for input_half_width.
/// @param settings the computation's settings.
/// @return the box.
AchievableBox achievable_box(const ThrusterCluster& cluster, const ReactionWheels& wheels,
                             const AllocationSettings& allocation, double mass,
                             const AchievableBoxSettings& settings = {});

/// A box containing every actuation error e = M x - w_delivered of a period: the allocated nominal wrench
/// minus the truth's period-average delivered wrench. Certified (deterministic) for: commanded thrusts in
/// [0, F_j] with the cluster's faults known to the allocation, the modulator's remainders in [0, r_max_j)
/// (true from a reset; none with PulseRounding::Nearest), and truth errors within the thrusters' scale_error_bound and misalignment_bound.
/// The wheels deliver their allocated torque exactly (their bounds are the allocation's).
struct ActuationErrorBound {
  /// Part from pulse modulation: sum_j |D_ij| F_j e_j / dt, e_j the modulator's on-time error bound
  /// (PulseModulator::on_time_error_bound: r_max_j, or r_max_j / 2 with PulseRounding::Nearest; an opposed
  /// pair's net error, at most q / 2, is within its two terms) (N, N m).
  Vector6 modulation_B = Vector6::Zero();
  /// Part from scale and misalignment errors: sum_j a_ij f_j over the delivered thrusts f_j, a_ij = max |v_j .
  /// c_ij| with v_j = (1 + s) R d_j - d_j over |s| <= s_j and rotations by at most theta_j, c_ij = e_i for
  /// force rows and e_i x p_j for torque rows (exact per thruster). For any command it is sum_j a_ij F_j
  /// (every thruster at full thrust); for commands in a box, min(sum_j a_ij F_j, ||a_i||_2 (thrust_norm +
  /// ||F_j x_j / dt||_2)) with x_j the modulator's on-time excess bound (PulseModulator::on_time_excess_bound)
  /// (N, N m).
  Vector6 misalignment_B = Vector6::Zero();
  /// Bound on ||f||_2 of the commanded thrusts used by misalignment_B (N): sqrt(sum_j F_j^2) for any command.
  double thrust_norm = 0.0;
  /// The sum of both: |e_i| <= wrench_B_i (N, N m).
  Vector6 wrench_B = Vector6::Zero();
  /// The box in MPC input coordinates, valid at every attitude: |e_u_p,i| <= ||wrench_B(0:3)||_2 / m
  /// (m/s^2, L) and |e_T,i| <= wrench_B(3 + i) (N m).
  Vector6 input = Vector6::Zero();
  /// Ellipsoid {e : e^T shape_p^-1 e <= 1} of the u_p error at every attitude: the ball
  /// (||wrench_B(0:3)||_2 / m)^2 I ((m/s^2)^2).
  Eigen::Matrix3d shape_p = Eigen::Matrix3d::Zero();
  /// Ellipsoid {e : e^T shape_T^-1 e <= 1} of the torque error: 3 diag(wrench_B(3:6))^2, the smallest-volume
  /// ellipsoid around the torque box ((N m)^2).
  Eigen::Matrix3d shape_T = Eigen::Matrix3d::Zero();
};

/// The actuation-error box (see ActuationErrorBound).
/// @param cluster the thrusters (their error bounds).
/// @param modulator the modulator (its period and resolution).
/// @param mass the spacecraft's mass (kg, > 0).
/// @return the bound.
ActuationErrorBound actuation_error_bound(const ThrusterCluster& cluster, const PulseModulator& modulator,
                                          double mass);

/// The actuation-error box for commands inside a wrench box |w_i| <= command_half_width_B_i (e.g. the
/// achievable box), tighter than the one for any command: the thrusts the allocation commands are bounded in
/// norm. Given the wheels' torques u, the allocated thrusts minimise the thruster-only objective
/// J(w') = ||W_r (D f - w')||^2 + thrust_weight^2 ||f||^2 for w' = w_B - [0; G u], so thrust_weight^2 ||f||^2 <=
/// J(w'); J is convex in w', so over the box plus every wheel torque (|u_j| <= u_max_j) its maximum is at a
/// vertex of that zonotope, all of which are allocated here. Certified (deterministic) under the assumptions of
/// ActuationErrorBound, for converged allocations (not AllocationStatus::MaxIterations), with or without
/// momentum dumping, for the cluster's faults at time t and, if asked, any one more thruster failed off.
/// @param cluster the thrusters (their error bounds and their faults at time t).
/// @param modulator the modulator (its period and resolution).
/// @param mass the spacecraft's mass (kg, > 0).
/// @param wheels the wheels (their axes and torque limits).
/// @param allocation the allocation's settings (its weights).
/// @param command_half_width_B half-widths of the command box (N, N m; >= 0).
/// @param t time at which the cluster's faults are read (s).
/// @param tolerate_one_failure whether the bound must hold with any one more thruster failed off.
/// @param command_force_norm a bound on the command's force norm ||F_B||_2 as well (N, > 0; +inf: none), e.g.
/// sqrt(3) m u_max for |u_p,i| <= u_max in L at any attitude. The force part of the box is then cut by the
/// octahedron |F_x| + |F_y| + |F_z| <= sqrt(3) command_force_norm, which contains that ball, and J's maximum
/// is taken at the vertices of the cut box instead (fewer and shorter forces than the box's corners).
/// @return the bound.
ActuationErrorBound actuation_error_bound(
    const ThrusterCluster& cluster, const PulseModulator& modulator, double mass,
    const ReactionWheels& wheels, const AllocationSettings& allocation, const Vector6& command_half_width_B,
    double t = 0.0, bool tolerate_one_failure = true,
    double command_force_norm = std::numeric_limits<double>::infinity());

/// The disturbance set of a subsystem's tube design with the actuation error added (docs/model.md M38): an
/// ellipsoid {w : w^T P^-1 w <= 1} containing W (+) B E, the Minkowski sum of W = {w : w^T P_W^-1 w <= 1} and
/// the image under B of the input error set E = {e : e^T E^-1 e <= 1}: P = P_W / (1 - beta) + P_E / beta,
/// P_E = B E B^T, which contains the sum for every beta in (0, 1). beta is chosen for the smallest volume
/// (log det P): 33 values of logit(beta) within +-8 of the start b / (a + b) (a = sqrt(6), b^2 = sum_i
/// P_E,ii / P_W,ii, the trace-minimal beta in the coordinates that make diag(P_W) = 1), then 30 golden-section
/// steps between the neighbours of the best. E = 0 returns P_W. Allocation-free, a fixed number of 6 x 6
/// Cholesky factorisations.
/// @param P_W the disturbance set's shape (6 x 6, symmetric positive definite; state units squared).
/// @param B the subsystem's discrete input matrix (6 x 3; state units per input unit).
/// @param E the input error set's shape (3 x 3, symmetric positive semidefinite; input units squared).
/// @return the shape P.
Eigen::Matrix<double, 6, 6> disturbance_with_actuation_error(const Eigen::Matrix<double, 6, 6>& P_W,
                                                             const Eigen::Matrix<double, 6, 3>& B,
                                                             const Eigen::Matrix3d& E);

}  // namespace tubempc::actuators
