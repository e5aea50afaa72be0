/// @file results.hpp
/// Outcomes of the tube MPC (TubeMPC, tube_mpc.hpp): the step Status, per-step Timings and StepResult,
/// and the exported QP (QpData) with its primal-dual solution (QpSolution).
#pragma once

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <array>
#include <string>

#include "tubempc/core/fields.hpp"

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

/// Name of a status ("solved", "fallback_shifted_plan", ...; core::EnumNames<Status>).
std::string to_string(Status status);
/// @param status a status.
/// @return whether it is a fallback (FallbackShiftedPlan or FallbackSafeInput).
constexpr bool is_fallback(Status status) {
  return status == Status::FallbackShiftedPlan || status == Status::FallbackSafeInput;
}

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
      0;  ///< Active-set factorisations summed over the step's QPs (incl. failed tries).
  int active_set_failures =
      0;  ///< Active-set tries of this step that did not verify (a cold try or PIQP followed).
  int active_set_refinements = 0;  ///< Iterative-refinement solves of the active set, summed over the step.
  int model_evaluations = 0;       ///< Nodes discretised by the model in this step (calls of
                                   ///< LinearizedModel::discretize; see Settings::reuse_linearization).
  double scp_residual = 0.0;       ///< Final max_i ||z*_i - z_lin_i||_inf (state units).
  double objective = 0.0;          ///< Nominal cost of the applied plan's last QP (incl. constant).
  Timings timings;                 ///< Wall-clock split of the step (s).
};

/// The last QP built, in PIQP's standard form (see tube_mpc.hpp). P is the full symmetric matrix.
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

}  // namespace tubempc::mpc

namespace tubempc::core {

/// Names of mpc::Status.
template <>
struct EnumNames<mpc::Status> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<mpc::Status>, 11> values{
      {{mpc::Status::Solved, "Solved", "solved"},
       {mpc::Status::SolvedInaccurate, "SolvedInaccurate", "solved_inaccurate"},
       {mpc::Status::MaxIterations, "MaxIterations", "max_iterations"},
       {mpc::Status::FallbackShiftedPlan, "FallbackShiftedPlan", "fallback_shifted_plan"},
       {mpc::Status::FallbackSafeInput, "FallbackSafeInput", "fallback_safe_input"},
       {mpc::Status::Infeasible, "Infeasible", "infeasible"},
       {mpc::Status::NotSolved, "NotSolved", "not_solved"},
       {mpc::Status::TimeLimit, "TimeLimit", "time_limit"},
       {mpc::Status::NumericalError, "NumericalError", "numerical_error"},
       {mpc::Status::EmptyTightening, "EmptyTightening", "empty_tightening"},
       {mpc::Status::ModelStructure, "ModelStructure", "model_structure"}}};
};

}  // namespace tubempc::core
