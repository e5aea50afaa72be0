/// @file tube_mpc.hpp
/// Nominal problem of the tube MPC (docs/model.md "Tube MPC", "Linearisation and discretisation",
/// "Constraints"; the paper's Problems 2 and 3 and the inner iteration of Algorithm 1), solved by
/// sequential convex programming with one sparse QP per iteration (a warm-started active set,
/// ActiveSetQp; PIQP where that does not verify). Settings and outcomes: settings.hpp, results.hpp.
///
/// Lifecycle: construct with a plant and Settings, `setup(reference)` once per mission (allocates
/// everything, computes the terminal weight, builds the QP's sparsity pattern, sets PIQP up and, with
/// Linearization::Reuse, computes the model data about the reference that a first step at k = 0 uses),
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
///    the ellipsoid, docs/model.md "Tube MPC"; the paper's set {x_k} (+) (-Z) is the whole ellipsoid);
///  - sigma ((N + 1) n_c, only with soft state constraints) are the L1 slacks of the state
///    constraints, t (n_x, only with a soft terminal constraint) those of the terminal equality
///    (|z_N - x_f| <= t, cost soft_penalty 1^T t + ||t||^2 in the shrinking phase; ||t||^2 before).
/// The cost is sum_{i < n} ||z_i - zbar_{k+i}||^2_Q + ||v_i||^2_R (or ||v_i - u_ref_{k+i}||^2_R), plus
/// ||z_N - zbar_{k+N}||^2_P while k + N < T (with a soft terminal constraint, ||z_N - x_f||^2_Q
/// after: P's angular-rate entries, ~1e8 on the Bennu scenario, stalled PIQP there); the QP's P is
/// twice the weights and the constant dropped
/// from the QP is `QpData::constant` (nonzero only with InputCost::Deviation). Constraints: the
/// linearised dynamics, the model's state constraints tightened by sqrt(a^T Pe a) at nodes 0..n, the
/// input box tightened by sqrt(K_i Pe K_i^T), and the SCP trust region |z_i - z_lin_i| <= r (i >= 1).
/// In the shrinking phase (k >= T - N, the paper's Problem 3) the QP has the step's horizon n = T - k
/// and z_n = x_f = zbar_T (hard, or L1-penalised): setup lays out and sets up one QP per horizon
/// 1..N, each with its own fixed sparsity pattern and solver, and a step's warm start maps the
/// previous step's active set from the QP of one node more. The plan returned still has N + 1 nodes:
/// past the mission's end it holds z_T with zero inputs.
/// QP solver (Settings::qp_solver): by default a warm-started primal-dual active-set method
/// (active_set_qp.hpp) whose guess is the previous QP's active set (the previous step's shifted by one
/// node in a step's first SCP iteration), accepted only when it verifies the KKT conditions; if that
/// guess fails, once more from the empty set (a wrong guess can make dependent rows active); otherwise
/// PIQP (an interior-point method, which has no warm start) solves the same QP. Each step's SCP starts
/// from the previous plan shifted to k as its linearisation trajectory. With Settings::linearization
/// (default), model data whose linearisation point lies within scp_eps of the plan are kept: a step that
/// follows a converged step by one period starts from that step's last model data shifted by one node (only
/// the appended last node calls the model; setup leaves the same for a first step at k = 0, about the
/// reference), and a later SCP iteration re-linearises only the nodes
/// whose plan moved by scp_eps or more. The convergence test is unchanged. The model must then be a
/// function of its arguments (t, dt, x, u) only; call reset() after changing it.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <limits>
#include <memory>
#include <string>

#include "tubempc/math/linearized_model.hpp"
#include "tubempc/mpc/active_set_qp.hpp"
#include "tubempc/mpc/results.hpp"
#include "tubempc/mpc/settings.hpp"

namespace tubempc::mpc {

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
  /// Output feedback (docs/model.md M40): the estimation-error set {e : e^T P_est^-1 e <= 1} of the
  /// state the step is given (n_x x n_x, symmetric positive semi-definite; units of x squared). The
  /// state constraints are tightened by sqrt(a^T P_est a) on top of sqrt(a^T Pe a). Empty (the
  /// default): full-state feedback, no extra tightening.
  Eigen::MatrixXd P_est;
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
  TubeMPC(std::shared_ptr<const math::LinearizedModel> model, Settings settings);
  ~TubeMPC();
  TubeMPC(const TubeMPC&) = delete;
  TubeMPC& operator=(const TubeMPC&) = delete;
  TubeMPC(TubeMPC&&) = delete;             ///< holds its QP workspaces in place
  TubeMPC& operator=(TubeMPC&&) = delete;  ///< likewise

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

  /// The model's discretisation over the mission's period k (from t0 + k dt) about (x, u), as a step computes a
  /// new node: with Linearization::Reuse, re-discretised from the reference's data at node k (computed by setup),
  /// so that the parts the model keeps (math::LinearizedModel::rediscretize; the proximity model's gravity blocks
  /// within its position tolerance of the reference's r_L) are not evaluated again; otherwise `discretize`.
  /// Allocation-free.
  /// @param k 0 <= k < T.
  /// @param x the state (n_x).
  /// @param u the input (n_u).
  /// @param A receives A_k (n_x x n_x).
  /// @param B receives B_k (n_x x n_u).
  /// @param c receives c_k (n_x).
  /// @throws std::invalid_argument before setup or for k out of range; what the model's discretize throws.
  void discretize(int k, const Eigen::Ref<const Eigen::VectorXd>& x,
                  const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const;

  /// The last QP built, of the last step's horizon (copies; allocates; empty before the first step).
  QpData qp_data() const;
  /// The last QP's primal-dual solution, from the solver that solved it (copies; allocates).
  QpSolution qp_solution() const;

  /// The validated settings.
  const Settings& settings() const { return settings_; }
  /// Terminal weight P (n_x x n_x) computed by setup.
  const Eigen::MatrixXd& terminal_weight() const;
  /// Mission length T (steps); 0 before setup.
  int mission_steps() const;
  /// Number of QP variables, equality rows and inequality rows of the horizon-N QP (a shrinking-phase
  /// step's QP, horizon T - k, is smaller).
  Eigen::Vector3i qp_dimensions() const;

 private:
  struct Impl;
  struct StepContext;  // the step's constants shared by its phases (tube_mpc.cpp)
  // The phases of step(), in order (tube_mpc.cpp documents each).
  void shift_warm_start(StepContext& c);
  void seed_linearization(StepContext& c);
  Status tighten(const StepContext& c);
  void write_cost(const StepContext& c);
  void write_constraints(const StepContext& c);
  double update_plan(const StepContext& c, const Eigen::VectorXd& x_qp);
  const StepResult& finish(const StepContext& c, bool converged, bool inaccurate);
  const StepResult& fallback(const StepContext& c, Status cause);
  std::shared_ptr<const math::LinearizedModel> model_;
  Settings settings_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tubempc::mpc
