/// @file tube_mpc.hpp
/// Nominal problem of the tube MPC (PAPER_NOTES.md "Tube MPC", "Linearisation and discretisation",
/// "Constraints"; the paper's Problems 2 and 3 and the inner iteration of Algorithm 1), solved by
/// sequential convex programming with one sparse QP per iteration (PIQP).
///
/// Lifecycle: construct with a plant and Settings, `setup(reference)` once per mission (allocates
/// everything, computes the terminal weight, builds the QP's sparsity pattern and sets PIQP up),
/// then `step(k, x_k, tube)` every control period. `step` does not allocate heap memory.
///
/// Stored (structural) entries: the upper triangles of Q, R and the terminal weight's nonzeros plus
/// their diagonals, the model structures of Settings (dense by default), identities and L's lower triangle.
///
/// The QP (exported by `qp_data()`, PIQP's form):
///     min 1/2 w^T P w + q^T w   s.t.  A w = b,  h_l <= G w <= h_u,  x_l <= w <= x_u
/// over w = [dz_0, v_0, dz_1, v_1, ..., dz_{N-1}, v_{N-1}, dz_N, s, sigma, t] where
///  - dz_i = z_i - zbar_{min(k+i, T)} (n_x) are the nominal states as deviations from the reference (so
///    the objective carries no large constant and relative solver tolerances stay meaningful for
///    states of hundreds of metres) and v_i (n_u) the nominal inputs at k + i;
///  - s (n_x, only with InitialCondition::WhitenedBox) holds z_0 = x_k + L s, Pe = L L^T, with
///    |s_j| <= 1/sqrt(n_x). That box in whitened coordinates is the largest axis-aligned cube inside
///    the unit ball, so z_0 - x_k lies in the tube ellipsoid Z = -Z (conservative: a polytope inside
///    the ellipsoid, as PAPER_NOTES.md asks; the paper's set {x_k} (+) (-Z) is the whole ellipsoid);
///  - sigma ((N + 1) n_c, only with soft state constraints) are the L1 slacks of the state
///    constraints, t (n_x, only with a soft terminal constraint) those of the terminal equality
///    (|z_N - x_f| <= t, cost soft_penalty 1^T t + ||t||^2 in the shrinking phase; ||t||^2 before).
/// The cost is sum_{i < n} ||z_i - zbar_{k+i}||^2_Q + ||v_i||^2_R (or ||v_i - u_ref_{k+i}||^2_R), plus
/// ||z_N - zbar_{k+N}||^2_P while k + N < T (with a soft terminal constraint, ||z_N - x_f||^2_Q
/// after: P's angular-rate entries, ~1e8 on the Bennu scenario, stalled PIQP there); the QP's P is
/// twice the weights and the constant dropped
/// from the QP is `QpData::constant` (nonzero only with InputCost::FromReference). Constraints: the
/// linearised dynamics, the model's state constraints tightened by sqrt(a^T Pe a) at nodes 0..n, the
/// input box tightened by sqrt(K_i Pe K_i^T), and the SCP trust region |z_i - z_lin_i| <= r (i >= 1).
/// The nodes past the mission's end (k + i > T) are padded with frozen nodes z_{i+1} = z_i, zero state
/// cost and free (costed, unused) inputs so the sparsity pattern never changes; in that shrinking
/// phase (k >= T - N, the paper's Problem 3) z_N = x_f = zbar_T (hard, or L1-penalised).
/// QP solver (Settings::backend): by default a warm-started primal-dual active-set method
/// (active_set_qp.hpp) whose guess is the previous QP's active set (the previous step's shifted by one
/// node in a step's first SCP iteration), accepted only when it verifies the KKT conditions; if that
/// guess fails, once more from the empty set (a wrong guess can make dependent rows active); otherwise
/// PIQP (an interior-point method, which has no warm start) solves the same QP. Each step's SCP starts
/// from the previous plan shifted to k as its linearisation trajectory. With Settings::reuse_linearization
/// (default), model data whose linearisation point lies within scp_eps of the plan are kept: a step that
/// follows a converged step by one period starts from that step's last model data shifted by one node (only
/// the appended last node calls the model), and a later SCP iteration re-linearises only the nodes
/// whose plan moved by scp_eps or more. The convergence test is unchanged. The model must then be a
/// function of its arguments (t, dt, x, u) only; call reset() after changing it.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <limits>
#include <memory>
#include <string>

#include "tubempc/mpc/active_set_qp.hpp"
#include "tubempc/mpc/linearized_model.hpp"

namespace tubempc::mpc {

/// Outcome of a step (`StepResult::status`) and cause of a fallback (`StepResult::failure`).
enum class Status {
  Solved,               ///< SCP converged, QPs solved to tolerance.
  SolvedInaccurate,     ///< SCP converged; a QP hit its iteration cap with small residuals.
  MaxIterations,        ///< SCP cap reached; the last QP solution is applied.
  FallbackShiftedPlan,  ///< The previous plan shifted by one step is applied (paper Theorem 1's candidate).
  FallbackSafeInput,    ///< No previous plan: u = sat(u_ref_k + K (x_k - zbar_k)) is applied.
  Infeasible,           ///< Failure cause: a QP was primal (or dual) infeasible.
  NotSolved,            ///< Failure cause: the QP solver stopped without a usable solution.
  TimeLimit,            ///< Failure cause: the step exceeded Settings::time_limit.
  NumericalError,       ///< Failure cause: non-finite data or solution, tube not positive definite.
  EmptyTightening,      ///< Failure cause: the tightened input box is empty (u_max_i <= sqrt(K_i Pe K_i^T)).
  ModelStructure,       ///< Failure cause: the model returned a nonzero outside Settings::*_structure.
};

/// Name of a status ("solved", "fallback_shifted_plan", ...).
std::string to_string(Status status);

/// Initial-condition handling of the nominal state z_0.
enum class InitialCondition {
  WhitenedBox,  ///< z_0 = x_k + L s, |s_j| <= 1/sqrt(n_x) (inside the tube ellipsoid; default).
  Exact,        ///< z_0 = x_k.
};

/// Input part of the stage cost.
enum class InputCost {
  Paper,          ///< ||v||^2_R (the paper's Problem 2, default).
  FromReference,  ///< ||v - u_ref||^2_R.
};

/// QP solver used inside `step`.
enum class Backend {
  PiqpSparse,  ///< PIQP's sparse interior-point solver, set up once, updated every QP.
  /// Warm-started primal-dual active set (ActiveSetQp, at most Settings::active_set_max_iterations
  /// factorisations per try; a second try from the empty set when the warm start fails); a QP it does
  /// not solve to the verified tolerance goes to PIQP (default).
  ActiveSetPiqp,
};

/// Factorisation of PIQP's KKT systems.
enum class KktSolver {
  SparseLdlt,        ///< General sparse LDL^T with fill-reducing ordering (default).
  SparseMultistage,  ///< Stage-wise block LDL^T; needs PIQP built with BLASFEO (validate() says if not).
};

/// Settings of the tube MPC; `validate()` throws std::invalid_argument naming the field.
struct Settings {
  int horizon = 30;                         ///< N, nodes of the nominal plan.
  double dt = 2.0;                          ///< Control period (s).
  Eigen::MatrixXd Q;                        ///< State weight (n_x x n_x, symmetric PSD); empty -> identity.
  Eigen::MatrixXd R;                        ///< Input weight (n_u x n_u, symmetric PD); empty -> identity.
  Eigen::VectorXd u_max;                    ///< True input bounds |u_i| <= u_max_i (input units); required.
  InputCost input_cost = InputCost::Paper;  ///< Input part of the stage cost.
  InitialCondition initial_condition = InitialCondition::WhitenedBox;  ///< How z_0 relates to x_k.
  double scp_eps = 1e-3;        ///< SCP stops when max_i ||z*_i - z_lin_i||_inf < scp_eps (state units).
  int scp_max_iterations = 10;  ///< Cap on SCP iterations per step.
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
  Backend backend = Backend::ActiveSetPiqp;  ///< QP solver.
  /// Factorisations the active-set solver may spend on each of its (at most two) tries on one QP
  /// before PIQP takes over (>= 1). Its KKT
  /// verification uses qp_eps_abs and qp_eps_rel.
  int active_set_max_iterations = 12;
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
  /// depends on (t, dt, x, u) only. false: every SCP iteration calls the model at every node about
  /// the latest plan.
  bool reuse_linearization = true;
  /// Optional structural patterns of the model's A (n_x x n_x), B (n_x x n_u) and G (n_c x n_x): entries
  /// != 0 are stored in the QP, the others are structural zeros the model must respect (a nonzero there
  /// makes the step fall back with failure ModelStructure). Empty: dense. Sparser patterns make the KKT
  /// factorisation cheaper (e.g. block-diagonal translational/rotational subsystems).
  Eigen::MatrixXd A_structure;  ///< Pattern of A (n_x x n_x) or empty (dense).
  Eigen::MatrixXd B_structure;  ///< Pattern of B (n_x x n_u) or empty (dense).
  Eigen::MatrixXd G_structure;  ///< Pattern of G (n_c x n_x) or empty (dense).

  /// Throws std::invalid_argument naming the offending field; n_x, n_u are the plant's sizes.
  void validate(int nx, int nu) const;
};

/// Mission reference: zbar (n_x x (T + 1)) and u_ref (n_u x T), node j at time t0 + j dt.
struct Reference {
  Eigen::MatrixXd z;  ///< Reference states zbar_0..zbar_T (columns); zbar_T is the target x_f.
  Eigen::MatrixXd u;  ///< Reference inputs u_ref_0..u_ref_{T-1} (columns).
  double t0 = 0.0;    ///< Time of node 0 (s), passed to the model.
};

/// Robust invariant tube: error e = x - z stays in {e : e^T Pe^-1 e <= 1} under u = v + K e.
struct Tube {
  Eigen::MatrixXd K;   ///< Ancillary gain (n_u x n_x).
  Eigen::MatrixXd Pe;  ///< Tube shape (n_x x n_x, symmetric positive definite).
};

/// Wall-clock split of one step (s).
struct Timings {
  double linearize = 0.0;  ///< Model discretisation and constraint linearisation.
  double build = 0.0;      ///< Writing the QP's values.
  double solve = 0.0;      ///< QP solves.
  double total = 0.0;      ///< Whole step.
};

/// Result of one step. Buffers are allocated at setup and overwritten by every step.
struct StepResult {
  Eigen::VectorXd u;  ///< Applied input u = sat(v_0 + K (x_k - z_0)) (n_u).
  Eigen::MatrixXd z;  ///< Nominal plan z_0..z_N (n_x x (N + 1)); frozen past the mission's end.
  Eigen::MatrixXd v;  ///< Nominal inputs v_0..v_{N-1} (n_u x N).
  Status status = Status::NotSolved;  ///< What was applied.
  Status failure = Status::Solved;    ///< Cause of a fallback (Solved when none).
  int horizon = 0;                    ///< Active horizon n = min(N, T - k).
  int scp_iterations = 0;             ///< QPs solved in this step. When re-linearising reproduces the
                                      ///< last QP's data exactly (a linear plant) and its trust region is
                                      ///< inactive, the loop stops without re-solving (residual 0).
  int qp_iterations = 0;              ///< PIQP interior-point iterations summed over the step's QPs.
  int active_set_solves = 0;  ///< QPs of this step solved by the active-set method (the others: PIQP).
  int active_set_iterations =
      0;                      ///< Active-set factorisations summed over the step's QPs (incl. failed tries).
  int model_evaluations = 0;  ///< Nodes discretised by the model in this step (calls of
                              ///< LinearizedModel::discretize; see Settings::reuse_linearization).
  double scp_residual = 0.0;  ///< Final max_i ||z*_i - z_lin_i||_inf (state units).
  double objective = 0.0;     ///< Nominal cost of the applied plan's last QP (incl. constant).
  Timings timings;            ///< Wall-clock split of the step (s).
};

/// The last QP built, in PIQP's form (see the file comment). P is the full symmetric matrix.
struct QpData {
  Eigen::SparseMatrix<double> P;  ///< Hessian (n_w x n_w, symmetric, both triangles).
  Eigen::VectorXd q;              ///< Linear cost (n_w).
  Eigen::SparseMatrix<double> A;  ///< Equality rows: initial condition and dynamics.
  Eigen::VectorXd b;              ///< Equality right-hand side.
  Eigen::SparseMatrix<double> G;  ///< Inequality rows: tightened state constraints (and soft-terminal rows).
  Eigen::VectorXd h_l;            ///< Lower side of G w (-inf where absent).
  Eigen::VectorXd h_u;            ///< Upper side of G w (+inf where absent).
  Eigen::VectorXd x_l;            ///< Lower variable bounds (-inf where absent).
  Eigen::VectorXd x_u;            ///< Upper variable bounds (+inf where absent).
  double constant = 0.0;          ///< Cost = 1/2 w^T P w + q^T w + constant.
};

/// Primal-dual solution of the last QP. Stationarity: P w + q + A^T y + G^T (z_u - z_l) + z_bu - z_bl = 0,
/// z_l, z_u, z_bl, z_bu >= 0 and complementary to the lower/upper sides.
struct QpSolution {
  Eigen::VectorXd w;     ///< Primal solution (n_w).
  Eigen::VectorXd y;     ///< Multipliers of A w = b.
  Eigen::VectorXd z_l;   ///< Multipliers of h_l <= G w.
  Eigen::VectorXd z_u;   ///< Multipliers of G w <= h_u.
  Eigen::VectorXd z_bl;  ///< Multipliers of x_l <= w.
  Eigen::VectorXd z_bu;  ///< Multipliers of w <= x_u.
};

/// Stabilising solution X of the discrete algebraic Riccati equation
/// X = A^T X A - A^T X B (R + B^T X B)^-1 B^T X A + Q by the structured doubling algorithm.
/// Throws std::invalid_argument on inconsistent sizes and std::runtime_error when it does not
/// converge to `tol` (relative) within `max_iterations` or meets a singular or non-finite iterate.
Eigen::MatrixXd solve_dare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                           const Eigen::MatrixXd& R, double tol = 1e-10, int max_iterations = 100);

/// Tube MPC (see the file comment for the QP).
class TubeMPC {
 public:
  /// Keeps a shared reference to the plant; validates the settings against its sizes.
  TubeMPC(std::shared_ptr<const LinearizedModel> model, Settings settings);
  ~TubeMPC();
  TubeMPC(const TubeMPC&) = delete;
  TubeMPC& operator=(const TubeMPC&) = delete;

  /// Stores the mission reference (T >= 1) and prepares everything; the terminal weight solves the
  /// DARE with the model's discretisation at the final node (zbar_T, u_ref_{T-1}, t0 + T dt).
  void setup(const Reference& reference);
  /// As above with the terminal weight from the DARE of a given (A, B) (discrete time).
  void setup(const Reference& reference, const Eigen::MatrixXd& A_terminal,
             const Eigen::MatrixXd& B_terminal);

  /// One control step at time index k (0 <= k < T) from the measured state x_k (n_x) with the
  /// tube (K, Pe). The linearisation starts from the last plan shifted to k (when it was made at a
  /// k' in (k - N, k]), else from the reference. Returns a reference to internal storage, valid until the
  /// next step. Numerical outcomes are statuses; wrong sizes or k out of range throw std::invalid_argument.
  const StepResult& step(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k, const Tube& tube);

  /// Forgets the previous plan and the re-usable model data (the next step linearises about the reference).
  void reset();

  /// The last QP built (copies; allocates).
  QpData qp_data() const;
  /// The last QP's primal-dual solution, from the solver that solved it (copies; allocates).
  QpSolution qp_solution() const;

  /// The validated settings.
  const Settings& settings() const { return settings_; }
  /// Terminal weight P (n_x x n_x) computed by setup.
  const Eigen::MatrixXd& terminal_weight() const;
  /// Mission length T (steps); 0 before setup.
  int mission_steps() const;
  /// Number of QP variables, equality rows and inequality rows.
  Eigen::Vector3i qp_dimensions() const;

 private:
  struct Impl;
  struct StepContext;  // the step's constants shared by its phases (tube_mpc.cpp)
  // The phases of step(), in order (tube_mpc.cpp documents each).
  void shift_warm_start(StepContext& c);
  void seed_linearization(StepContext& c);
  Status tighten(const StepContext& c);
  void write_cost(const StepContext& c);
  Status linearize(const StepContext& c, int it);
  bool same_model_data(const StepContext& c, int it, double last_delta);
  void write_constraints(const StepContext& c);
  Status solve_with_retry(const StepContext& c);
  double update_plan(const StepContext& c, const Eigen::VectorXd& x_qp);
  const StepResult& finish(const StepContext& c, bool converged, bool inaccurate);
  const StepResult& fallback(const StepContext& c, Status cause);
  std::shared_ptr<const LinearizedModel> model_;
  Settings settings_;
  std::unique_ptr<Impl> impl_;
};

/// Linear time-invariant plant x+ = A x + B u + c with constant constraints G x <= h: a test and
/// benchmark plant (and a stand-in for the 6-DOF model). The discretisation is computed once.
class LtiModel final : public LinearizedModel {
 public:
  /// Continuous-time (A_c, B_c, c_c), discretised with a zero-order hold over dt (s).
  LtiModel(const Eigen::MatrixXd& A_c, const Eigen::MatrixXd& B_c, const Eigen::VectorXd& c_c, double dt,
           const Eigen::MatrixXd& G, const Eigen::VectorXd& h);
  int nx() const override { return static_cast<int>(A_.rows()); }
  int nu() const override { return static_cast<int>(B_.cols()); }
  int n_constraints() const override { return static_cast<int>(G_.rows()); }
  /// Writes the precomputed (A, B, c); throws std::invalid_argument if dt differs from the construction's.
  void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                  const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override;
  void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x_lin, Eigen::Ref<Eigen::MatrixXd> G,
                   Eigen::Ref<Eigen::VectorXd> h) const override;

 private:
  Eigen::MatrixXd A_, B_;
  Eigen::VectorXd c_;
  double dt_;
  Eigen::MatrixXd G_;
  Eigen::VectorXd h_;
};

}  // namespace tubempc::mpc
