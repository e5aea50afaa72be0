/// @file settings.hpp
/// Settings of the tube MPC (TubeMPC, tube_mpc.hpp): the option enums and Settings, with in-class
/// defaults and validate(). Each enum's text form (to_string) is its name in scenario files; the
/// names are in one table per enum (core::EnumNames) and the fields in one list (Settings::for_each_field).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <limits>

#include "tubempc/core/fields.hpp"

namespace tubempc::mpc {

/// Initial-condition handling of the nominal state z_0.
enum class InitialCondition {
  WhitenedBox,  ///< z_0 = x_k + L s, |s_j| <= 1/sqrt(n_x) (inside the tube ellipsoid; default).
  Exact,        ///< z_0 = x_k.
};

/// Input part of the stage cost.
enum class InputCost {
  Absolute,   ///< ||v||^2_R (the paper's Problem 2, default).
  Deviation,  ///< ||v - u_ref||^2_R (the deviation from the reference input).
};
/// Name of an input cost (as in configuration and scenario files).
/// @param c the input cost.
/// @return "absolute" or "deviation".
const char* to_string(InputCost c);

/// QP solver used inside `step`.
enum class QpSolver {
  Piqp,  ///< PIQP's sparse interior-point solver, set up once, updated every QP.
  /// Warm-started primal-dual active set (ActiveSetQp, at most Settings::active_set_max_iterations
  /// factorisations per try; a second try from the empty set when the warm start fails); a QP it does
  /// not solve to the verified tolerance goes to PIQP (default).
  ActiveSet,
};
/// Name of a QP solver (as in configuration and scenario files).
/// @param q the solver.
/// @return "piqp" or "active_set".
const char* to_string(QpSolver q);

/// Which nodes the SCP iterations re-linearise.
enum class Linearization {
  /// Model data whose linearisation point lies within scp_eps of the plan are kept, across steps and
  /// SCP iterations (default; see tube_mpc.hpp).
  Reuse,
  EveryIteration,  ///< Every node re-linearised about the latest plan at every SCP iteration (Algorithm 1).
};
/// Name of a linearisation policy (as in configuration and scenario files).
/// @param l the policy.
/// @return "reuse" or "every_iteration".
const char* to_string(Linearization l);

/// How many SCP iterations (QPs) one step runs.
enum class ScpMode {
  /// Until the plan moves less than scp_eps from its linearisation points, at most scp_max_iterations
  /// QPs (the paper's Algorithm 1; default).
  Converge,
  /// One QP per step (a real-time iteration, as acados' RTI): the nodes whose plan moved by scp_eps or
  /// more are re-linearised about that plan at the next step, before its QP; needs
  /// Linearization::Reuse. StepResult::scp_residual reports the move.
  RealTime,
};
/// Name of an SCP mode (as in configuration and scenario files).
/// @param m the mode.
/// @return "converge" or "real_time".
const char* to_string(ScpMode m);

/// Factorisation of PIQP's KKT systems.
enum class KktSolver {
  SparseLdlt,        ///< General sparse LDL^T with fill-reducing ordering (default).
  SparseMultistage,  ///< Stage-wise block LDL^T; needs PIQP built with BLASFEO (validate() says if not).
};

/// Settings of the tube MPC; `validate()` throws std::invalid_argument naming the field.
struct Settings {
  int horizon = 30;       ///< N, nodes of the nominal plan.
  double dt = 2.0;        ///< Control period (s).
  Eigen::MatrixXd Q;      ///< State weight (n_x x n_x, symmetric PSD); empty -> identity.
  Eigen::MatrixXd R;      ///< Input weight (n_u x n_u, symmetric PD); empty -> identity.
  Eigen::VectorXd u_max;  ///< True input bounds |u_i| <= u_max_i (input units); required.
  InputCost input_cost = InputCost::Absolute;                          ///< Input part of the stage cost.
  InitialCondition initial_condition = InitialCondition::WhitenedBox;  ///< How z_0 relates to x_k.
  double scp_eps = 1e-3;        ///< SCP stops when max_i ||z*_i - z_lin_i||_inf < scp_eps (state units).
  int scp_max_iterations = 10;  ///< Cap on SCP iterations per step (ScpMode::Converge).
  ScpMode scp_mode = ScpMode::Converge;  ///< Iterate to convergence or one QP per step.
  double trust_region =
      std::numeric_limits<double>::infinity();  ///< |z_i - z_lin_i|_inf bound (i >= 1); inf: off.
  double qp_eps_abs = 1e-8;                     ///< PIQP absolute tolerance.
  double qp_eps_rel = 1e-9;                     ///< PIQP relative tolerance.
  int qp_max_iterations = 200;                  ///< PIQP iteration cap.
  double qp_inaccurate_tol = 1e-5;      ///< A capped QP with relative residuals below this is accepted.
  double time_limit = 1.0;              ///< Wall-clock budget of one step (s); exceeded -> fallback.
  bool soft_state_constraints = false;  ///< Exact L1 penalty on state-constraint violations.
  /// Exact L1 penalty on z_N - x_f in the shrinking phase (default; plus ||z_N - x_f||^2_Q). The
  /// penalty is exact: the minimiser is the hard constraint's (the paper's Problem 3)
  /// whenever soft_penalty exceeds the terminal multipliers, and the step still returns a plan when
  /// the hard terminal set is out of reach. With the hard equality (false) PIQP's interior point needs
  /// hundreds of iterations on the last steps, whose terminal multipliers reach ~1e6.
  bool soft_terminal = true;
  double soft_penalty = 1e6;         ///< L1 penalty weight of the slacks (cost units per constraint unit).
  double riccati_tol = 1e-10;        ///< Relative convergence tolerance of the DARE doubling.
  int riccati_max_iterations = 100;  ///< Cap on DARE doubling iterations.
  QpSolver qp_solver = QpSolver::ActiveSet;  ///< QP solver.
  /// Factorisations the active-set solver may spend on each of its (at most two) tries on one QP
  /// before PIQP takes over (>= 1). Its KKT
  /// verification uses qp_eps_abs and qp_eps_rel.
  int active_set_max_iterations = 20;
  KktSolver kkt_solver = KktSolver::SparseLdlt;  ///< Factorisation of PIQP's KKT systems.
  /// PIQP also scales the cost in its equilibration (on by default): the shrinking-horizon QPs, whose
  /// terminal-equality multipliers reach ~1e6, need ~14 interior-point iterations instead of 200+
  /// (PIQP >= 0.7; `tubempc bench mpc` reports the optimum's agreement with Clarabel). With soft
  /// constraints the L1 penalty dominates PIQP's cost scale and the quadratic part becomes tiny; turn
  /// it off there if QPs stop at the iteration cap (status SolvedInaccurate).
  bool qp_scale_cost = true;
  int qp_preconditioner_iterations = 10;  ///< Ruiz equilibration iterations of PIQP (>= 0).
  double qp_reg_lower_limit = 1e-10;      ///< Floor of PIQP's proximal regularisation (> 0; PIQP's default).
  /// A QP that ends at the iteration cap (beyond qp_inaccurate_tol) or in a numerical error is solved
  /// once more with this regularisation floor before the step falls back (0: no retry). A few
  /// terminal-phase QPs of the Bennu mission lose KKT accuracy at 1e-10 and stall at the cap; with
  /// 1e-8 they solve in ~16 iterations (the floor does not move the optimum; as a default it slows the
  /// last iterations of other QPs, hence a retry).
  double qp_retry_reg_lower_limit = 1e-8;
  /// Re-use of model data whose linearisation point already meets the SCP convergence test:
  ///  - across steps: the first SCP iteration of a step that follows a converged step (status Solved
  ///    or SolvedInaccurate) at k - 1 takes that step's last model data, shifted by one node, with
  ///    their linearisation points (within scp_eps of the previous plan) instead of the previous plan;
  ///  - across SCP iterations: a node whose plan moved less than scp_eps (inf-norm of the state) keeps
  ///    its model data and point; the others are linearised about the new plan.
  /// Only the other nodes call the model (StepResult::model_evaluations). Needs a model whose output
  /// depends on (t, dt, x, u) only. Linearization::EveryIteration: every SCP iteration calls the model
  /// at every node about the latest plan.
  Linearization linearization = Linearization::Reuse;
  /// Optional structural patterns of the model's A (n_x x n_x), B (n_x x n_u) and G (n_c x n_x): entries
  /// != 0 are stored in the QP, the others are structural zeros the model must respect (a nonzero there
  /// makes the step fall back with failure ModelStructure). Empty: dense. Sparser patterns make the KKT
  /// factorisation cheaper (e.g. block-diagonal translational/rotational subsystems).
  Eigen::MatrixXd A_structure;  ///< Pattern of A (n_x x n_x) or empty (dense).
  Eigen::MatrixXd B_structure;  ///< Pattern of B (n_x x n_u) or empty (dense).
  Eigen::MatrixXd G_structure;  ///< Pattern of G (n_c x n_x) or empty (dense).

  /// Throws std::invalid_argument naming the offending field; n_x, n_u are the plant's sizes.
  void validate(int nx, int nu) const;

  /// The fields, once: calls visit(info, pointer to the member) with a core::FieldInfo for each member,
  /// in the order scenario files write them (each as the record mpc.name). Drives the scenario file's
  /// reading and writing (io/scenario.cpp) and the Python binding; adding a setting is one line there
  /// (see "One field table" in docs/decisions.md).
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

}  // namespace tubempc::mpc

namespace tubempc::core {

/// Names of mpc::InitialCondition.
template <>
struct EnumNames<mpc::InitialCondition> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<mpc::InitialCondition>, 2> values{
      {{mpc::InitialCondition::WhitenedBox, "WhitenedBox", "whitened_box"},
       {mpc::InitialCondition::Exact, "Exact", "exact"}}};
};
/// Names of mpc::InputCost.
template <>
struct EnumNames<mpc::InputCost> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<mpc::InputCost>, 2> values{
      {{mpc::InputCost::Absolute, "Absolute", "absolute"},
       {mpc::InputCost::Deviation, "Deviation", "deviation"}}};
};
/// Names of mpc::QpSolver.
template <>
struct EnumNames<mpc::QpSolver> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<mpc::QpSolver>, 2> values{
      {{mpc::QpSolver::Piqp, "Piqp", "piqp"}, {mpc::QpSolver::ActiveSet, "ActiveSet", "active_set"}}};
};
/// Names of mpc::Linearization.
template <>
struct EnumNames<mpc::Linearization> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<mpc::Linearization>, 2> values{
      {{mpc::Linearization::Reuse, "Reuse", "reuse"},
       {mpc::Linearization::EveryIteration, "EveryIteration", "every_iteration"}}};
};
/// Names of mpc::ScpMode.
template <>
struct EnumNames<mpc::ScpMode> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<mpc::ScpMode>, 2> values{
      {{mpc::ScpMode::Converge, "Converge", "converge"}, {mpc::ScpMode::RealTime, "RealTime", "real_time"}}};
};
/// Names of mpc::KktSolver.
template <>
struct EnumNames<mpc::KktSolver> {
  /// The values, their identifiers and file names.
  static constexpr std::array<EnumName<mpc::KktSolver>, 2> values{
      {{mpc::KktSolver::SparseLdlt, "SparseLdlt", "sparse_ldlt"},
       {mpc::KktSolver::SparseMultistage, "SparseMultistage", "sparse_multistage"}}};
};

}  // namespace tubempc::core

namespace tubempc::mpc {

// The table of Settings::for_each_field.
template <typename V>
void Settings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  constexpr bool req = false, opt = true, inf = true, finite = false;
  visit(FieldInfo{"horizon", "", req, finite}, &Settings::horizon);
  visit(FieldInfo{"dt", "s", req, finite}, &Settings::dt);
  visit(FieldInfo{"Q", "", req, finite, Dim::Nx, Dim::Nx}, &Settings::Q);
  visit(FieldInfo{"R", "", req, finite, Dim::Nu, Dim::Nu}, &Settings::R);
  visit(FieldInfo{"u_max", "input units", req, finite, Dim::Nu, Dim::One}, &Settings::u_max);
  visit(FieldInfo{"input_cost", "", req, finite}, &Settings::input_cost);
  visit(FieldInfo{"scp_eps", "state units", req, finite}, &Settings::scp_eps);
  visit(FieldInfo{"initial_condition", "", opt, finite}, &Settings::initial_condition);
  visit(FieldInfo{"scp_max_iterations", "", opt, finite}, &Settings::scp_max_iterations);
  visit(FieldInfo{"trust_region", "state units", opt, inf}, &Settings::trust_region);
  visit(FieldInfo{"qp_eps_abs", "", opt, finite}, &Settings::qp_eps_abs);
  visit(FieldInfo{"qp_eps_rel", "", opt, finite}, &Settings::qp_eps_rel);
  visit(FieldInfo{"qp_max_iterations", "", opt, finite}, &Settings::qp_max_iterations);
  visit(FieldInfo{"qp_inaccurate_tol", "", opt, finite}, &Settings::qp_inaccurate_tol);
  visit(FieldInfo{"time_limit", "s", opt, inf}, &Settings::time_limit);
  visit(FieldInfo{"soft_state_constraints", "", opt, finite}, &Settings::soft_state_constraints);
  visit(FieldInfo{"soft_terminal", "", opt, finite}, &Settings::soft_terminal);
  visit(FieldInfo{"soft_penalty", "", opt, finite}, &Settings::soft_penalty);
  visit(FieldInfo{"riccati_tol", "", opt, finite}, &Settings::riccati_tol);
  visit(FieldInfo{"riccati_max_iterations", "", opt, finite}, &Settings::riccati_max_iterations);
  visit(FieldInfo{"kkt_solver", "", opt, finite}, &Settings::kkt_solver);
  visit(FieldInfo{"qp_solver", "", opt, finite}, &Settings::qp_solver);
  visit(FieldInfo{"active_set_max_iterations", "", opt, finite}, &Settings::active_set_max_iterations);
  visit(FieldInfo{"qp_scale_cost", "", opt, finite}, &Settings::qp_scale_cost);
  visit(FieldInfo{"linearization", "", opt, finite}, &Settings::linearization);
  visit(FieldInfo{"scp_mode", "", opt, finite}, &Settings::scp_mode);
  visit(FieldInfo{"qp_preconditioner_iterations", "", opt, finite}, &Settings::qp_preconditioner_iterations);
  visit(FieldInfo{"qp_reg_lower_limit", "", opt, finite}, &Settings::qp_reg_lower_limit);
  visit(FieldInfo{"qp_retry_reg_lower_limit", "", opt, finite}, &Settings::qp_retry_reg_lower_limit);
  visit(FieldInfo{"A_structure", "", opt, finite, Dim::Nx, Dim::Nx}, &Settings::A_structure);
  visit(FieldInfo{"B_structure", "", opt, finite, Dim::Nx, Dim::Nu}, &Settings::B_structure);
  visit(FieldInfo{"G_structure", "", opt, finite, Dim::Nc, Dim::Nx}, &Settings::G_structure);
}

}  // namespace tubempc::mpc
