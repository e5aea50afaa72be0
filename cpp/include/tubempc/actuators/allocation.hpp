/// @file allocation.hpp
/// Control allocation (docs/model.md "Actuators"): a commanded wrench w_B = [F_B (N); T_B (N m)] to thruster
/// thrusts f (N, n) and wheel torques u (N m, m) by the bounded least-squares problem
///
///     minimise  ||W_r (M x - w_B)||^2 + ||W_x (x - x_pref)||^2     over x = [f; u]
///     subject to  0 <= f_j <= F_j (healthy),  f_j = 0 (failed off),  f_j = F_j (stuck on),
///                 u_lo <= u <= u_hi (the wheels' torque and momentum limits over the period),
///
/// M = [D; 0 G] (D the nominal thruster mapping, G the wheel axes), W_r = diag(residual_weight),
/// W_x = diag(thrust_weight, wheel_weight or dump_weight while dumping) a small regularisation that makes the
/// solution unique and prefers x_pref = [0; u_dump]. It is solved by a primal active-set method with a fixed
/// iteration cap on a fixed-size workspace (docs/decisions.md "Allocation algorithm"); what cannot be
/// delivered, w_B - M x, is reported as the remainder, with a Status.
///
/// Frames and mass: the MPC commands u = [u_p (m/s^2, in L); T (N m, in B)]. The wrench is
/// F_B = m C_BL u_p (m the spacecraft's mass, C_BL = Exp(phi)^T) and T_B = T: wrench_from_input.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <string>

#include "tubempc/actuators/reaction_wheels.hpp"
#include "tubempc/actuators/thrusters.hpp"
#include "tubempc/core/fields.hpp"

namespace tubempc::actuators {

/// Largest number of allocation variables (thrusters + wheels).
inline constexpr int kMaxVariables = kMaxThrusters + kMaxWheels;

/// The wrench in B of an MPC input: [m C_BL u_p; T].
/// @param u the MPC input [u_p (m/s^2, in L); T (N m, in B)].
/// @param C_BL the rotation from L to B (C_BL = Exp(phi)^T).
/// @param mass the spacecraft's mass (kg).
/// @return [F_B (N); T_B (N m)].
Vector6 wrench_from_input(const Vector6& u, const Eigen::Matrix3d& C_BL, double mass);
/// The MPC input of a wrench in B: [C_BL^T F_B / m; T_B] (the inverse of wrench_from_input).
/// @param w_B the wrench [F_B (N); T_B (N m)].
/// @param C_BL the rotation from L to B.
/// @param mass the spacecraft's mass (kg).
/// @return [u_p (m/s^2, in L); T (N m, in B)].
Vector6 input_from_wrench(const Vector6& w_B, const Eigen::Matrix3d& C_BL, double mass);

/// Outcome of an allocation.
enum class AllocationStatus {
  Ok,              ///< Delivered within tolerance, every thruster healthy.
  ThrusterFailed,  ///< Delivered within tolerance with at least one thruster failed (re-solved around it).
  Saturated,       ///< Not delivered: the direction can be produced but not the magnitude; the least-squares
                   ///< best is returned and the remainder reported.
  Infeasible,      ///< Not delivered: the command has a direction the available actuators cannot produce at
                   ///< any magnitude; the least-squares best is returned and the remainder reported.
  MaxIterations,   ///< The active-set cap was reached: a feasible, possibly suboptimal allocation.
  InvalidCommand,  ///< Non-finite command: no thrust (stuck-on thrusters still fire), no wheel torque.
};

/// Name of a status ("ok", "thruster_failed", "saturated", "infeasible", "max_iterations", "invalid_command";
/// core::EnumNames<AllocationStatus>).
std::string to_string(AllocationStatus status);

/// Settings of the allocation.
struct AllocationSettings {
  double period = 1.0;                        ///< Control period (s, > 0), for the wheels' momentum limits.
  Vector6 residual_weight = Vector6::Ones();  ///< W_r: 3 force rows (1/N), 3 torque rows (1/(N m)); > 0.
  double thrust_weight = 1e-3;                ///< W_x on thrusts (1/N, > 0).
  double wheel_weight = 1e-3;                 ///< W_x on wheel torques (1/(N m), > 0).
  double dump_weight = 1e-1;                  ///< W_x on wheel torques while dumping (1/(N m), > 0).
  int max_iterations = 200;                   ///< Active-set iteration cap (>= 1).
  double optimality_tolerance = 1e-11;  ///< Multiplier sign tolerance, relative to the gradient's scale.
  double remainder_tolerance = 1e-5;    ///< Delivered if ||W_r r||_inf <= this (||W_r w||_inf + 1) (> 0).
  double cone_test_scale = 1e-3;  ///< Scale of the command in the Saturated/Infeasible test (in (0, 1]).

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);

  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// Counters and outcome of an allocation.
struct AllocationInfo {
  AllocationStatus status = AllocationStatus::Ok;  ///< Outcome.
  int iterations = 0;        ///< Active-set iterations (both solves when the cone test ran).
  int failed_thrusters = 0;  ///< Thrusters failed at the solve's time.
  bool resetup = false;      ///< Whether the fault set changed at this solve (bounds and workspace re-set).
  bool dumping = false;      ///< Whether the wheels were being unloaded.
  double remainder_norm = 0.0;  ///< ||W_r (w_B - M x)||_inf (weighted units).
  double solve_time = 0.0;      ///< Wall-clock time of the solve (s).
};

/// Result of an allocation (buffers sized at construction, overwritten by every solve).
struct AllocationResult {
  Eigen::VectorXd thrust;              ///< Period-average thrust of each thruster (N, n), in [0, F_j].
  Eigen::VectorXd wheel_torque;        ///< Wheel torques on the spacecraft (N m, m), within the period's box.
  Vector6 wrench_B = Vector6::Zero();  ///< M x, the nominal wrench allocated (N, N m).
  Vector6 remainder_B = Vector6::Zero();  ///< w_B - M x, what is not delivered (N, N m).
  AllocationInfo info;                    ///< Outcome and counters.
};

/// The allocator. Construction copies the nominal geometry and sizes every buffer; solve() does not
/// allocate. A change of the cluster's fault set between solves is detected and the bounds re-set.
class Allocator {
 public:
  /// @param cluster the thrusters (nominal geometry copied; faults read at each solve).
  /// @param wheels the wheels (geometry copied; momentum read at each solve).
  /// @param settings the settings (validated).
  Allocator(const ThrusterCluster& cluster, const ReactionWheels& wheels,
            const AllocationSettings& settings = {});

  /// Allocates a wrench. Dimension mismatches with the construction throw std::invalid_argument; every
  /// numerical outcome is a status.
  /// @param cluster the thrusters (their faults at time t are applied).
  /// @param wheels the wheels (their momentum bounds and dump preference are applied).
  /// @param t time (s).
  /// @param w_B the commanded wrench [F_B (N); T_B (N m)].
  /// @return the allocation (valid until the next solve).
  const AllocationResult& solve(const ThrusterCluster& cluster, const ReactionWheels& wheels, double t,
                                const Vector6& w_B);

  /// The last solve's problem as min ||A x - b||^2, lower <= x <= upper (for checks against other solvers;
  /// allocates).
  /// @param A the stacked matrix [W_r M; W_x] ((6 + n + m) x (n + m)).
  /// @param b the stacked right-hand side [W_r w_B; W_x x_pref].
  /// @param lower lower bounds of x.
  /// @param upper upper bounds of x.
  void last_problem(Eigen::MatrixXd& A, Eigen::VectorXd& b, Eigen::VectorXd& lower,
                    Eigen::VectorXd& upper) const;

  /// Marks thrusters as failed off in addition to the cluster's faults, for the next solves (what-if
  /// allocations, e.g. the achievable set with one thruster failed). Not for the control step: it is not
  /// time-dependent.
  /// @param failed_off per-thruster flag (n; nonzero: failed off), or an empty vector to clear.
  void set_extra_failures(const Eigen::VectorXi& failed_off);

  /// @return the number of thrusters n.
  int thrusters() const { return n_; }
  /// @return the number of wheels m.
  int wheels() const { return m_; }
  /// @return M = [D; 0 G] (6 x (n + m)).
  const Eigen::Matrix<double, 6, Eigen::Dynamic>& mapping() const { return M_; }
  /// @return the settings.
  const AllocationSettings& settings() const { return settings_; }

  /// Internal fixed-capacity vector of the allocation variables.
  using VarVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxVariables, 1>;
  /// Internal fixed-capacity matrix over the allocation variables.
  using VarMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxVariables, kMaxVariables>;

 private:
  int active_set(const VarVector& g, VarVector& x, bool& converged);
  void set_bounds(const ThrusterCluster& cluster, const ReactionWheels& wheels, double t);
  double weighted_inf(const Vector6& r) const;

  AllocationSettings settings_;
  int n_ = 0, m_ = 0, nv_ = 0;
  Eigen::Matrix<double, 6, Eigen::Dynamic> M_;
  Eigen::VectorXi faults_;     // the fault set of the last solve (FaultKind as int)
  Eigen::VectorXi extra_off_;  // set_extra_failures
  bool dumping_ = false;
  Vector6 w_last_ = Vector6::Zero();
  VarMatrix H_, H_dump_, Hf_;
  VarVector wx2_, wx2_dump_, lo_, hi_, pref_, g_, x_, x_cone_, grad_, xf_, step_;
  Eigen::Matrix<int, Eigen::Dynamic, 1, 0, kMaxVariables, 1> state_, free_;
  Eigen::LLT<VarMatrix> llt_;
  Eigen::VectorXd wheel_lo_, wheel_hi_, wheel_pref_;
  AllocationResult result_;
};

}  // namespace tubempc::actuators

namespace tubempc::actuators {

// The table of AllocationSettings::for_each_field.
template <typename V>
void AllocationSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = AllocationSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, six = Dim::Six;
  visit(FieldInfo{"period", "s", req, finite, one, one,
                  "control period (s), > 0, for the wheels' momentum limits"},
        &S::period);
  visit(FieldInfo{"residual_weight", "1/N, 1/(N m)", req, finite, six, one,
                  "W_r: 3 force rows (1/N), 3 torque rows (1/(N m)), > 0"},
        &S::residual_weight);
  visit(FieldInfo{"thrust_weight", "1/N", req, finite, one, one, "W_x on thrusts (1/N), > 0"},
        &S::thrust_weight);
  visit(FieldInfo{"wheel_weight", "1/(N m)", req, finite, one, one, "W_x on wheel torques (1/(N m)), > 0"},
        &S::wheel_weight);
  visit(FieldInfo{"dump_weight", "1/(N m)", req, finite, one, one,
                  "W_x on wheel torques while dumping (1/(N m)), > 0"},
        &S::dump_weight);
  visit(FieldInfo{"max_iterations", "", req, finite, one, one, "active-set iteration cap, >= 1"},
        &S::max_iterations);
  visit(FieldInfo{"optimality_tolerance", "", req, finite, one, one,
                  "multiplier sign tolerance, relative to the gradient's scale"},
        &S::optimality_tolerance);
  visit(FieldInfo{"remainder_tolerance", "", req, finite, one, one,
                  "delivered if ||W_r r||_inf <= this (||W_r w||_inf + 1), > 0"},
        &S::remainder_tolerance);
  visit(FieldInfo{"cone_test_scale", "", req, finite, one, one,
                  "scale of the command in the Saturated/Infeasible test, in (0, 1]"},
        &S::cone_test_scale);
}

}  // namespace tubempc::actuators

namespace tubempc::core {

/// Names of actuators::AllocationStatus.
template <>
struct EnumNames<actuators::AllocationStatus> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<actuators::AllocationStatus>, 6> values{
      {{actuators::AllocationStatus::Ok, "Ok", "ok"},
       {actuators::AllocationStatus::ThrusterFailed, "ThrusterFailed", "thruster_failed"},
       {actuators::AllocationStatus::Saturated, "Saturated", "saturated"},
       {actuators::AllocationStatus::Infeasible, "Infeasible", "infeasible"},
       {actuators::AllocationStatus::MaxIterations, "MaxIterations", "max_iterations"},
       {actuators::AllocationStatus::InvalidCommand, "InvalidCommand", "invalid_command"}}};
};

}  // namespace tubempc::core
