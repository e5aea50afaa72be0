/// @file reaction_wheels.hpp
/// Reaction wheels fixed in the body B (docs/model.md "Actuators"): spin axes, torque and momentum
/// limits, the wheels' momentum state and the momentum-dump policy.
///
/// Convention: u_j (N m) is the torque wheel j exerts on the spacecraft about its unit spin axis g_j;
/// the spacecraft receives T_B = G u (G = [g_1 ... g_m], 3 x m) and the wheel's momentum about g_j
/// changes by h_j' = -u_j. The gyroscopic coupling of the wheels' momentum with the body rate belongs
/// to the plant, not to this model.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "tubempc/core/fields.hpp"

namespace tubempc::actuators {

/// Largest number of reaction wheels (the allocation's workspace is fixed-size).
inline constexpr int kMaxWheels = 8;

/// One reaction wheel.
struct ReactionWheelSpec {
  Eigen::Vector3d axis_B = Eigen::Vector3d::UnitZ();  ///< Unit spin axis in B.
  double max_torque = 0.2;                            ///< |u_j| limit (N m, > 0).
  double max_momentum = 50.0;                         ///< |h_j| limit (N m s, > 0).

  /// Throws std::invalid_argument naming the field (`what` prefixes it, e.g. "wheels[1]").
  /// @param what name of this wheel in the message.
  void validate(const std::string& what = "wheel") const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// When and how fast the wheels are unloaded; the thrusters produce the external torque that holds the
/// attitude meanwhile (the allocation's preferred wheel torques become u_dump).
struct MomentumDumpSettings {
  bool enabled = true;          ///< Whether momentum is dumped at all.
  double start_fraction = 0.8;  ///< Dumping starts when some |h_j| > start_fraction h_max_j (in (0, 1]).
  double stop_fraction = 0.2;   ///< ... and stops when every |h_j| <= stop_fraction h_max_j (in [0, start)).
  /// While dumping, u_dump_j = h_j / time_constant, clamped to the torque limit (s, > 0).
  double time_constant = 600.0;

  /// Throws std::invalid_argument naming the field.
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// The wheels and their momentum. Allocation-free after construction.
class ReactionWheels {
 public:
  /// Validates every wheel (0 to kMaxWheels of them) and the dump settings; momentum starts at 0.
  /// @param wheels the wheels, in the order of the allocation's variables.
  /// @param dump the momentum-dump policy.
  explicit ReactionWheels(std::vector<ReactionWheelSpec> wheels, const MomentumDumpSettings& dump = {});

  /// @return the number of wheels m.
  int size() const { return static_cast<int>(specs_.size()); }
  /// @return wheel j's specification (std::out_of_range for a bad index).
  /// @param j wheel index in [0, m).
  const ReactionWheelSpec& wheel(int j) const { return specs_.at(static_cast<std::size_t>(j)); }
  /// @return the spin axes G (3 x m), in B.
  const Eigen::Matrix<double, 3, Eigen::Dynamic>& axes_B() const { return G_; }
  /// @return the torque limits (N m, m).
  const Eigen::VectorXd& max_torque() const { return u_max_; }
  /// @return the momentum limits (N m s, m).
  const Eigen::VectorXd& max_momentum() const { return h_max_; }
  /// @return the dump settings.
  const MomentumDumpSettings& dump_settings() const { return dump_; }

  /// @return the wheels' momenta h_j about their axes (N m s, m).
  const Eigen::VectorXd& momentum() const { return h_; }
  /// @return the wheels' total momentum in B, G h (N m s).
  Eigen::Vector3d momentum_B() const { return G_ * h_; }
  /// Sets the momenta (|h_j| <= h_max_j, finite: std::invalid_argument otherwise) and re-evaluates dumping.
  /// @param h the momenta (N m s, m).
  void set_momentum(const Eigen::Ref<const Eigen::VectorXd>& h);

  /// The torque box that respects both limits over a period: |u_j| <= u_max_j and |h_j - u_j dt| <= h_max_j.
  /// @param dt the period (s, > 0).
  /// @param lower lower bounds (N m, m; resized only if its size differs).
  /// @param upper upper bounds (N m, m).
  void torque_bounds(double dt, Eigen::VectorXd& lower, Eigen::VectorXd& upper) const;
  /// Fails wheel j from time t_start on: from then it gives no torque and keeps its momentum (a failed wheel's
  /// spin is left to itself; its friction is not modelled) and no longer counts in the momentum dump.
  /// @param j       wheel index in [0, m) (std::out_of_range otherwise).
  /// @param t_start the failure's time (s; +inf: healthy; NaN: std::invalid_argument).
  void set_failure(int j, double t_start);
  /// @param j wheel index in [0, m).
  /// @return wheel j's failure time (s; +inf: healthy).
  double failure_time(int j) const { return fail_time_(j); }
  /// Marks the wheels failed at time t (their torque bounds are 0 from then; ActuationSystem::step calls it at
  /// each period's start). Allocation-free.
  /// @param t time (s).
  void update_failures(double t) noexcept;
  /// @return the wheels failed at the last update_failures.
  int failed() const { return static_cast<int>(failed_.count()); }

  /// @return whether a momentum dump is in progress.
  bool dumping() const { return dumping_; }
  /// The preferred wheel torques: u_dump while dumping, 0 otherwise.
  /// @param u_pref the preferred torques (N m, m; resized only if its size differs).
  void preferred_torque(Eigen::VectorXd& u_pref) const;

  /// Applies wheel torques over a period: each is clamped into torque_bounds(dt) (a non-finite one is 0),
  /// the momenta are updated (h -= u dt) and dumping is re-evaluated.
  /// @param u the commanded wheel torques (N m, m).
  /// @param dt the period (s, > 0).
  /// @return the torque on the spacecraft, G u_applied (N m, in B).
  Eigen::Vector3d apply(const Eigen::Ref<const Eigen::VectorXd>& u, double dt);
  /// @return the torques applied by the last apply() (N m, m).
  const Eigen::VectorXd& applied_torque() const { return u_applied_; }

 private:
  void update_dumping();
  std::vector<ReactionWheelSpec> specs_;
  MomentumDumpSettings dump_;
  Eigen::Matrix<double, 3, Eigen::Dynamic> G_;
  Eigen::VectorXd u_max_, h_max_, h_, u_applied_;
  Eigen::VectorXd fail_time_;                     // failure times (s; +inf: healthy)
  Eigen::Array<bool, Eigen::Dynamic, 1> failed_;  // failed at the last update_failures
  bool dumping_ = false;
};

}  // namespace tubempc::actuators

namespace tubempc::actuators {

// The table of ReactionWheelSpec::for_each_field.
template <typename V>
void ReactionWheelSpec::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = ReactionWheelSpec;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, three = Dim::Three;
  visit(FieldInfo{"axis_B", "", req, finite, three, one, "unit spin axis in B"}, &S::axis_B);
  visit(FieldInfo{"max_torque", "N m", req, finite, one, one, "|u_j| limit (N m), > 0"}, &S::max_torque);
  visit(FieldInfo{"max_momentum", "N m s", req, finite, one, one, "|h_j| limit (N m s), > 0"},
        &S::max_momentum);
}

// The table of MomentumDumpSettings::for_each_field.
template <typename V>
void MomentumDumpSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = MomentumDumpSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One;
  visit(FieldInfo{"enabled", "", req, finite, one, one, "whether momentum is dumped at all"}, &S::enabled);
  visit(FieldInfo{"start_fraction", "", req, finite, one, one,
                  "dumping starts when some |h_j| > start_fraction h_max_j, in (0, 1]"},
        &S::start_fraction);
  visit(FieldInfo{"stop_fraction", "", req, finite, one, one,
                  "dumping stops when every |h_j| <= stop_fraction h_max_j, in [0, start_fraction)"},
        &S::stop_fraction);
  visit(FieldInfo{"time_constant", "s", req, finite, one, one,
                  "while dumping, u_dump_j = h_j / time_constant, clamped to the torque limit (s), > 0"},
        &S::time_constant);
}

}  // namespace tubempc::actuators
