/// @file active_set_qp.hpp
/// Warm-started primal-dual active-set solver for the tube MPC's QP (PIQP's form, see tube_mpc.hpp):
///     min 1/2 w^T P w + q^T w   s.t.  A w = b,  h_l <= G w <= h_u,  x_l <= w <= x_u.
///
/// Method (the primal-dual active-set iteration of Hintermueller, Ito and Kunisch, SIAM J. Optim.
/// 13(3), 2003): given a guess of the active set, solve the equality-constrained QP in which the
/// active rows hold at their bound (one sparse LDL^T of the KKT matrix), then move rows whose
/// multiplier has the wrong sign out of the set and violated rows into it; stop when the set repeats.
/// At that point the KKT conditions hold, which `solve` verifies on the unregularised problem before
/// it reports Status::Solved. In MPC the active set of the previous QP (shifted by one node) is
/// usually right or nearly right, so a QP costs one to three factorisations, against the ~14 of an
/// interior point. The iteration can cycle on hard instances (the Bennu mission's shrinking phase, where
/// a soft-terminal L1 penalty makes the QP nearly an LP): after Settings::primal_dual_iterations
/// factorisations, or on a dependent set, a dual active-set phase (Goldfarb and Idnani, Math. Program.
/// 27, 1983) takes over from the current set without its wrong-sign rows. It adds one violated row at a
/// time along the segment of minimisers on which that row's multiplier grows from zero, dropping any
/// active row whose multiplier reaches zero first; the dual objective increases at every step, so no set
/// repeats. A solve that has not settled after Settings::max_iterations factorisations in all returns
/// Status::MaxIterations, and the caller uses its fallback solver.
///
/// The KKT matrix [[P + rho I, A^T, C^T], [A, -delta I, 0], [C, 0, -D]] (C: the rows of G and the
/// bound rows of the variables that may carry bounds; inactive rows have C_i = 0 and D_ii = 1, so
/// their multiplier is 0) keeps one sparsity pattern for every active set: its fill-reducing (AMD)
/// ordering and symbolic analysis are done once by `setup`, and `solve` allocates nothing. Each
/// factorisation recomputes only the rows of L that depend on the columns whose values changed
/// (PartialLdlt, partial_ldlt.hpp): the first of a solve is complete when the QP's data changed, the
/// following ones, after a change of a few rows of the set, recompute a small part of the factor.
/// The regularisations rho and delta make the matrix quasi-definite (an LDL^T exists for any
/// ordering); iterative refinement against the unregularised matrix removes their effect.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <array>
#include <string>

#include "tubempc/core/fields.hpp"
#include "tubempc/mpc/partial_ldlt.hpp"

namespace tubempc::mpc {

/// Primal-dual active-set QP solver with a fixed sparsity pattern (see the file comment).
class ActiveSetQp {
 public:
  using SpMat = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;  ///< Compressed column storage of P, A, G.

  /// Outcome of `solve`.
  enum class Status {
    Solved,         ///< Active set repeated and the KKT conditions verified to tolerance.
    MaxIterations,  ///< The set still changed after Settings::max_iterations factorisations.
    Inaccurate,     ///< The set repeated but the verified KKT residuals exceed the tolerance.
    Singular,  ///< A zero pivot in the LDL^T, or multipliers beyond Settings::max_multiplier_ratio (dependent rows).
    InvalidData,  ///< Non-finite data, a finite bound outside the set-up pattern, or h_l > h_u.
  };

  /// Settings; `validate()` throws std::invalid_argument naming the field.
  struct Settings {
    int max_iterations = 20;  ///< Factorisations (active-set iterations) per solve (>= 1).
    /// Factorisations of the primal-dual phase before the dual phase takes over (>= 1; see the file comment).
    int primal_dual_iterations = 4;
    double eps_abs = 1e-8;     ///< Absolute tolerance of the KKT verification.
    double eps_rel = 1e-9;     ///< Relative tolerance of the KKT verification (and of the set updates).
    double primal_reg = 1e-9;  ///< rho: regularisation of the Hessian block (> 0).
    double dual_reg = 1e-12;   ///< delta: regularisation of the constraint blocks (> 0).
    int max_refinement = 10;   ///< Iterative-refinement steps per factorisation (>= 0).
    /// A try stops with Status::Singular when a multiplier of G or of a bound exceeds this times
    /// max(1, |q|_inf) (> 0; inf: never): dependent active rows, whose multipliers the regularised
    /// KKT matrix makes of the order of 1/dual_reg (with three full primal-dual steps per solve, the
    /// Bennu mission's shrinking-phase QPs reached 1e14 against |q|_inf = 1e6 when the box of the
    /// whitened initial condition fixed z_0 and a node-0 state constraint joined the set). A verified
    /// solution is never rejected by it.
    double max_multiplier_ratio = 1e6;
    /// Throws std::invalid_argument naming the offending field.
    void validate() const;
  };

  /// Iterations, residuals and the final active set's size of the last `solve`.
  struct Info {
    Status status = Status::InvalidData;  ///< Outcome.
    int iterations = 0;                   ///< Factorisations.
    int refinements = 0;                  ///< Iterative-refinement steps, summed over the factorisations.
    int n_active = 0;                     ///< Active rows (G rows and bounds) at the end.
    double primal_res = 0.0;              ///< max(|A w - b|_inf, largest violation of G w and of the bounds).
    double dual_res = 0.0;                ///< |P w + q + A^T y + G^T (z_u - z_l) + z_bu - z_bl|_inf.
  };

  ActiveSetQp() = default;  ///< Empty solver; call setup before solve.

  /// Fixes the pattern: P (n x n, upper triangle, compressed), A (m x n), G (p x n), and which
  /// variables may carry a finite bound (`boundable`, n). Values are ignored. Allocates.
  void setup(const SpMat& P_upper, const SpMat& A, const SpMat& G,
             const Eigen::Array<bool, Eigen::Dynamic, 1>& boundable, const Settings& settings);

  /// Marks the G rows of exact L1 penalty pairs (|a^T w| <= t with t costed: rows a^T w - t <= 0 and
  /// a^T w + t >= 0), `rows` with p entries (empty: none; setup clears the marks). At a solution at least
  /// one row of each pair is active, so a wrong-sign multiplier of such a row in the primal-dual phase
  /// is the echo of another row's wrong guess: these rows leave the set only in an iteration where no
  /// unmarked row has a wrong sign. Allocates; throws std::invalid_argument on a wrong size.
  void set_penalty_rows(const Eigen::Array<bool, Eigen::Dynamic, 1>& rows);

  /// Solves the QP whose matrices have the set-up patterns. `active` (p + n entries: the G rows, then
  /// one per variable) holds the guess on entry (+1 upper side, -1 lower side, 0 inactive; entries of
  /// variables that are not boundable are ignored) and the final set on return. Allocates nothing.
  Status solve(const SpMat& P_upper, const Eigen::VectorXd& q, const SpMat& A, const Eigen::VectorXd& b,
               const SpMat& G, const Eigen::VectorXd& h_l, const Eigen::VectorXd& h_u,
               const Eigen::VectorXd& x_l, const Eigen::VectorXd& x_u, Eigen::Ref<Eigen::VectorXi> active);

  // Solution of the last solve in QpSolution's convention (tube_mpc.hpp).
  const Eigen::VectorXd& w() const { return w_; }        ///< Primal solution (n).
  const Eigen::VectorXd& y() const { return y_; }        ///< Multipliers of A w = b (m).
  const Eigen::VectorXd& z_l() const { return z_l_; }    ///< Multipliers of h_l <= G w (p, >= 0).
  const Eigen::VectorXd& z_u() const { return z_u_; }    ///< Multipliers of G w <= h_u (p, >= 0).
  const Eigen::VectorXd& z_bl() const { return z_bl_; }  ///< Multipliers of x_l <= w (n, >= 0).
  const Eigen::VectorXd& z_bu() const { return z_bu_; }  ///< Multipliers of w <= x_u (n, >= 0).
  /// Objective 1/2 w^T P w + q^T w of the last solve.
  double objective() const { return objective_; }
  /// Status, iterations and residuals of the last solve.
  const Info& info() const { return info_; }
  /// The validated settings of setup.
  const Settings& settings() const { return settings_; }

 private:
  void write_matrix(const SpMat& P_upper, const SpMat& A, const SpMat& G, const Eigen::VectorXi& active);
  bool factorize();
  void residual();

  Settings settings_;
  int n_ = 0, m_ = 0, p_ = 0;
  Eigen::VectorXi bound_var_;                          // variable of each bound row
  Eigen::VectorXi bound_row_;                          // bound row of each variable (-1: not boundable)
  Eigen::Array<bool, Eigen::Dynamic, 1> penalty_row_;  // G rows of exact L1 penalty pairs (p)
  SpMat K_;                                            // KKT upper triangle in the permuted order
  Eigen::VectorXi perm_;                               // natural index -> permuted index
  Eigen::VectorXi pos_P_, pos_A_, pos_G_, pos_B_, pos_diag_;  // value positions in K_
  PartialLdlt ldlt_;
  Eigen::VectorXd K_factored_;  // K_'s values at the last factorisation
  Eigen::VectorXi changed_;     // columns of K_ changed since then
  Eigen::VectorXd reg_;         // K_ = K0 + diag(reg_), K0 the unregularised KKT matrix (permuted order)
  Eigen::VectorXi set_;         // working copy of the active set (p + n)
  Eigen::VectorXd rhs_, sol_;   // KKT right-hand side and solution (natural order)
  Eigen::VectorXd rhs_p_, sol_p_, res_p_;  // the same and the residual (permuted order)
  Eigen::VectorXd tmp_, corr_, g_;
  Eigen::VectorXd w_, y_, z_l_, z_u_, z_bl_, z_bu_, lam_g_, lam_b_;
  Eigen::VectorXd w_c_, y_c_, lam_gc_, lam_bc_;  // the dual phase's current point
  double objective_ = 0.0;
  Info info_;
};

/// Name of an ActiveSetQp status ("solved", "max_iterations", ...; core::EnumNames<ActiveSetQp::Status>).
std::string to_string(ActiveSetQp::Status status);

}  // namespace tubempc::mpc

namespace tubempc::core {

/// Names of mpc::ActiveSetQp::Status.
template <>
struct EnumNames<mpc::ActiveSetQp::Status> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<mpc::ActiveSetQp::Status>, 5> values{
      {{mpc::ActiveSetQp::Status::Solved, "Solved", "solved"},
       {mpc::ActiveSetQp::Status::MaxIterations, "MaxIterations", "max_iterations"},
       {mpc::ActiveSetQp::Status::Inaccurate, "Inaccurate", "inaccurate"},
       {mpc::ActiveSetQp::Status::Singular, "Singular", "singular"},
       {mpc::ActiveSetQp::Status::InvalidData, "InvalidData", "invalid_data"}}};
};

}  // namespace tubempc::core
