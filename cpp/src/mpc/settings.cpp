// Settings of the tube MPC: names of the options and validation (see settings.hpp).
#include "tubempc/mpc/settings.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace tubempc::mpc {

namespace {

void check_square_symmetric(const Eigen::MatrixXd& M, int n, const char* field) {
  if (M.rows() != n || M.cols() != n)
    throw std::invalid_argument(std::string("TubeMPC Settings: ") + field + " must be " + std::to_string(n) +
                                "x" + std::to_string(n));
  if (!M.allFinite())
    throw std::invalid_argument(std::string("TubeMPC Settings: ") + field + " has non-finite entries");
  if ((M - M.transpose()).cwiseAbs().maxCoeff() > 1e-12 * std::max(1.0, M.cwiseAbs().maxCoeff()))
    throw std::invalid_argument(std::string("TubeMPC Settings: ") + field + " is not symmetric");
}

}  // namespace

const char* to_string(InputCost c) { return core::enum_name(c); }
const char* to_string(QpSolver q) { return core::enum_name(q); }
const char* to_string(Linearization l) { return core::enum_name(l); }
const char* to_string(ScpMode m) { return core::enum_name(m); }

void Settings::validate(int nx, int nu) const {
  auto fail = [](const std::string& field, const std::string& what) {
    throw std::invalid_argument("TubeMPC Settings: " + field + " " + what);
  };
  if (nx <= 0 || nu <= 0) fail("(model)", "must have n_x > 0 and n_u > 0");
  if (horizon < 1) fail("horizon", "must be >= 1");
  if (!(dt > 0.0) || !std::isfinite(dt)) fail("dt", "must be finite and > 0 s");
  if (Q.size() != 0) {
    check_square_symmetric(Q, nx, "Q");
    if (Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Q).eigenvalues().minCoeff() < 0.0)
      fail("Q", "must be positive semidefinite");
  }
  if (R.size() != 0) {
    check_square_symmetric(R, nu, "R");
    if (!(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(R).eigenvalues().minCoeff() > 0.0))
      fail("R", "must be positive definite");
  }
  if (u_max.size() != nu) fail("u_max", "must have n_u = " + std::to_string(nu) + " entries");
  if (!u_max.allFinite() || (u_max.array() <= 0.0).any()) fail("u_max", "must be finite and > 0");
  if (!(scp_eps > 0.0)) fail("scp_eps", "must be > 0");
  if (scp_max_iterations < 1) fail("scp_max_iterations", "must be >= 1");
  if (!(trust_region > 0.0)) fail("trust_region", "must be > 0 (inf disables it)");
  if (!(qp_eps_abs > 0.0) || !std::isfinite(qp_eps_abs)) fail("qp_eps_abs", "must be finite and > 0");
  if (!(qp_eps_rel >= 0.0) || !std::isfinite(qp_eps_rel)) fail("qp_eps_rel", "must be finite and >= 0");
  if (qp_max_iterations < 1) fail("qp_max_iterations", "must be >= 1");
  if (!(qp_inaccurate_tol > 0.0)) fail("qp_inaccurate_tol", "must be > 0");
  if (!(time_limit > 0.0)) fail("time_limit", "must be > 0 s (inf disables it)");
  if (!(soft_penalty > 0.0) || !std::isfinite(soft_penalty)) fail("soft_penalty", "must be finite and > 0");
  if (!(riccati_tol > 0.0)) fail("riccati_tol", "must be > 0");
  if (A_structure.size() != 0 && (A_structure.rows() != nx || A_structure.cols() != nx))
    fail("A_structure", "must be empty or n_x x n_x");
  if (B_structure.size() != 0 && (B_structure.rows() != nx || B_structure.cols() != nu))
    fail("B_structure", "must be empty or n_x x n_u");
  if (G_structure.size() != 0 && G_structure.cols() != nx) fail("G_structure", "must be empty or n_c x n_x");
  if (riccati_max_iterations < 1) fail("riccati_max_iterations", "must be >= 1");
  if (active_set_max_iterations < 1) fail("active_set_max_iterations", "must be >= 1");
  if (!core::is_named(qp_solver)) fail("qp_solver", "is not a known QP solver");
  if (!core::is_named(linearization)) fail("linearization", "is not a known policy");
  if (!core::is_named(scp_mode)) fail("scp_mode", "is not a known mode");
  if (scp_mode == ScpMode::RealTime && linearization != Linearization::Reuse)
    fail("scp_mode", "real_time needs linearization = reuse (its next step re-linearises the moved nodes)");
  if (qp_preconditioner_iterations < 0) fail("qp_preconditioner_iterations", "must be >= 0");
  if (!(qp_reg_lower_limit > 0.0) || !std::isfinite(qp_reg_lower_limit))
    fail("qp_reg_lower_limit", "must be finite and > 0");
  if (!(qp_retry_reg_lower_limit >= 0.0) || !std::isfinite(qp_retry_reg_lower_limit))
    fail("qp_retry_reg_lower_limit", "must be finite and >= 0 (0: no retry)");
#ifndef PIQP_HAS_BLASFEO
  if (kkt_solver == KktSolver::SparseMultistage)
    fail("kkt_solver", "SparseMultistage needs PIQP built with BLASFEO, which this build is not");
#endif
}

}  // namespace tubempc::mpc
