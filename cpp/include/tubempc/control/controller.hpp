/// @file controller.hpp
/// The whole control step of TBMPC and TBMPC-FFA in one call (docs/model.md "Closed loop"; the paper's
/// Algorithm 1): the measured exogenous input of the last period and its forgetting-factor
/// identification per subsystem (identification.hpp), the tube update (tube_update.hpp) and the tube
/// MPC step (mpc::TubeMPC). No heap allocation and no semidefinite program inside a step; every loop
/// in it has a bound fixed at set-up.
///
/// Lifecycle: construct with the controller's model and settings; `setup(reference, designs)` once per
/// mission (allocates, discretises the reference for the tube update); then `step(k, x_k)` every control
/// period with the measured state. After the command, the step predicts x_{k+1} from (x_k, u_k) (the
/// residual input: one discretisation of the model at the measured state), so that the next step's
/// identification is a subtraction. A caller that runs background LMI designs (Python) reads
/// `ControlStep::design_due` and offers finished designs through `adopt`.
///
/// Subsystems: translation (p: states 0-5 [r_L (m), v_L (m/s)], inputs 0-2 (m/s^2)) and rotation
/// (r: states 6-11 [phi (rad), omega_BL_B (rad/s)], inputs 3-5 (N m)); the tube is block diagonal.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <memory>
#include <vector>

#include "tubempc/control/identification.hpp"
#include "tubempc/control/tube_update.hpp"
#include "tubempc/math/linearized_model.hpp"
#include "tubempc/mpc/tube_mpc.hpp"

namespace tubempc::control {

/// The method flown.
enum class Method {
  Tbmpc,  ///< the tube designed at set-up from the prior, kept (the paper's TBMPC)
  Ffa,    ///< the tube updated from the identified disturbance set (the paper's TBMPC-FFA)
};
/// @param m a method.
/// @return "tbmpc" or "ffa".
const char* to_string(Method m);

/// What the identification takes as the measured exogenous input w_k.
enum class MeasuredInput {
  Residual,  ///< w_k = x_{k+1} - (A_k x_k + B_k u_k + c_k), the model's one-step prediction error (default)
  ReferenceDeviation,  ///< w_k = x_{k+1} - zbar_{k+1}, the paper's literal Eq. (26)
};
/// @param m a measured-input kind.
/// @return "residual" or "reference_deviation".
const char* to_string(MeasuredInput m);

/// Settings of the controller (the MPC's own are mpc::Settings).
struct ControllerSettings {
  Method method = Method::Ffa;                             ///< TBMPC or TBMPC-FFA
  MeasuredInput measured_input = MeasuredInput::Residual;  ///< the identification's input
  IdentifierSettings identification_p;                     ///< translational identifier
  IdentifierSettings identification_r;                     ///< rotational identifier
  /// The tube update; `adaptive` is set from `method` by the controller.
  TubePolicySettings tube;
  /// Certified actuation-error sets of the inputs {e : e^T E^-1 e <= 1} (p: (m/s^2)^2, r: (N m)^2; symmetric
  /// positive semidefinite): each step's tube is certified for the identified P_W plus B_k E
  /// (actuators::disturbance_with_actuation_error; docs/model.md M38). Zero (the default): ideal actuators.
  std::array<Eigen::Matrix3d, 2> actuation_error{Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()};
  /// TBMPC-FFA only (docs/model.md M43): cancel the identified mean input w^_s through the input, u_ff,s =
  /// -(B_s^T B_s)^-1 B_s^T w^_s (B_s about the reference's node k), each component within feedforward_limit
  /// of the MPC's input bound, added to the MPC's command and the sum clipped into the input bounds. The tube
  /// then faces the spread of the input about its mean, the set the identification measures, and the
  /// controller carries the feed-forward's box in its input-error sets (input_error_with_feedforward), so that
  /// the certified part of the guarantee (actuation_error) still holds. Off (the paper's method): the mean is
  /// not used.
  bool feedforward = false;
  /// Largest feed-forward per input component, as a fraction of the MPC's bound u_max_i (in (0, 1)).
  double feedforward_limit = 0.002;
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// The input-error set a TBMPC-FFA tube carries with the feed-forward (M43): an ellipsoid containing E (+) the
/// box |u_ff,i| <= rho_i, the trace-minimal one of the outer family (1 + 1/beta) E + (1 + beta) 3 diag(rho)^2
/// (3 diag(rho)^2: the smallest ellipsoid around the box). For a ball E = r^2 I and rho = p (1, 1, 1) it is the
/// ball of radius r + sqrt(3) p. Controller applies it to ControllerSettings::actuation_error when the
/// feed-forward is on; the set-up designs (Python: tubempc.design.library) use the same call.
/// @param E the input-error set's shape (3 x 3, symmetric positive semidefinite; input units squared).
/// @param rho the feed-forward's bound per component (>= 0; input units).
/// @return the shape (input units squared).
Eigen::Matrix3d input_error_with_feedforward(const Eigen::Matrix3d& E, const Eigen::Vector3d& rho);

/// A state lies outside a tube when its squared gauge exceeds 1 + kExcursionTolerance (Controller::excursion;
/// rounding of a state on the tube's boundary is not an exit). Python: tubempc.analysis.metrics reads it.
inline constexpr double kExcursionTolerance = 1e-9;

/// The LMI designs a controller flies with (computed at set-up; Python: tubempc.design.library).
struct ControllerDesigns {
  SubsystemDesign initial_p;               ///< translational design of k = 0 (TBMPC: for the whole mission)
  SubsystemDesign initial_r;               ///< rotational design of k = 0
  std::vector<SubsystemDesign> library_p;  ///< translational library (TBMPC-FFA)
  std::vector<SubsystemDesign> library_r;  ///< rotational library (TBMPC-FFA)
};

/// Wall-clock split of one control step (s). The command is ready after identify + tube + mpc; the
/// prediction follows it (a flight loop runs it while it waits for the next measurement).
struct ControlTimings {
  double identify = 0.0;  ///< the last period's measured input and the identifiers' update
  double tube = 0.0;      ///< tube update of both subsystems
  double mpc = 0.0;       ///< tube MPC step
  double predict =
      0.0;             ///< the one-step prediction from (x_k, u_k) that the next identification compares with
  double total = 0.0;  ///< the whole call
};

/// Result of one control step; storage allocated at set-up and overwritten by every step.
struct ControlStep {
  Eigen::VectorXd u;  ///< the command (6: m/s^2, N m), always finite
  /// The part of u from ControllerSettings::feedforward after the clipping (6: m/s^2, N m; 0 when off).
  Eigen::Matrix<double, 6, 1> u_feedforward = Eigen::Matrix<double, 6, 1>::Zero();
  mpc::Tube tube;                           ///< the tube flown: K (6 x 12), Pe (12 x 12), block diagonal
  std::array<TubeStatus, 2> tube_status{};  ///< per subsystem (p, r)
  std::array<double, 2> alpha{};            ///< per subsystem
  std::array<double, 2> residual{};  ///< each tube's lmi_residual for this step (SubsystemTube::residual)
  /// Whether a new LMI design is due at this step (a search step, or the margin was lost at the last
  /// step): a caller with background designs starts one from A, B and (1 + margin) P_W of this step.
  bool design_due = false;
  std::array<SubMatrix, 2> A;       ///< subsystem A about the reference's node k
  std::array<SubInputMatrix, 2> B;  ///< subsystem B about the reference's node k
  std::array<SubMatrix, 2> P_W;     ///< identified disturbance sets used by this step
  /// The identified disturbance set relative to the identifier's prior, per subsystem: cover_ratio of
  /// pw_scale S^_k and pw_scale S^_0 (the largest generalised eigenvalue; 1: the prior's own set, > 1: beyond it
  /// along some direction; the actuation error excluded). The safe abort's disturbance trigger (abort.hpp).
  std::array<double, 2> disturbance_ratio{};
  bool identified = false;  ///< whether the last period's input was folded in
  /// That input: x_k minus its prediction from step k - 1 (MeasuredInput).
  Eigen::Matrix<double, 12, 1> w_measured = Eigen::Matrix<double, 12, 1>::Zero();
  /// That input's normalised innovation per subsystem, before it was folded in: (w - w^)^T S^-1 (w - w^) / 6 with the
  /// identified mean w^ and covariance S^ of the step before (chi-square with 6 degrees of freedom over 6 for an input
  /// drawn from the identified distribution: about 1; 0 when nothing was folded in). A disturbance beyond the
  /// identified set raises it at once, before the identification absorbs it: the safe abort's windowed test
  /// (abort.hpp).
  std::array<double, 2> input_nis{};
  const mpc::StepResult* mpc = nullptr;  ///< the MPC step's result (plan, statuses, timings)
  ControlTimings timings;                ///< wall-clock split
};

/// TBMPC / TBMPC-FFA (see the file comment).
class Controller {
 public:
  /// @param model        the controller's plant (12 states, 6 inputs), non-null.
  /// @param mpc_settings the tube MPC's settings (validated).
  /// @param settings     the controller's settings (validated).
  Controller(std::shared_ptr<const math::LinearizedModel> model, mpc::Settings mpc_settings,
             ControllerSettings settings);
  ~Controller();
  Controller(const Controller&) = delete;
  Controller& operator=(const Controller&) = delete;
  Controller(Controller&&) = delete;             ///< holds its MPC and set-up storage in place
  Controller& operator=(Controller&&) = delete;  ///< likewise

  /// Prepares a mission: the MPC's setup, the reference discretised at every node for the tube update,
  /// the identifiers at their prior and the tube policies with their designs.
  /// @param reference the mission's reference (12 x (T + 1), 6 x T).
  /// @param designs   the initial designs and libraries (validated).
  /// @throws std::invalid_argument for inconsistent data; std::domain_error if the reference cannot be
  ///         discretised.
  void setup(const mpc::Reference& reference, const ControllerDesigns& designs);
  /// Back to k = 0 (identifiers at their prior, initial designs, MPC without a previous plan).
  void reset();

  /// One control step from the measured state x_k (12). Identifies the last period's input when
  /// step(k - 1) was the previous call, updates the tube, runs the MPC. Numerical outcomes are statuses
  /// (in ControlStep and its mpc result); the command is always finite.
  /// @param k   step index, 0 <= k < T.
  /// @param x_k the measured state [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)].
  /// @return internal storage, valid until the next call.
  /// @throws std::invalid_argument for a wrong size or k out of range.
  const ControlStep& step(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k);

  /// Folds in the measured exogenous input of the period from step k - 1 to k, given x_k, when
  /// step(k - 1) was the last step and this period was not folded in yet (`step(k, x_k)` does this
  /// itself; call it alone after the last step). The attitude part of the input is taken with x_k's
  /// rotation vector as math::nearest_representative of the prediction's, so that a state whose chart
  /// switched across |phi| = pi is the same attitude, not one 2 pi away. Allocation-free.
  /// @param k   the step reached, 1 <= k <= T.
  /// @param x_k the measured state at k (12).
  /// @return whether an input was folded in (false: nothing to identify, or a non-finite input).
  bool identify(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k);
  /// The squared gauge of a state in the tube of the last step k, per subsystem: e^T Pe_k^-1 e with
  /// e = x - z*_1|k, the plan's next nominal state (docs/model.md "Tube MPC"; > 1 + kExcursionTolerance: outside
  /// the tube the step certified). Given the estimate x^_k+1, it says whether the state the next step is handed
  /// left its own tube (the safe abort's trigger, abort.hpp). x's rotation vector is taken as
  /// math::nearest_representative of z*_1|k's, as in `identify`. Allocation-free.
  /// @param x the state at k + 1 (12; the measured or estimated state).
  /// @return (p, r); zeros before the first step, +inf for a non-finite state or a tube that is not positive
  ///         definite.
  /// @throws std::invalid_argument for a wrong size.
  std::array<double, 2> excursion(const Eigen::Ref<const Eigen::VectorXd>& x) const;
  /// @return the last measured input folded in (12: the p then r subsystem's state units).
  const Eigen::Matrix<double, 12, 1>& last_measured_input() const { return out_.w_measured; }

  /// Output feedback (docs/model.md M40): the estimation-error set {e : e^T P_est^-1 e <= 1} of the
  /// state the next steps are given; their state constraints are tightened by its support on top of
  /// the tube's. An empty matrix returns to full-state feedback. Allocation-free after the first call.
  /// @param P_est 12 x 12, symmetric positive semi-definite (units of x squared), or empty.
  /// @throws std::invalid_argument for another size.
  void set_estimation_error(const Eigen::Ref<const Eigen::MatrixXd>& P_est);

  /// Offers a background LMI design of subsystem `subsystem` (0: p, 1: r), started from the data of
  /// step `k_started` (TubePolicy::adopt). Allocation-free.
  /// @param subsystem 0 or 1.
  /// @param design    the design.
  /// @param k_started its step.
  /// @return whether it was adopted.
  bool adopt(int subsystem, const SubsystemDesign& design, int k_started);

  /// Takes over another controller's identified disturbance: both subsystems' identifiers (estimates and
  /// settings) are copied, so that the next steps' tubes are certified for what `other` identified (the safe
  /// abort entered from the descent, abort.hpp). Allocation-free.
  /// @param other a controller of the same plant.
  void inherit_identification(const Controller& other);

  /// @param subsystem 0 (p) or 1 (r).
  /// @return that subsystem's identifier.
  const ForgettingFactorIdentifier& identifier(int subsystem) const;
  /// @param subsystem 0 (p) or 1 (r).
  /// @return that subsystem's tube policy (after setup).
  const TubePolicy& policy(int subsystem) const;
  /// @return the tube MPC.
  const mpc::TubeMPC& mpc() const { return *mpc_; }
  /// @return the settings.
  const ControllerSettings& settings() const { return settings_; }

 private:
  std::shared_ptr<const math::LinearizedModel> model_;
  ControllerSettings settings_;
  std::unique_ptr<mpc::TubeMPC> mpc_;
  std::array<ForgettingFactorIdentifier, 2> identifiers_;
  std::vector<TubePolicy> policies_;
  mpc::Reference reference_;
  std::vector<std::array<SubMatrix, 2>> A_ref_;
  std::vector<std::array<SubInputMatrix, 2>> B_ref_;
  std::array<double, 2> u_max_{};
  ControlStep out_;
  // the last call's step, state and command, for the measured input of the next
  void predict(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k);
  void feedforward();  // ControllerSettings::feedforward on out_.u
  void restart();      // identifiers, policies and the step bookkeeping back to k = 0
  int last_k_ = -1;
  int identified_k_ = -1;   // the step whose period was last folded in
  bool predicted_ = false;  // x_pred_ holds the prediction of step last_k_ + 1
  Eigen::Matrix<double, 12, 1> x_pred_ = Eigen::Matrix<double, 12, 1>::Zero();
  Eigen::MatrixXd A_buf_, B_buf_;
  Eigen::VectorXd c_buf_;
  bool margin_lost_ = false;
};

}  // namespace tubempc::control

namespace tubempc::core {

/// Names of control::Method.
template <>
struct EnumNames<control::Method> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<control::Method>, 2> values{
      {{control::Method::Tbmpc, "Tbmpc", "tbmpc"}, {control::Method::Ffa, "Ffa", "ffa"}}};
};

/// Names of control::MeasuredInput.
template <>
struct EnumNames<control::MeasuredInput> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<control::MeasuredInput>, 2> values{
      {{control::MeasuredInput::Residual, "Residual", "residual"},
       {control::MeasuredInput::ReferenceDeviation, "ReferenceDeviation", "reference_deviation"}}};
};

}  // namespace tubempc::core
