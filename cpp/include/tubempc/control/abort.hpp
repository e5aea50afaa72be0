/// @file abort.hpp
/// The certified safe abort (docs/model.md M52, "Safe abort"; issue #43): a back-away from the descent to a
/// hover above the landing site along its local normal, flown by a second controller that is set up once,
/// before the mission, with the abort's hover reference and its own certified tube designs.
///
/// Set-up (Python: tubempc.scenario.abort) plans the hover reference, designs and certifies its tubes and flies
/// the nominal abort from entries spread over the descent (the abort library): each entry's plan must stay
/// outside the body, inside the approach cone and within the input bounds (the actuators' one-failure box), and
/// end in the hover. The last step with a certified entry is AbortSettings::commit_step: past it the descent is
/// committed to landing, as a touch-and-go's waive-off is only possible down to a set altitude.
///
/// Every control period the caller hands `monitor(k, triggers)` the step's detections (the navigation's fault
/// status, the descent tube's certification, the state handed to the step in the descent's last tube, the
/// identified disturbance set against the prior, the measured inputs' innovation over a window, the allocation's
/// outcome, a command). `monitor` is called once per step. The decision is latched: the
/// first enabled trigger at a step k <= commit_step enters the abort (AbortMode::Aborting) with its cause and
/// step, and from then on `step(k, x_k)` flies the abort controller; a trigger past the commit step is recorded
/// as refused and the descent goes on. `monitor` and `step` do not allocate heap memory after `setup`.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <memory>

#include "tubempc/control/controller.hpp"
#include "tubempc/core/fields.hpp"

namespace tubempc::control {

/// Where the abort supervision stands.
enum class AbortMode {
  Armed,      ///< descending; an abort is certified from this step (k <= commit_step)
  Committed,  ///< descending past the commit step: no certified abort, a trigger is refused
  Aborting,   ///< flying the abort (latched)
};
/// @param m a mode.
/// @return "armed", "committed" or "aborting".
const char* to_string(AbortMode m);

/// What entered (or would have entered) the abort, in the order of precedence when several act at one step.
enum class AbortCause {
  None,                 ///< nothing
  Command,              ///< commanded (ground or operator)
  NavigationFault,      ///< the navigation step detected a fault (nav::NavFault)
  TubeUncertified,      ///< the descent's tube could not be certified for the step (TubeStatus::Uncertified)
  EstimateOutsideTube,  ///< the state handed to the descent left the tube its last step certified
  InputNis,  ///< the measured inputs' windowed normalised innovation beyond AbortSettings::input_nis_limit (a burst)
  DisturbanceBeyondLimit,  ///< the identified disturbance set beyond AbortSettings::disturbance_limit x the prior
  AllocationInfeasible,  ///< the actuators cannot deliver the command's direction (AllocationStatus::Infeasible)
};
/// @param c a cause.
/// @return "none", "command", "navigation_fault", "tube_uncertified", "estimate_outside_tube", "input_nis",
///         "disturbance_beyond_limit" or "allocation_infeasible".
const char* to_string(AbortCause c);

/// A step's detections, handed to SafeAbort::monitor. A non-finite excursion or ratio counts as beyond its limit; a
/// non-finite innovation counts as 0 in the window (the controller reports 0 for an input it did not fold in).
struct AbortTriggers {
  bool command = false;           ///< an abort is commanded at this step
  bool navigation_fault = false;  ///< the navigation's latched fault status (NavigationStep::fault_detected)
  bool tube_uncertified = false;  ///< the last descent step's tube was not certified (either subsystem)
  bool allocation_infeasible = false;  ///< the last allocation could not deliver the command's direction
  /// The state the step is handed (the estimate with navigation) in the descent's last tube, per subsystem
  /// (Controller::excursion: squared gauge, > 1 + kExcursionTolerance outside; 0: no step yet).
  std::array<double, 2> excursion{};
  /// The descent's identified disturbance set relative to its prior, per subsystem (ControlStep::disturbance_ratio
  /// of the last descent step; 0: no step yet).
  std::array<double, 2> disturbance_ratio{};
  /// The descent's last measured input's normalised innovation, per subsystem (ControlStep::input_nis; 0: none).
  std::array<double, 2> input_nis{};
};

/// The longest window of AbortSettings::input_nis_window (steps; the supervision's ring buffer is this long).
inline constexpr int kMaxInputNisWindow = 32;

/// Settings of the abort supervision (the scenario file's `abort.` records; TOML `[abort]`).
struct AbortSettings {
  /// The last step an abort may be entered at (the abort library's last certified entry, >= -1; -1: never).
  int commit_step = -1;
  bool on_navigation_fault = true;       ///< a navigation fault enters the abort
  bool on_tube_uncertified = true;       ///< an uncertified descent tube enters the abort
  bool on_allocation_infeasible = true;  ///< an allocation that cannot deliver enters the abort
  bool on_estimate_outside_tube =
      true;  ///< the state handed to the descent outside its last tube enters the abort
  bool on_disturbance_beyond_limit = true;  ///< an identified set beyond disturbance_limit enters the abort
  /// The identified disturbance set the descent is qualified to land under, as a ratio to the identifier's prior
  /// set (ControlStep::disturbance_ratio; > 0, +inf: no limit): beyond it the descent cannot keep its touchdown
  /// accuracy (for a ratio c the disturbance's support grows by sqrt(c)) and backs away.
  double disturbance_limit = 4.0;
  bool on_input_nis = true;  ///< a windowed input innovation beyond input_nis_limit enters the abort
  /// Steps of the input innovation's window (1 to kMaxInputNisWindow): the test is the mean of the last window
  /// values of AbortTriggers::input_nis (per subsystem; the steps before the first count as 0).
  int input_nis_window = 5;
  /// The window's mean beyond which the inputs are not drawn from the identified distribution (> 0; about 1 for
  /// inputs that are: chi-square with 6 window degrees of freedom over 6 window).
  double input_nis_limit = 3.0;
  /// @throws std::invalid_argument naming the field ("abort.<field>").
  void validate() const;

  /// Calls visit(core::FieldInfo, member pointer) once per field (scenario files, Python attributes).
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// The supervision's decision, latched over a mission.
struct AbortDecision {
  AbortMode mode = AbortMode::Armed;            ///< after the last monitor call
  AbortCause cause = AbortCause::None;          ///< what entered the abort (None: not entered)
  int entered_at = -1;                          ///< the step the abort was entered at (-1: not entered)
  AbortCause refused_cause = AbortCause::None;  ///< the first trigger seen while committed (None: none)
  int refused_at = -1;                          ///< its step (-1: none)
};

/// The safe abort: supervision and the abort's controller (see the file comment).
class SafeAbort {
 public:
  /// @param model               the controller's plant (12 states, 6 inputs), non-null.
  /// @param mpc_settings        the abort MPC's settings (validated).
  /// @param controller_settings the abort controller's settings (validated); its tube is updated and certified
  ///                            at every step (Method::Ffa is enforced: the abort's guarantee is per step).
  /// @param settings            the supervision's settings (validated).
  /// @throws std::invalid_argument naming a bad field.
  SafeAbort(std::shared_ptr<const math::LinearizedModel> model, mpc::Settings mpc_settings,
            ControllerSettings controller_settings, const AbortSettings& settings);

  /// Sets the abort controller up with the hover reference and its designs (Controller::setup) and arms.
  /// @param hover   the abort's reference over the whole mission (12 x (T + 1), 6 x T), the descent's time base.
  /// @param designs its certified designs.
  /// @throws std::invalid_argument for inconsistent data.
  void setup(const mpc::Reference& hover, const ControllerDesigns& designs);
  /// Re-arms for a new mission (the decision cleared, the abort controller at k = 0).
  void reset();

  /// The decision for step k from the step's detections (latched; see the file comment). On entering, the abort
  /// controller takes over the descent's identified disturbance (Controller::inherit_identification), so that its
  /// first tube is certified for what the descent identified, not for the prior. Allocation-free.
  /// @param k        the step, 0 <= k.
  /// @param triggers the step's detections.
  /// @param descent  the descent's controller (nullptr: the abort starts from its prior).
  /// @return the decision after this step.
  /// @throws std::invalid_argument for k < 0 (no decision taken).
  const AbortDecision& monitor(int k, const AbortTriggers& triggers, const Controller* descent = nullptr);
  /// @return whether the abort is being flown.
  bool aborting() const { return decision_.mode == AbortMode::Aborting; }
  /// @return the decision so far.
  const AbortDecision& decision() const { return decision_; }
  /// @return the input innovation's window mean per subsystem after the last monitor call.
  std::array<double, 2> input_nis_mean() const;

  /// One step of the abort controller from the measured state (Controller::step; also flown by the set-up's
  /// certification of the library, without a decision). Allocation-free.
  /// @param k   step index on the mission's time base, 0 <= k < T.
  /// @param x_k the measured state (12).
  /// @return the controller's storage, valid until its next call.
  const ControlStep& step(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k);
  /// Output feedback for the abort controller (Controller::set_estimation_error).
  /// @param P_est 12 x 12 estimation-error set, or empty.
  void set_estimation_error(const Eigen::Ref<const Eigen::MatrixXd>& P_est);

  /// @return the abort controller.
  const Controller& controller() const { return controller_; }
  /// @return the supervision's settings.
  const AbortSettings& settings() const { return settings_; }

 private:
  AbortSettings settings_;
  Controller controller_;
  AbortDecision decision_;
  // the last input_nis_window values of AbortTriggers::input_nis (a ring; nis_next_ the slot of the next)
  std::array<std::array<double, 2>, kMaxInputNisWindow> nis_ring_{};
  int nis_next_ = 0;
};

template <typename V>
void AbortSettings::for_each_field(V&& visit) {
  using core::FieldInfo;
  using S = AbortSettings;
  constexpr bool required = false, finite = false, infinite_ok = true;
  visit(FieldInfo{"commit_step", "", required, finite}, &S::commit_step);
  visit(FieldInfo{"on_navigation_fault", "", required, finite}, &S::on_navigation_fault);
  visit(FieldInfo{"on_tube_uncertified", "", required, finite}, &S::on_tube_uncertified);
  visit(FieldInfo{"on_allocation_infeasible", "", required, finite}, &S::on_allocation_infeasible);
  visit(FieldInfo{"on_estimate_outside_tube", "", required, finite}, &S::on_estimate_outside_tube);
  visit(FieldInfo{"on_disturbance_beyond_limit", "", required, finite}, &S::on_disturbance_beyond_limit);
  visit(FieldInfo{"disturbance_limit", "", required, infinite_ok}, &S::disturbance_limit);
  visit(FieldInfo{"on_input_nis", "", required, finite}, &S::on_input_nis);
  visit(FieldInfo{"input_nis_window", "", required, finite}, &S::input_nis_window);
  visit(FieldInfo{"input_nis_limit", "", required, finite}, &S::input_nis_limit);
}

}  // namespace tubempc::control

namespace tubempc::core {

/// Names of control::AbortMode.
template <>
struct EnumNames<control::AbortMode> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<control::AbortMode>, 3> values{
      {{control::AbortMode::Armed, "Armed", "armed"},
       {control::AbortMode::Committed, "Committed", "committed"},
       {control::AbortMode::Aborting, "Aborting", "aborting"}}};
};

/// Names of control::AbortCause.
template <>
struct EnumNames<control::AbortCause> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<control::AbortCause>, 8> values{
      {{control::AbortCause::None, "None", "none"},
       {control::AbortCause::Command, "Command", "command"},
       {control::AbortCause::NavigationFault, "NavigationFault", "navigation_fault"},
       {control::AbortCause::TubeUncertified, "TubeUncertified", "tube_uncertified"},
       {control::AbortCause::EstimateOutsideTube, "EstimateOutsideTube", "estimate_outside_tube"},
       {control::AbortCause::InputNis, "InputNis", "input_nis"},
       {control::AbortCause::DisturbanceBeyondLimit, "DisturbanceBeyondLimit", "disturbance_beyond_limit"},
       {control::AbortCause::AllocationInfeasible, "AllocationInfeasible", "allocation_infeasible"}}};
};

}  // namespace tubempc::core
