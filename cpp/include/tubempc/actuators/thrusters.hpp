/// @file thrusters.hpp
/// A cluster of on/off thrusters fixed to the spacecraft body B (docs/model.md "Actuators"): geometry, the
/// force/torque mapping, per-thruster scale and misalignment errors of the truth, faults (failed off or
/// stuck on from a time), and pulse modulation of commanded thrusts within a control period by
/// remainder carry-over (docs/decisions.md "Thruster pulse modulation").
///
/// Wrenches are w_B = [F_B (N); T_B (N m)] about the spacecraft's centre of mass, in B. A thrust f_j (N)
/// of thruster j produces F_B = f_j d_j and T_B = f_j (p_j x d_j), d_j its unit direction (the direction
/// of the force on the spacecraft, opposite to the exhaust) and p_j its position relative to the centre
/// of mass (m).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <string>
#include <vector>

#include "tubempc/core/fields.hpp"

namespace tubempc::actuators {

/// A wrench [F_B (N); T_B (N m)] in B, about the centre of mass.
using Vector6 = Eigen::Matrix<double, 6, 1>;
/// A matrix with one wrench per column (6 x n).
using Matrix6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// Largest number of thrusters of a cluster (the allocation's workspace is fixed-size).
inline constexpr int kMaxThrusters = 32;
/// Standard gravity g0 (m/s^2), for the propellant mass m = I / (Isp g0).
inline constexpr double kStandardGravity = 9.80665;

/// A thruster's fault.
enum class FaultKind {
  None,       ///< Healthy.
  FailedOff,  ///< Produces no thrust from the fault time on, whatever is commanded.
  StuckOn,    ///< Fires at full thrust for the whole period from the fault time on.
};

/// Name of a fault kind ("none", "failed_off", "stuck_on"; core::EnumNames<FaultKind>).
std::string to_string(FaultKind kind);
/// The fault kind of a name (as to_string); throws std::invalid_argument naming the text otherwise.
/// @param name "none", "failed_off" or "stuck_on".
FaultKind fault_kind_from_string(const std::string& name);

/// One thruster. The nominal fields (position, direction, thrust) are what the allocation knows; the
/// truth delivers (1 + scale_error) max_thrust along direction_B turned by the rotation vector
/// misalignment_B. The certified error bounds hold for every truth error within scale_error_bound and
/// misalignment_bound.
struct ThrusterSpec {
  /// Position relative to the centre of mass, in B (m).
  Eigen::Vector3d position_B = Eigen::Vector3d::Zero();
  /// Unit direction of the force on the spacecraft (opposite to the exhaust), in B.
  Eigen::Vector3d direction_B = Eigen::Vector3d::UnitZ();
  /// Thrust when on (N, > 0).
  double max_thrust = 1.0;
  /// Shortest firing (s, >= 0): the minimum impulse bit is max_thrust min_on_time.
  double min_on_time = 0.02;
  /// Specific impulse (s, > 0).
  double isp = 220.0;
  /// Truth's relative thrust error: it delivers (1 + scale_error) max_thrust.
  double scale_error = 0.0;
  /// Truth's direction error, a rotation vector (rad).
  Eigen::Vector3d misalignment_B = Eigen::Vector3d::Zero();
  /// Certified bound on |scale_error| (>= |scale_error|, < 1).
  double scale_error_bound = 0.0;
  /// Certified bound on |misalignment_B| (rad, >= |misalignment_B|, < pi).
  double misalignment_bound = 0.0;
  /// Configured fault (None: healthy).
  FaultKind fault = FaultKind::None;
  /// Time from which the fault acts (s).
  double fault_time = 0.0;  ///< Time from which the fault acts (s).

  /// Throws std::invalid_argument naming the field (`what` prefixes it, e.g. "thrusters[3]").
  /// @param what name of this thruster in the message.
  void validate(const std::string& what = "thruster") const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// The thrusters of a spacecraft: geometry, truth errors and faults. A value type; set-up errors throw
/// std::invalid_argument, the accessors do not allocate.
class ThrusterCluster {
 public:
  /// Validates every thruster (1 to kMaxThrusters of them).
  /// @param thrusters the thrusters, in the order of the allocation's variables.
  explicit ThrusterCluster(std::vector<ThrusterSpec> thrusters);

  /// @return the number of thrusters n.
  int size() const { return static_cast<int>(specs_.size()); }
  /// @return thruster i's specification (throws std::out_of_range for a bad index).
  /// @param i thruster index in [0, n).
  const ThrusterSpec& thruster(int i) const { return specs_.at(static_cast<std::size_t>(i)); }
  /// @return the nominal mapping D (6 x n): w_B = D f for thrusts f (N), column j = [d_j; p_j x d_j].
  const Matrix6X& mapping() const { return D_; }
  /// @return the truth's mapping (6 x n) per unit commanded thrust: column j = (1 + s_j) [R_j d_j; p_j x R_j d_j]
  /// with R_j = Exp(misalignment_j).
  const Matrix6X& true_mapping() const { return D_true_; }
  /// @return the thrusts when on, max_thrust_j (N, n).
  const Eigen::VectorXd& max_thrust() const { return f_max_; }

  /// Sets thruster i's fault from time t_start on (FaultKind::None clears it).
  /// @param i thruster index in [0, n) (std::invalid_argument otherwise).
  /// @param kind the fault.
  /// @param t_start time from which it acts (s, finite).
  void set_fault(int i, FaultKind kind, double t_start);
  /// @return thruster i's fault at time t (None before its fault time).
  /// @param i thruster index in [0, n).
  /// @param t time (s).
  FaultKind fault_at(int i, double t) const;
  /// @return the number of thrusters failed (off or stuck on) at time t.
  /// @param t time (s).
  int faults_at(double t) const;

 private:
  std::vector<ThrusterSpec> specs_;
  Matrix6X D_, D_true_;
  Eigen::VectorXd f_max_;
};

/// How the modulator turns a commanded on-time into one the valves fire (docs/decisions.md "Thruster pulse
/// modulation").
enum class PulseRounding {
  /// Down to the resolution, the rest carried to the next period (remainder carry-over; default): over any
  /// number of periods the delivered impulse follows the commanded one to within one remainder, and one
  /// period's on-time error is below r_max = max(tau_min, q).
  Carry,
  /// To the nearest level the valves can fire (0, the minimum on-time, or a multiple of the resolution above
  /// it), nothing carried: one period's on-time error is at most r_max / 2, half the carry-over's, but the
  /// errors of successive periods do not cancel (a command below tau_min / 2 is never delivered).
  Nearest,
};

/// Name of a pulse rounding ("carry", "nearest"; core::EnumNames<PulseRounding>).
std::string to_string(PulseRounding rounding);

/// Settings of the pulse modulation.
struct ModulationSettings {
  double period = 1.0;  ///< Control period dt over which a commanded thrust is averaged (s, > 0).
  double on_time_resolution = 1e-3;  ///< On-times are whole multiples of this (s, >= 0; 0: continuous).
  PulseRounding rounding = PulseRounding::Carry;  ///< Carry-over or nearest level.
  /// Fire a net on-time below the minimum on-time as the difference of two opposed thrusters (docs/model.md
  /// M34''): thrusters j and p with D_p = -D_j (one line of action, opposite directions) and the same thrust
  /// and minimum on-time are a pair; each period the pair's net commanded on-time d = |tau_c,j - tau_c,p| is
  /// fired by the thruster it points along for the nearest level of d when d >= tau_min, and as tau_min +
  /// q round(d / q) against tau_min on the other when 0 < d < tau_min. The pair's net on-time error is then
  /// at most q / 2 instead of tau_min / 2, for 2 F tau_min of extra impulse in such a period. Needs
  /// PulseRounding::Nearest, at least one pair and 2 tau_min <= period (rounded up to q).
  bool opposed_pairs = false;

  /// Throws std::invalid_argument naming the field.
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// One period's firing (buffers sized at construction, overwritten by every call).
struct Firing {
  Eigen::VectorXd on_time;  ///< On-time of each thruster, one pulse centred in the period (s, n).
  Eigen::VectorXd impulse;  ///< Impulse delivered by each thruster, truth (N s, n).
  /// D f_cmd: the wrench of the commanded thrusts (nominal, N and N m).
  Vector6 commanded_B = Vector6::Zero();
  /// Period-average wrench delivered by the truth (errors and faults, N and N m).
  Vector6 delivered_B = Vector6::Zero();
  double propellant = 0.0;  ///< Propellant spent in the period (kg).
  int pulses = 0;           ///< Thrusters fired in the period.
};

/// Pulse-width modulation, by default with remainder carry-over (PulseRounding::Carry): each period, thruster j is asked for the on-time
/// tau_c = f_j dt / F_j plus its carried remainder r_j; the sum is rounded down to the resolution q; it
/// fires if that reaches the minimum on-time (rounded up to q), at most for the whole period; what was not
/// fired is carried: r_j' = tau_c + r_j - tau_j. The remainder stays in [0, r_max_j), r_max_j =
/// max(tau_min_j, q) (tau_min rounded up to q), so over any number of periods the delivered nominal impulse
/// differs from the commanded one by less than F_j r_max_j, and in one period by less than that too.
/// With PulseRounding::Nearest the commanded on-time itself is rounded to the nearest level it can fire (0
/// below half the minimum on-time, the minimum on-time up to it, the nearest multiple of q above it, at most
/// the period) and nothing is carried (the remainders stay 0).
/// With ModulationSettings::opposed_pairs, the pairs whose two thrusters are both healthy at t are fired from
/// their net command (see there); the others as above.
/// A failed-off thruster fires 0, a stuck-on one the whole period (their remainders are cleared).
/// Allocation-free after construction.
class PulseModulator {
 public:
  /// Sizes the modulator for the cluster; every thruster's minimum on-time, rounded up to the resolution,
  /// must fit in the period (std::invalid_argument otherwise).
  /// @param cluster the thrusters.
  /// @param settings the modulation settings (validated).
  PulseModulator(const ThrusterCluster& cluster, const ModulationSettings& settings);

  /// Modulates one period's commanded thrusts. A non-finite command is taken as 0, the others are
  /// clamped into [0, max_thrust_j].
  /// @param cluster the thrusters (n must match: std::invalid_argument otherwise).
  /// @param t the period's start time (s; faults are evaluated at it).
  /// @param thrust_cmd period-average commanded thrust of each thruster (N, n).
  /// @return the firing (valid until the next call).
  const Firing& modulate(const ThrusterCluster& cluster, double t,
                         const Eigen::Ref<const Eigen::VectorXd>& thrust_cmd);

  /// Clears the remainders, the pulse counts and the propellant total.
  void reset();
  /// @return the carried on-time remainders r_j (s, n).
  const Eigen::VectorXd& remainder() const { return r_; }
  /// @return thruster j's remainder bound r_max_j = max(tau_min_j rounded up to q, q) (s).
  /// @param cluster the thrusters.
  /// @param j thruster index.
  double remainder_bound(const ThrusterCluster& cluster, int j) const;
  /// @return the bound on |tau_j - tau_c,j| in one period of a healthy thruster, tau_c,j = f_j dt / F_j the
  /// commanded on-time (s): r_max_j with PulseRounding::Carry (strict), r_max_j / 2 with Nearest.
  /// @param cluster the thrusters.
  /// @param j thruster index.
  double on_time_error_bound(const ThrusterCluster& cluster, int j) const;
  /// @return the bound on tau_j - tau_c,j, by how much thruster j's on-time can exceed its command in one
  /// period (s): on_time_error_bound, or tau_min,j + q / 2 for a thruster of an opposed pair (it fires tau_min
  /// against a partner's sub-minimum net command). It bounds the delivered thrusts for the misalignment part of
  /// the actuation error (M36).
  /// @param cluster the thrusters.
  /// @param j thruster index.
  double on_time_excess_bound(const ThrusterCluster& cluster, int j) const;
  /// @return thruster j's opposed partner (ModulationSettings::opposed_pairs), or -1.
  /// @param j thruster index in [0, n).
  int partner(int j) const { return partner_(j); }
  /// @return thruster j's minimum on-time rounded up to the resolution (s).
  /// @param cluster the thrusters.
  /// @param j thruster index.
  double effective_min_on_time(const ThrusterCluster& cluster, int j) const;
  /// @return the pulses fired by each thruster since the last reset (n).
  const Eigen::VectorXi& pulse_counts() const { return pulses_; }
  /// @return the propellant spent since the last reset (kg).
  double propellant() const { return propellant_; }
  /// @return the settings.
  const ModulationSettings& settings() const { return settings_; }

 private:
  double nearest_level(double tau_c, double t_min) const;

  ModulationSettings settings_;
  Eigen::VectorXd r_, f_cmd_;
  Eigen::VectorXi pulses_, partner_;
  double propellant_ = 0.0;
  Firing firing_;
};

}  // namespace tubempc::actuators

namespace tubempc::core {

/// Names of actuators::FaultKind.
template <>
struct EnumNames<actuators::FaultKind> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<actuators::FaultKind>, 3> values{
      {{actuators::FaultKind::None, "None", "none"},
       {actuators::FaultKind::FailedOff, "FailedOff", "failed_off"},
       {actuators::FaultKind::StuckOn, "StuckOn", "stuck_on"}}};
};
/// Names of actuators::PulseRounding.
template <>
struct EnumNames<actuators::PulseRounding> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<actuators::PulseRounding>, 2> values{
      {{actuators::PulseRounding::Carry, "Carry", "carry"},
       {actuators::PulseRounding::Nearest, "Nearest", "nearest"}}};
};

}  // namespace tubempc::core

namespace tubempc::actuators {

// The table of ThrusterSpec::for_each_field.
template <typename V>
void ThrusterSpec::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = ThrusterSpec;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, three = Dim::Three;
  visit(FieldInfo{"position_B", "m", req, finite, three, one,
                  "position relative to the centre of mass, in B (m)"},
        &S::position_B);
  visit(FieldInfo{"direction_B", "", req, finite, three, one,
                  "unit direction of the force on the spacecraft (opposite to the exhaust), in B"},
        &S::direction_B);
  visit(FieldInfo{"max_thrust", "N", req, finite, one, one, "thrust when on (N), > 0"}, &S::max_thrust);
  visit(FieldInfo{"min_on_time", "s", req, finite, one, one, "shortest firing (s), >= 0"}, &S::min_on_time);
  visit(FieldInfo{"isp", "s", req, finite, one, one, "specific impulse (s), > 0"}, &S::isp);
  visit(FieldInfo{"scale_error", "", req, finite, one, one,
                  "truth's relative thrust error: it delivers (1 + scale_error) max_thrust"},
        &S::scale_error);
  visit(FieldInfo{"misalignment_B", "rad", req, finite, three, one,
                  "truth's direction error, a rotation vector (rad)"},
        &S::misalignment_B);
  visit(FieldInfo{"scale_error_bound", "", req, finite, one, one,
                  "certified bound on |scale_error| (>= |scale_error|, < 1)"},
        &S::scale_error_bound);
  visit(FieldInfo{"misalignment_bound", "rad", req, finite, one, one,
                  "certified bound on |misalignment_B| (rad, >= |misalignment_B|, < pi)"},
        &S::misalignment_bound);
  visit(FieldInfo{"fault", "", req, finite, one, one, "configured fault (None: healthy)"}, &S::fault);
  visit(FieldInfo{"fault_time", "s", req, finite, one, one, "time from which the fault acts (s)"},
        &S::fault_time);
}

// The table of ModulationSettings::for_each_field.
template <typename V>
void ModulationSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = ModulationSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One;
  visit(FieldInfo{"period", "s", req, finite, one, one,
                  "control period over which a commanded thrust is averaged (s), > 0"},
        &S::period);
  visit(FieldInfo{"on_time_resolution", "s", req, finite, one, one,
                  "on-times are whole multiples of this (s), >= 0; 0: continuous"},
        &S::on_time_resolution);
  visit(FieldInfo{"rounding", "", req, finite, one, one, "carry-over or nearest level"}, &S::rounding);
  visit(FieldInfo{"opposed_pairs", "", req, finite, one, one,
                  "fire a net on-time below the minimum on-time as the difference of two opposed thrusters"},
        &S::opposed_pairs);
}

}  // namespace tubempc::actuators
