// Tube MPC nominal problem: fixed-pattern sparse QP, SCP loop, fallbacks (see tube_mpc.hpp).
#include "tubempc/mpc/tube_mpc.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <piqp/piqp.hpp>
#include <stdexcept>
#include <vector>

#include "tubempc/dynamics/expm.hpp"

namespace tubempc::mpc {

namespace {

using SpMat = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Structural pattern of a block (true: stored entry, explicit zero or not).
using Mask = Eigen::Array<bool, Eigen::Dynamic, Eigen::Dynamic>;

Mask mask_dense(Eigen::Index m, Eigen::Index n) { return Mask::Constant(m, n, true); }
Mask mask_diagonal(Eigen::Index n) { return Eigen::MatrixXd::Identity(n, n).array() != 0.0; }
Mask mask_upper(Eigen::Index n) {
  return Eigen::MatrixXd::Ones(n, n).triangularView<Eigen::Upper>().toDenseMatrix().array() != 0.0;
}
Mask mask_lower(Eigen::Index n) {
  return Eigen::MatrixXd::Ones(n, n).triangularView<Eigen::Lower>().toDenseMatrix().array() != 0.0;
}
// Upper triangle of W's nonzeros plus the diagonal.
Mask mask_upper_of(const Eigen::MatrixXd& W) {
  return (W.array() != 0.0 || mask_diagonal(W.rows())) && mask_upper(W.rows());
}
// A user structure (entries != 0 structural; empty -> dense).
Mask mask_structure(const Eigen::MatrixXd& S, Eigen::Index m, Eigen::Index n) {
  return S.size() == 0 ? mask_dense(m, n) : Mask(S.array() != 0.0);
}

void add_block(std::vector<Eigen::Triplet<double, int>>& trip, int r0, int c0, const Mask& p) {
  for (int c = 0; c < p.cols(); ++c)
    for (int r = 0; r < p.rows(); ++r)
      if (p(r, c)) trip.emplace_back(r0 + r, c0 + c, 1.0);
}

// Positions in M.valuePtr() of the block's entries, in column-major order of the block.
std::vector<int> block_positions(const SpMat& M, int r0, int c0, const Mask& p) {
  std::vector<int> pos;
  for (int c = 0; c < p.cols(); ++c) {
    const int* begin = M.innerIndexPtr() + M.outerIndexPtr()[c0 + c];
    const int* end = M.innerIndexPtr() + M.outerIndexPtr()[c0 + c + 1];
    for (int r = 0; r < p.rows(); ++r) {
      if (!p(r, c)) continue;
      const int* it = std::lower_bound(begin, end, r0 + r);
      if (it == end || *it != r0 + r) throw std::logic_error("TubeMPC: sparsity pattern lookup failed");
      pos.push_back(static_cast<int>(it - M.innerIndexPtr()));
    }
  }
  return pos;
}

// Writes scale * W's entries selected by the pattern into M's values at pos.
template <typename Derived>
void write_block(SpMat& M, const std::vector<int>& pos, const Eigen::MatrixBase<Derived>& W, double scale,
                 const Mask& p) {
  double* val = M.valuePtr();
  std::size_t k = 0;
  for (Eigen::Index c = 0; c < W.cols(); ++c)
    for (Eigen::Index r = 0; r < W.rows(); ++r)
      if (p(r, c)) val[pos[k++]] = scale * W(r, c);
}

void zero_block(SpMat& M, const std::vector<int>& pos) {
  for (int i : pos) M.valuePtr()[i] = 0.0;
}

// Zeroes row j of a block written with mask p.
void zero_block_row(SpMat& M, const std::vector<int>& pos, const Mask& p, Eigen::Index j) {
  std::size_t k = 0;
  for (Eigen::Index c = 0; c < p.cols(); ++c)
    for (Eigen::Index r = 0; r < p.rows(); ++r)
      if (p(r, c)) {
        if (r == j) M.valuePtr()[pos[k]] = 0.0;
        ++k;
      }
}

// True if W has a nonzero outside the structural pattern p.
bool outside_structure(const Eigen::MatrixXd& W, const Mask& p) {
  for (Eigen::Index c = 0; c < W.cols(); ++c)
    for (Eigen::Index r = 0; r < W.rows(); ++r)
      if (!p(r, c) && W(r, c) != 0.0) return true;
  return false;
}

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

const char* to_string(InputCost c) { return c == InputCost::Absolute ? "absolute" : "deviation"; }
const char* to_string(QpSolver q) { return q == QpSolver::Piqp ? "piqp" : "active_set"; }
const char* to_string(Linearization l) { return l == Linearization::Reuse ? "reuse" : "every_iteration"; }

std::string to_string(Status status) {
  switch (status) {
    case Status::Solved:
      return "solved";
    case Status::SolvedInaccurate:
      return "solved_inaccurate";
    case Status::MaxIterations:
      return "max_iterations";
    case Status::FallbackShiftedPlan:
      return "fallback_shifted_plan";
    case Status::FallbackSafeInput:
      return "fallback_safe_input";
    case Status::Infeasible:
      return "infeasible";
    case Status::NotSolved:
      return "not_solved";
    case Status::TimeLimit:
      return "time_limit";
    case Status::NumericalError:
      return "numerical_error";
    case Status::EmptyTightening:
      return "empty_tightening";
    case Status::ModelStructure:
      return "model_structure";
  }
  return "unknown";
}

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
  if (qp_solver != QpSolver::Piqp && qp_solver != QpSolver::ActiveSet)
    fail("qp_solver", "is not a known QP solver");
  if (linearization != Linearization::Reuse && linearization != Linearization::EveryIteration)
    fail("linearization", "is not a known policy");
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

Eigen::MatrixXd solve_dare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::MatrixXd& Q,
                           const Eigen::MatrixXd& R, double tol, int max_iterations) {
  const Eigen::Index n = A.rows();
  if (A.cols() != n || B.rows() != n || Q.rows() != n || Q.cols() != n || R.rows() != B.cols() ||
      R.cols() != B.cols())
    throw std::invalid_argument("solve_dare: inconsistent sizes of A, B, Q, R");
  if (!A.allFinite() || !B.allFinite() || !Q.allFinite() || !R.allFinite())
    throw std::invalid_argument("solve_dare: non-finite entries in A, B, Q or R");
  Eigen::LLT<Eigen::MatrixXd> llt_R(R);
  if (llt_R.info() != Eigen::Success) throw std::invalid_argument("solve_dare: R is not positive definite");
  // Structured doubling (Chu, Fan, Lin 2005): A_k, G_k, H_k with H_k -> X quadratically.
  Eigen::MatrixXd Ak = A;
  Eigen::MatrixXd Gk = B * llt_R.solve(B.transpose());
  Eigen::MatrixXd Hk = Q;
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  for (int it = 0; it < max_iterations; ++it) {
    Eigen::PartialPivLU<Eigen::MatrixXd> lu(I + Gk * Hk);
    if (!(std::abs(lu.determinant()) > 0.0) || !std::isfinite(lu.determinant()))
      throw std::runtime_error("solve_dare: singular I + G H in the doubling iteration " +
                               std::to_string(it));
    const Eigen::MatrixXd W1 = lu.solve(Ak);  // (I + G H)^-1 A
    const Eigen::MatrixXd W2 = lu.solve(Gk);  // (I + G H)^-1 G
    const Eigen::MatrixXd H_next = Hk + Ak.transpose() * Hk * W1;
    Gk = Gk + Ak * W2 * Ak.transpose();
    Ak = Ak * W1;
    const double change = (H_next - Hk).cwiseAbs().maxCoeff();
    Hk = 0.5 * (H_next + H_next.transpose());
    if (!Hk.allFinite()) throw std::runtime_error("solve_dare: non-finite iterate");
    if (change <= tol * std::max(1.0, Hk.cwiseAbs().maxCoeff())) return Hk;
  }
  throw std::runtime_error("solve_dare: no convergence in " + std::to_string(max_iterations) +
                           " doubling iterations (is (A, B) stabilisable and (A, Q^1/2) detectable?)");
}

// ------------------------------------------------------------------------------------------------

struct TubeMPC::Impl {
  int nx = 0, nu = 0, nc = 0, N = 0, T = 0;
  Eigen::MatrixXd Q, R, P_term;
  Reference ref;

  // Layout of w.
  int n_var = 0, n_eq = 0, n_in = 0;
  int off_s = -1, off_sigma = -1, off_t = -1;
  int iz(int i) const { return i < N ? i * (nx + nu) : N * (nx + nu); }
  int iv(int i) const { return i * (nx + nu) + nx; }

  // QP data (fixed pattern).
  SpMat P, A, G;
  Eigen::VectorXd q, b, h_l, h_u, x_l, x_u;
  double constant = 0.0;
  std::vector<std::vector<int>> posP_z, posA_A, posA_B, posG;
  std::vector<int> posA_L, posG_term;
  Mask mQ, mP, mR, mA, mB, mG, mL;  // posG_term: the soft-terminal rows' four diagonals

  piqp::SparseSolver<double> solver;
  // Active-set solver, its working set (G rows, then one entry per variable), the set-index map of
  // a one-node shift (as_shift[j]: entry of the previous step's set that guesses entry j),
  // the step whose final set as_set holds (-1: none) and which solver produced the last QP solution.
  ActiveSetQp active_set;
  Eigen::VectorXi as_set, as_prev, as_shift;
  int as_set_k = -1;
  bool last_qp_active_set = false;

  // Linearisation trajectory and per-node model data.
  Eigen::MatrixXd z_lin, v_lin;  // nx x (N+1), nu x N
  std::vector<Eigen::MatrixXd> Ad, Bd, Gc, Ad_prev, Bd_prev, Gc_prev;
  std::vector<Eigen::VectorXd> cd, hc, cd_prev, hc_prev;
  // Trajectory of the model data in Ad..hc, and (after a converged step) the step whose data they are
  // (lin_k, -1: none) with its horizon lin_n: Ad..cd hold nodes 0..lin_n-1, Gc, hc nodes 0..lin_n.
  Eigen::MatrixXd z_lin_at, v_lin_at;
  int lin_k = -1, lin_n = 0;
  // Nodes whose discretisation (N) and constraints (N + 1) the next linearisation evaluates.
  Eigen::Array<bool, Eigen::Dynamic, 1> eval_d, eval_c;
  bool have_plan = false;
  int plan_k = 0;                  // time index of z_plan's first node
  Eigen::MatrixXd z_plan, v_plan;  // last applied plan (for the shifted fallback)
  Eigen::MatrixXd z_ref;           // zbar_{min(k+i, T)}, i = 0..N: origin of the QP's state deviations
  Eigen::MatrixXd z_star, v_star;

  // Tube work.
  Eigen::LLT<Eigen::MatrixXd> llt;
  Eigen::MatrixXd Lc;
  Eigen::VectorXd tmp_nx, tmp_nu, u_tight, e;
  Eigen::VectorXd tight_row;  // per-constraint tightening at the current node

  StepResult result;

  void allocate(int nx_, int nu_, int nc_, const Settings& s) {
    nx = nx_;
    nu = nu_;
    nc = nc_;
    N = s.horizon;
    z_lin.setZero(nx, N + 1);
    v_lin.setZero(nu, N);
    z_plan = z_lin;
    v_plan = v_lin;
    z_lin_at = z_lin;
    v_lin_at = v_lin;
    lin_k = -1;
    eval_d.setConstant(N, true);
    eval_c.setConstant(N + 1, true);
    z_star = z_lin;
    z_ref = z_lin;
    v_star = v_lin;
    Ad.assign(N, Eigen::MatrixXd::Zero(nx, nx));
    Bd.assign(N, Eigen::MatrixXd::Zero(nx, nu));
    cd.assign(N, Eigen::VectorXd::Zero(nx));
    Gc.assign(N + 1, Eigen::MatrixXd::Zero(nc, nx));
    hc.assign(N + 1, Eigen::VectorXd::Zero(nc));
    Ad_prev = Ad;
    Bd_prev = Bd;
    cd_prev = cd;
    Gc_prev = Gc;
    hc_prev = hc;
    llt.compute(Eigen::MatrixXd::Identity(nx, nx));  // sizes the factor storage (and sets its state) at setup
    Lc.setZero(nx, nx);
    tmp_nx.setZero(nx);
    tmp_nu.setZero(nu);
    e.setZero(nx);
    u_tight.setZero(nu);
    tight_row.setZero(nc);
    result.u.setZero(nu);
    result.z.setZero(nx, N + 1);
    result.v.setZero(nu, N);
  }

  // The QP's fixed sparsity pattern and the positions of every block in it, set up once. Longer than
  // the other functions on purpose: one pass lays out the variables, the equality, inequality and
  // soft-terminal rows in the order their position tables assume; split, that order would be implicit.
  void build_pattern(const Settings& s) {
    const bool box_ic = s.initial_condition == InitialCondition::WhitenedBox;
    n_var = N * (nx + nu) + nx;
    if (box_ic) {
      off_s = n_var;
      n_var += nx;
    }
    if (s.soft_state_constraints && nc > 0) {
      off_sigma = n_var;
      n_var += (N + 1) * nc;
    }
    if (s.soft_terminal) {
      off_t = n_var;
      n_var += nx;
    }
    n_eq = (N + 1) * nx;
    n_in = (N + 1) * nc + (s.soft_terminal ? 2 * nx : 0);

    mQ = mask_upper_of(Q);
    mP = mask_upper_of(P_term);
    mR = mask_upper_of(R);
    mA = mask_structure(s.A_structure, nx, nx) || mask_diagonal(nx);  // frozen nodes write the identity
    mB = mask_structure(s.B_structure, nx, nu);
    mG = mask_structure(s.G_structure, nc, nx);
    const Mask dx = mask_diagonal(nx), dc = mask_diagonal(nc), lx = mask_lower(nx);
    std::vector<Eigen::Triplet<double, int>> tp, ta, tg;
    for (int i = 0; i <= N; ++i) add_block(tp, iz(i), iz(i), i < N ? mQ : mP);
    for (int i = 0; i < N; ++i) add_block(tp, iv(i), iv(i), mR);
    // ||t||^2 on the soft-terminal slacks: they are unique (t = 0) outside the shrinking phase, where
    // their rows are zero and their L1 cost is off; inside it the L1 term keeps the penalty exact.
    if (off_t >= 0) add_block(tp, off_t, off_t, dx);
    add_block(ta, 0, iz(0), dx);
    if (box_ic) add_block(ta, 0, off_s, lx);
    for (int i = 0; i < N; ++i) {
      const int r0 = (i + 1) * nx;
      add_block(ta, r0, iz(i + 1), dx);
      add_block(ta, r0, iz(i), mA);
      add_block(ta, r0, iv(i), mB);
    }
    for (int i = 0; i <= N; ++i) {
      add_block(tg, i * nc, iz(i), mG);
      if (off_sigma >= 0) add_block(tg, i * nc, off_sigma + i * nc, dc);
    }
    if (s.soft_terminal) {
      const int r0 = (N + 1) * nc;
      add_block(tg, r0, iz(N), dx);
      add_block(tg, r0, off_t, dx);
      add_block(tg, r0 + nx, iz(N), dx);
      add_block(tg, r0 + nx, off_t, dx);
    }
    P.resize(n_var, n_var);
    P.setFromTriplets(tp.begin(), tp.end());
    A.resize(n_eq, n_var);
    A.setFromTriplets(ta.begin(), ta.end());
    G.resize(n_in, n_var);
    G.setFromTriplets(tg.begin(), tg.end());
    P.makeCompressed();
    A.makeCompressed();
    G.makeCompressed();

    posP_z.clear();
    posA_A.clear();
    posA_B.clear();
    posG.clear();
    for (int i = 0; i <= N; ++i) posP_z.push_back(block_positions(P, iz(i), iz(i), i < N ? mQ : mP));
    const Eigen::MatrixXd Ix = Eigen::MatrixXd::Identity(nx, nx);
    for (int i = 0; i < N; ++i) {
      write_block(P, block_positions(P, iv(i), iv(i), mR), R, 2.0, mR);
      const int r0 = (i + 1) * nx;
      write_block(A, block_positions(A, r0, iz(i + 1), dx), Ix, 1.0, dx);
      posA_A.push_back(block_positions(A, r0, iz(i), mA));
      posA_B.push_back(block_positions(A, r0, iv(i), mB));
    }
    write_block(A, block_positions(A, 0, iz(0), dx), Ix, 1.0, dx);
    if (off_t >= 0) write_block(P, block_positions(P, off_t, off_t, dx), Ix, 2.0, dx);
    if (box_ic) posA_L = block_positions(A, 0, off_s, lx);
    for (int i = 0; i <= N; ++i) {
      posG.push_back(block_positions(G, i * nc, iz(i), mG));
      if (off_sigma >= 0)
        write_block(G, block_positions(G, i * nc, off_sigma + i * nc, dc), Eigen::MatrixXd::Identity(nc, nc),
                    -1.0, dc);
    }
    if (s.soft_terminal) {
      const int r0 = (N + 1) * nc;
      for (const auto& blk : {block_positions(G, r0, iz(N), dx), block_positions(G, r0, off_t, dx),
                              block_positions(G, r0 + nx, iz(N), dx), block_positions(G, r0 + nx, off_t, dx)})
        posG_term.insert(posG_term.end(), blk.begin(), blk.end());
    }
    q.setZero(n_var);
    b.setZero(n_eq);
    // Absent rows are zero rows with bounds [-1, 1] (what PIQP would do itself, with a message, for
    // rows whose two sides are infinite).
    h_l.setConstant(n_in, -1.0);
    h_u.setConstant(n_in, 1.0);
    x_l.setConstant(n_var, -kInf);
    x_u.setConstant(n_var, kInf);
  }

  // Active-set solver on the QP's pattern: the variables that may carry bounds are the inputs, s,
  // sigma, the states with a finite trust region and z_N with the hard terminal constraint.
  void setup_active_set(const Settings& s) {
    Eigen::Array<bool, Eigen::Dynamic, 1> boundable =
        Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(n_var, false);
    for (int i = 0; i < N; ++i) boundable.segment(iv(i), nu).setConstant(true);
    if (off_s >= 0) boundable.segment(off_s, nx).setConstant(true);
    if (off_sigma >= 0) boundable.segment(off_sigma, (N + 1) * nc).setConstant(true);
    for (int i = 1; i <= N && std::isfinite(s.trust_region); ++i)
      boundable.segment(iz(i), nx).setConstant(true);
    if (!s.soft_terminal) boundable.segment(iz(N), nx).setConstant(true);
    ActiveSetQp::Settings as;
    as.max_iterations = s.active_set_max_iterations;
    as.eps_abs = s.qp_eps_abs;
    as.eps_rel = s.qp_eps_rel;
    active_set.setup(P, A, G, boundable, as);
    as_set.setZero(n_in + n_var);
    as_prev = as_set;
    as_set_k = -1;
    // One-node shift: node i's rows and variables take node i + 1's (the last node keeps its own).
    as_shift.resize(n_in + n_var);
    for (int j = 0; j < n_in + n_var; ++j) as_shift(j) = j;
    for (int i = 0; i < N; ++i) {
      for (int c = 0; c < nc; ++c) as_shift(i * nc + c) = (i + 1) * nc + c;
      for (int r = 0; r < nx; ++r) as_shift(n_in + iz(i) + r) = n_in + iz(i + 1) + r;
      if (i + 1 < N)
        for (int r = 0; r < nu; ++r) as_shift(n_in + iv(i) + r) = n_in + iv(i + 1) + r;
      if (off_sigma >= 0)
        for (int c = 0; c < nc; ++c)
          as_shift(n_in + off_sigma + i * nc + c) = n_in + off_sigma + (i + 1) * nc + c;
    }
  }

  // PIQP on the current QP, with one retry at a higher regularisation floor (same data, same solver:
  // no allocation). Returns Solved, SolvedInaccurate (capped with small residuals) or the failure cause.
  Status solve_piqp(const Settings& s, StepResult& res, Clock::time_point t_start) {
    solver.update(P, q, A, b, G, h_l, h_u, x_l, x_u);
    piqp::Status qs = solver.solve();
    const auto& r = solver.result();
    res.qp_iterations += static_cast<int>(r.info.iter);
    const auto capped_inaccurate = [&] {
      return qs == piqp::Status::PIQP_MAX_ITER_REACHED && r.info.primal_res_rel <= s.qp_inaccurate_tol &&
             r.info.dual_res_rel <= s.qp_inaccurate_tol;
    };
    if ((qs == piqp::Status::PIQP_NUMERICS ||
         (qs == piqp::Status::PIQP_MAX_ITER_REACHED && !capped_inaccurate())) &&
        s.qp_retry_reg_lower_limit > 0.0 && seconds_since(t_start) < s.time_limit) {
      piqp::Settings<double>& ps = solver.settings();
      ps.reg_lower_limit = s.qp_retry_reg_lower_limit;
      qs = solver.solve();
      ps.reg_lower_limit = s.qp_reg_lower_limit;
      res.qp_iterations += static_cast<int>(r.info.iter);
    }
    if (qs == piqp::Status::PIQP_INVALID_SETTINGS) return Status::NotSolved;
    if (qs == piqp::Status::PIQP_PRIMAL_INFEASIBLE || qs == piqp::Status::PIQP_DUAL_INFEASIBLE)
      return Status::Infeasible;
    Status out = Status::Solved;
    if (capped_inaccurate())
      out = Status::SolvedInaccurate;
    else if (qs != piqp::Status::PIQP_SOLVED)
      return qs == piqp::Status::PIQP_NUMERICS ? Status::NumericalError : Status::NotSolved;
    active_set_from_piqp();
    return out;
  }

  // Active set read off PIQP's multipliers (the warm start of the next QP after a PIQP solve).
  void active_set_from_piqp() {
    const auto& r = solver.result();
    const double scale = std::max({1.0, r.z_l.lpNorm<Eigen::Infinity>(), r.z_u.lpNorm<Eigen::Infinity>(),
                                   r.z_bl.lpNorm<Eigen::Infinity>(), r.z_bu.lpNorm<Eigen::Infinity>()});
    const double tol = 1e-6 * scale;
    for (int i = 0; i < n_in; ++i) as_set(i) = r.z_u(i) > tol ? 1 : (r.z_l(i) > tol ? -1 : 0);
    for (int j = 0; j < n_var; ++j) as_set(n_in + j) = r.z_bu(j) > tol ? 1 : (r.z_bl(j) > tol ? -1 : 0);
  }
};

TubeMPC::TubeMPC(std::shared_ptr<const LinearizedModel> model, Settings settings)
    : model_(std::move(model)), settings_(std::move(settings)), impl_(std::make_unique<Impl>()) {
  if (!model_) throw std::invalid_argument("TubeMPC: model is null");
  const int nx = model_->nx(), nu = model_->nu();
  settings_.validate(nx, nu);
  if (model_->n_constraints() < 0) throw std::invalid_argument("TubeMPC: model n_constraints() < 0");
  if (settings_.G_structure.size() != 0 && settings_.G_structure.rows() != model_->n_constraints())
    throw std::invalid_argument("TubeMPC Settings: G_structure must have n_constraints() rows");
  if (settings_.Q.size() == 0) settings_.Q = Eigen::MatrixXd::Identity(nx, nx);
  if (settings_.R.size() == 0) settings_.R = Eigen::MatrixXd::Identity(nu, nu);
}

TubeMPC::~TubeMPC() = default;

const Eigen::MatrixXd& TubeMPC::terminal_weight() const { return impl_->P_term; }
int TubeMPC::mission_steps() const { return impl_->T; }
Eigen::Vector3i TubeMPC::qp_dimensions() const { return {impl_->n_var, impl_->n_eq, impl_->n_in}; }

void TubeMPC::setup(const Reference& reference) {
  const int nx = model_->nx(), nu = model_->nu();
  if (reference.u.cols() < 1 || reference.z.rows() != nx || reference.u.rows() != nu ||
      reference.z.cols() != reference.u.cols() + 1)
    throw std::invalid_argument(
        "TubeMPC::setup: reference.z must be n_x x (T + 1) and reference.u n_u x T, T >= 1");
  const int T = static_cast<int>(reference.u.cols());
  Eigen::MatrixXd A(nx, nx), B(nx, nu);
  Eigen::VectorXd c(nx);
  model_->discretize(reference.t0 + T * settings_.dt, settings_.dt, reference.z.col(T),
                     reference.u.col(T - 1), A, B, c);
  setup(reference, A, B);
}

void TubeMPC::setup(const Reference& reference, const Eigen::MatrixXd& A_terminal,
                    const Eigen::MatrixXd& B_terminal) {
  const int nx = model_->nx(), nu = model_->nu(), nc = model_->n_constraints();
  if (reference.u.cols() < 1 || reference.z.rows() != nx || reference.u.rows() != nu ||
      reference.z.cols() != reference.u.cols() + 1)
    throw std::invalid_argument(
        "TubeMPC::setup: reference.z must be n_x x (T + 1) and reference.u n_u x T, T >= 1");
  if (!reference.z.allFinite() || !reference.u.allFinite() || !std::isfinite(reference.t0))
    throw std::invalid_argument("TubeMPC::setup: reference has non-finite entries");
  if (A_terminal.rows() != nx || A_terminal.cols() != nx || B_terminal.rows() != nx ||
      B_terminal.cols() != nu)
    throw std::invalid_argument("TubeMPC::setup: A_terminal must be n_x x n_x and B_terminal n_x x n_u");
  impl_ = std::make_unique<Impl>();
  Impl& m = *impl_;
  m.Q = settings_.Q;
  m.R = settings_.R;
  m.P_term =
      solve_dare(A_terminal, B_terminal, m.Q, m.R, settings_.riccati_tol, settings_.riccati_max_iterations);
  m.ref = reference;
  m.T = static_cast<int>(reference.u.cols());
  m.allocate(nx, nu, nc, settings_);
  m.mL = mask_lower(nx);
  m.build_pattern(settings_);
  piqp::Settings<double>& ps = m.solver.settings();
  ps.eps_abs = settings_.qp_eps_abs;
  ps.eps_rel = settings_.qp_eps_rel;
  ps.eps_duality_gap_abs = settings_.qp_eps_abs;
  ps.eps_duality_gap_rel = settings_.qp_eps_rel;
  ps.max_iter = settings_.qp_max_iterations;
  ps.kkt_solver = settings_.kkt_solver == KktSolver::SparseMultistage ? piqp::KKTSolver::sparse_multistage
                                                                      : piqp::KKTSolver::sparse_ldlt;
  ps.compute_timings = false;
  ps.reg_lower_limit = settings_.qp_reg_lower_limit;
  ps.preconditioner_scale_cost = settings_.qp_scale_cost;
  ps.preconditioner_iter = settings_.qp_preconditioner_iterations;
  m.solver.setup(m.P, m.q, m.A, m.b, m.G, m.h_l, m.h_u, m.x_l, m.x_u);
  m.setup_active_set(settings_);
}

void TubeMPC::reset() {
  impl_->have_plan = false;
  impl_->lin_k = -1;
  impl_->as_set_k = -1;
}

QpData TubeMPC::qp_data() const {
  const Impl& m = *impl_;
  QpData d;
  const SpMat Pu = m.P;
  d.P = Pu.selfadjointView<Eigen::Upper>();
  d.q = m.q;
  d.A = m.A;
  d.b = m.b;
  d.G = m.G;
  d.h_l = m.h_l;
  d.h_u = m.h_u;
  d.x_l = m.x_l;
  d.x_u = m.x_u;
  d.constant = m.constant;
  return d;
}

QpSolution TubeMPC::qp_solution() const {
  const ActiveSetQp& as = impl_->active_set;
  if (impl_->last_qp_active_set) return QpSolution{as.w(), as.y(), as.z_l(), as.z_u(), as.z_bl(), as.z_bu()};
  const auto& r = impl_->solver.result();
  return QpSolution{r.x, r.y, r.z_l, r.z_u, r.z_bl, r.z_bu};
}

// The phases of TubeMPC::step, in order; each works on the controller's preallocated state (Impl) and
// the step's constants (StepContext). None allocates after setup (tests/cpp/mpc_alloc).
struct TubeMPC::StepContext {
  const Settings& s;
  const LinearizedModel& model;
  const Eigen::Ref<const Eigen::VectorXd>& x_k;
  const Tube& tube;
  Clock::time_point t_start;
  int k = 0;
  int n = 0;  // nodes of this step's horizon, min(N, T - k)
  bool terminal_phase = false;
  int shift = 0;          // steps since the last plan
  bool use_plan = false;  // that plan seeds the linearisation (and the shifted fallback)
  int n_reuse_d = 0;      // nodes whose discretisation is re-used from the previous step
  int n_reuse_z = 0;      // nodes whose linearisation state and constraints are re-used
  // Time of node i: a function of the absolute node index, so that re-used model data are exact.
  double t_node(double t0, int i) const { return t0 + static_cast<double>(k + i) * s.dt; }
};

// Phase 1: re-use the previous converged step's model data shifted by one node
// (Settings::linearization) and shift its final active set as the first QP's guess.
void TubeMPC::shift_warm_start(StepContext& c) {
  Impl& m = *impl_;
  if (c.s.linearization == Linearization::Reuse && m.lin_k >= 0 && c.k == m.lin_k + 1) {
    c.n_reuse_z = std::min(c.n + 1, m.lin_n);
    c.n_reuse_d = std::min(c.n, m.lin_n - 1);
    std::rotate(m.Ad.begin(), m.Ad.begin() + 1, m.Ad.end());  // swaps: no allocation
    std::rotate(m.Bd.begin(), m.Bd.begin() + 1, m.Bd.end());
    std::rotate(m.cd.begin(), m.cd.begin() + 1, m.cd.end());
    std::rotate(m.Gc.begin(), m.Gc.begin() + 1, m.Gc.end());
    std::rotate(m.hc.begin(), m.hc.begin() + 1, m.hc.end());
  }
  m.lin_k = -1;  // valid again only if this step converges
  if (m.as_set_k == c.k - 1) {
    m.as_prev = m.as_set;
    for (int j = 0; j < m.as_set.size(); ++j) m.as_set(j) = m.as_prev(m.as_shift(j));
  } else {
    m.as_set.setZero();
  }
  m.as_set_k = -1;  // valid again only if this step returns a plan
  for (int i = 0; i < m.N; ++i) m.eval_d(i) = i >= c.n_reuse_d;
  for (int i = 0; i <= m.N; ++i) m.eval_c(i) = i >= c.n_reuse_z;
}

// Phase 2: the linearisation trajectory: the previous plan shifted to k (usually by one node),
// completed from the reference; the reference alone without a usable plan. Nodes with re-used data
// take the trajectory those data were computed about.
void TubeMPC::seed_linearization(StepContext& c) {
  Impl& m = *impl_;
  const int N = m.N, T = m.T, k = c.k;
  c.shift = k - m.plan_k;
  c.use_plan = m.have_plan && c.shift >= 0 && c.shift < N;
  for (int i = 0; i <= N; ++i) {
    if (i < c.n_reuse_z)
      m.z_lin.col(i) = m.z_lin_at.col(i + 1);
    else
      m.z_lin.col(i) =
          c.use_plan && i + c.shift <= N ? m.z_plan.col(i + c.shift) : m.ref.z.col(std::min(k + i, T));
  }
  for (int i = 0; i < N; ++i) {
    if (i < c.n_reuse_d)
      m.v_lin.col(i) = m.v_lin_at.col(i + 1);
    else
      m.v_lin.col(i) =
          c.use_plan && i + c.shift < N ? m.v_plan.col(i + c.shift) : m.ref.u.col(std::min(k + i, T - 1));
  }
}

// The step's outcome when no new plan is applied: Theorem 1's candidate (the previous plan shifted to
// k, holding its last state, zero inputs appended (u_ref with InputCost::Deviation)) or the
// reference; the ancillary law on it, saturated and never non-finite.
const StepResult& TubeMPC::fallback(const StepContext& c, Status cause) {
  Impl& m = *impl_;
  StepResult& res = m.result;
  const Settings& s = c.s;
  const int N = m.N, T = m.T, k = c.k;
  res.failure = cause;
  if (c.use_plan && m.z_plan.allFinite() && m.v_plan.allFinite()) {
    for (int i = 0; i <= N; ++i) res.z.col(i) = m.z_plan.col(std::min(i + c.shift, N));
    for (int i = 0; i < N; ++i) {
      if (i + c.shift < N)
        res.v.col(i) = m.v_plan.col(i + c.shift);
      else if (s.input_cost == InputCost::Deviation && k + i < T)
        res.v.col(i) = m.ref.u.col(k + i);
      else
        res.v.col(i).setZero();
    }
    m.z_plan = res.z;
    m.v_plan = res.v;
    m.plan_k = k;
    res.status = Status::FallbackShiftedPlan;
  } else {
    for (int i = 0; i <= N; ++i) res.z.col(i) = m.ref.z.col(std::min(k + i, T));
    for (int i = 0; i < N; ++i) res.v.col(i) = m.ref.u.col(std::min(k + i, T - 1));
    res.status = Status::FallbackSafeInput;
  }
  m.e = c.x_k - res.z.col(0);
  res.u = res.v.col(0);
  if (c.tube.K.allFinite() && m.e.allFinite()) res.u.noalias() += c.tube.K * m.e;
  if (!res.u.allFinite()) res.u = m.ref.u.col(k);
  res.u = res.u.cwiseMax(-s.u_max).cwiseMin(s.u_max);
  res.objective = kInf;
  res.timings.total = seconds_since(c.t_start);
  return res;
}

// Phase 3: the tube's factor Pe = L L^T and the input tightenings sqrt(K_i Pe K_i^T).
Status TubeMPC::tighten(const StepContext& c) {
  Impl& m = *impl_;
  const Tube& tube = c.tube;
  if (!c.x_k.allFinite() || !tube.K.allFinite() || !tube.Pe.allFinite()) return Status::NumericalError;
  m.llt.compute(tube.Pe);
  if (m.llt.info() != Eigen::Success) return Status::NumericalError;
  m.Lc = m.llt.matrixL();
  for (int j = 0; j < m.nu; ++j) {
    m.tmp_nx.noalias() = tube.Pe * tube.K.row(j).transpose();
    m.u_tight(j) = c.s.u_max(j) - std::sqrt(std::max(0.0, tube.K.row(j).dot(m.tmp_nx)));
  }
  return (m.u_tight.array() <= 0.0).any() ? Status::EmptyTightening : Status::Solved;
}

// Phase 4: the parts of the QP that do not depend on the linearisation: the initial condition, the
// input box and input cost, the state costs and the soft-constraint and soft-terminal rows. The
// QP's state variables are the deviations dz_i = z_i - zbar_{min(k+i, T)}: the objective then
// carries no large constant, which keeps the solvers' relative tolerances meaningful for states of
// hundreds of metres.
void TubeMPC::write_cost(const StepContext& c) {
  Impl& m = *impl_;
  const Settings& s = c.s;
  const int nx = m.nx, nu = m.nu, nc = m.nc, N = m.N, T = m.T, k = c.k, n = c.n;
  for (int i = 0; i <= N; ++i) m.z_ref.col(i) = m.ref.z.col(std::min(k + i, T));
  m.constant = 0.0;
  m.b.head(nx) = c.x_k - m.z_ref.col(0);
  if (s.initial_condition == InitialCondition::WhitenedBox) {
    write_block(m.A, m.posA_L, m.Lc, -1.0, m.mL);
    const double r = 1.0 / std::sqrt(static_cast<double>(nx));
    m.x_l.segment(m.off_s, nx).setConstant(-r);
    m.x_u.segment(m.off_s, nx).setConstant(r);
  }
  for (int i = 0; i < N; ++i) {
    m.x_l.segment(m.iv(i), nu) = -m.u_tight;
    m.x_u.segment(m.iv(i), nu) = m.u_tight;
    if (s.input_cost == InputCost::Deviation && i < n) {
      m.tmp_nu.noalias() = m.R * m.ref.u.col(k + i);
      m.q.segment(m.iv(i), nu) = -2.0 * m.tmp_nu;
      m.constant += m.ref.u.col(k + i).dot(m.tmp_nu);
    } else {
      m.q.segment(m.iv(i), nu).setZero();
    }
  }
  for (int i = 0; i <= N; ++i) {
    const bool staged = i < n;
    const bool terminal_cost = i == N && !c.terminal_phase;
    const bool soft_end = i == N && c.terminal_phase && s.soft_terminal;
    // Stage, terminal (zbar_{k+N}, W = P_term) and soft-end (zbar_T = x_f, W = Q) costs are all
    // ||dz_i||^2_W. The soft end takes Q: the exact penalty already holds z_N at x_f, and P_term's
    // rate entries (~1e8) would only worsen the KKT conditioning there.
    if (staged || terminal_cost || soft_end)
      write_block(m.P, m.posP_z[i], terminal_cost ? m.P_term : m.Q, 2.0, i < N ? m.mQ : m.mP);
    else
      zero_block(m.P, m.posP_z[i]);
    m.q.segment(m.iz(i), nx).setZero();
  }
  if (m.off_sigma >= 0) {
    m.q.segment(m.off_sigma, (N + 1) * nc).setConstant(s.soft_penalty);
    m.x_l.segment(m.off_sigma, (N + 1) * nc).setZero();
  }
  if (m.off_t >= 0) {
    const int r0 = (N + 1) * nc;
    m.q.segment(m.off_t, nx).setConstant(c.terminal_phase ? s.soft_penalty : 0.0);
    m.x_l.segment(m.off_t, nx).setConstant(-kInf);  // t >= 0 follows from |dz_N| <= t: no redundant bound
    const double sign[4] = {1.0, -1.0, 1.0, 1.0};   // dz_N - t <= 0, dz_N + t >= 0 (zbar_T = x_f)
    for (int blk = 0; blk < 4; ++blk)
      for (int j = 0; j < nx; ++j)
        m.G.valuePtr()[m.posG_term[blk * nx + j]] = c.terminal_phase ? sign[blk] : 0.0;
    if (c.terminal_phase) {
      m.h_l.segment(r0, nx).setConstant(-kInf);
      m.h_u.segment(r0, nx).setZero();
      m.h_l.segment(r0 + nx, nx).setZero();
      m.h_u.segment(r0 + nx, nx).setConstant(kInf);
    } else {
      m.h_l.segment(r0, 2 * nx).setConstant(-1.0);
      m.h_u.segment(r0, 2 * nx).setConstant(1.0);
    }
  }
}

// Phase 5a: linearise about (z_lin, v_lin) the nodes marked for evaluation (the first SCP iteration
// keeps the re-used nodes' data); NumericalError or ModelStructure when the data cannot be used.
Status TubeMPC::linearize(const StepContext& c, int it) {
  Impl& m = *impl_;
  StepResult& res = m.result;
  const int nc = m.nc, n = c.n;
  const double dt = c.s.dt;
  bool finite = true;
  for (int i = 0; i < n; ++i) {
    if (!m.eval_d(i)) continue;
    if (it > 0)  // the node holds data about (z_lin_at, v_lin_at) for the same time: the model may keep parts
      c.model.rediscretize(c.t_node(m.ref.t0, i), dt, m.z_lin_at.col(i), m.v_lin_at.col(i), m.z_lin.col(i),
                           m.v_lin.col(i), m.Ad[i], m.Bd[i], m.cd[i]);
    else
      c.model.discretize(c.t_node(m.ref.t0, i), dt, m.z_lin.col(i), m.v_lin.col(i), m.Ad[i], m.Bd[i],
                         m.cd[i]);
    finite = finite && m.Ad[i].allFinite() && m.Bd[i].allFinite() && m.cd[i].allFinite();
    ++res.model_evaluations;
  }
  for (int i = 0; i <= n; ++i) {
    if (nc == 0) break;
    if (!m.eval_c(i)) continue;
    c.model.constraints(c.t_node(m.ref.t0, i), m.z_lin.col(i), m.Gc[i], m.hc[i]);
    finite =
        finite && m.Gc[i].allFinite() && !m.hc[i].array().isNaN().any() && !(m.hc[i].array() == -kInf).any();
  }
  m.z_lin_at = m.z_lin;
  m.v_lin_at = m.v_lin;
  if (!finite) return Status::NumericalError;
  bool structured = true;
  for (int i = 0; i < n; ++i)
    structured = structured && !outside_structure(m.Ad[i], m.mA) && !outside_structure(m.Bd[i], m.mB);
  for (int i = 0; i <= n && nc > 0; ++i) structured = structured && !outside_structure(m.Gc[i], m.mG);
  return structured ? Status::Solved : Status::ModelStructure;
}

// Phase 5b: whether the model data equal the previous QP's (then, with its trust region inactive,
// the QP about the new nominal has the same minimiser: converged without solving it again); keeps
// the data for the next comparison.
bool TubeMPC::same_model_data(const StepContext& c, int it, double last_delta) {
  Impl& m = *impl_;
  const int nc = m.nc, n = c.n;
  bool same = it > 0 && last_delta < c.s.trust_region;
  for (int i = 0; i < n && same; ++i)
    same = m.Ad[i] == m.Ad_prev[i] && m.Bd[i] == m.Bd_prev[i] && m.cd[i] == m.cd_prev[i];
  for (int i = 0; i <= n && same && nc > 0; ++i) same = m.Gc[i] == m.Gc_prev[i] && m.hc[i] == m.hc_prev[i];
  if (same) return true;
  for (int i = 0; i < n; ++i) {
    m.Ad_prev[i] = m.Ad[i];
    m.Bd_prev[i] = m.Bd[i];
    m.cd_prev[i] = m.cd[i];
  }
  for (int i = 0; i <= n && nc > 0; ++i) {
    m.Gc_prev[i] = m.Gc[i];
    m.hc_prev[i] = m.hc[i];
  }
  return false;
}

// Phase 5c: the linearisation-dependent QP values: dynamics rows, tightened state constraints
// (sqrt(a^T Pe a)), the SCP trust region and the hard terminal equality.
void TubeMPC::write_constraints(const StepContext& c) {
  Impl& m = *impl_;
  const Settings& s = c.s;
  const Eigen::MatrixXd& Pe = c.tube.Pe;
  const int nx = m.nx, nc = m.nc, N = m.N, n = c.n;
  for (int i = 0; i < N; ++i) {
    const int r0 = (i + 1) * nx;
    if (i < n) {
      write_block(m.A, m.posA_A[i], m.Ad[i], -1.0, m.mA);
      write_block(m.A, m.posA_B[i], m.Bd[i], -1.0, m.mB);
      // dz_{i+1} - A dz_i - B v_i = c + A zbar_i - zbar_{i+1}
      m.tmp_nx.noalias() = m.Ad[i] * m.z_ref.col(i);
      m.b.segment(r0, nx) = m.cd[i] + m.tmp_nx - m.z_ref.col(i + 1);
    } else {  // frozen node: z_{i+1} = z_i, input without effect
      write_block(m.A, m.posA_A[i], Eigen::MatrixXd::Identity(nx, nx), -1.0, m.mA);
      zero_block(m.A, m.posA_B[i]);
      m.b.segment(r0, nx) = m.z_ref.col(i) - m.z_ref.col(i + 1);
    }
  }
  for (int i = 0; i <= N; ++i) {
    if (nc == 0) break;
    if (i <= n) {
      write_block(m.G, m.posG[i], m.Gc[i], 1.0, m.mG);
      for (int j = 0; j < nc; ++j) {
        const int row = i * nc + j;
        if (std::isfinite(m.hc[i](j))) {
          m.tmp_nx.noalias() = Pe * m.Gc[i].row(j).transpose();
          m.h_l(row) = -kInf;
          m.h_u(row) = m.hc[i](j) - std::sqrt(std::max(0.0, m.Gc[i].row(j).dot(m.tmp_nx))) -
                       m.Gc[i].row(j).dot(m.z_ref.col(i));
        } else {  // the model marks the row absent
          zero_block_row(m.G, m.posG[i], m.mG, j);
          m.h_l(row) = -1.0;
          m.h_u(row) = 1.0;
        }
      }
    } else {
      zero_block(m.G, m.posG[i]);
      m.h_l.segment(i * nc, nc).setConstant(-1.0);
      m.h_u.segment(i * nc, nc).setConstant(1.0);
    }
  }
  for (int i = 1; i <= N; ++i) {
    if (i <= n && std::isfinite(s.trust_region)) {
      m.x_l.segment(m.iz(i), nx).array() = (m.z_lin.col(i) - m.z_ref.col(i)).array() - s.trust_region;
      m.x_u.segment(m.iz(i), nx).array() = (m.z_lin.col(i) - m.z_ref.col(i)).array() + s.trust_region;
    } else {
      m.x_l.segment(m.iz(i), nx).setConstant(-kInf);
      m.x_u.segment(m.iz(i), nx).setConstant(kInf);
    }
  }
  if (c.terminal_phase && !s.soft_terminal) {  // z_N = x_f = zbar_T
    m.x_l.segment(m.iz(N), nx).setZero();
    m.x_u.segment(m.iz(N), nx).setZero();
  }
}

// Phase 6: solve the QP: the active set warm-started from the last QP's set, then once more from the
// empty set if that guess led it astray (it can make dependent rows active); PIQP if neither verifies.
Status TubeMPC::solve_with_retry(const StepContext& c) {
  Impl& m = *impl_;
  StepResult& res = m.result;
  m.last_qp_active_set = false;
  if (c.s.qp_solver == QpSolver::ActiveSet) {
    const bool warm = (m.as_set.array() != 0).any();
    for (int attempt = 0; attempt < (warm ? 2 : 1) && !m.last_qp_active_set; ++attempt) {
      if (attempt == 1) m.as_set.setZero();
      m.last_qp_active_set = m.active_set.solve(m.P, m.q, m.A, m.b, m.G, m.h_l, m.h_u, m.x_l, m.x_u,
                                                m.as_set) == ActiveSetQp::Status::Solved;
      res.active_set_iterations += m.active_set.info().iterations;
    }
    if (m.last_qp_active_set) ++res.active_set_solves;
  }
  return m.last_qp_active_set ? Status::Solved : m.solve_piqp(c.s, res, c.t_start);
}

// Phase 7: the QP's plan, its largest move from the linearisation (the SCP residual) and the next
// linearisation point. With Linearization::Reuse, a node whose plan moved less than scp_eps (it
// already meets the convergence test) keeps its model data and their point; the others are
// linearised about the new plan.
double TubeMPC::update_plan(const StepContext& c, const Eigen::VectorXd& x_qp) {
  Impl& m = *impl_;
  const Settings& s = c.s;
  const int nx = m.nx, nu = m.nu, N = m.N, n = c.n;
  double delta = 0.0;
  for (int i = 0; i <= N; ++i) {
    m.z_star.col(i) = x_qp.segment(m.iz(i), nx) + m.z_ref.col(i);
    if (i <= n) delta = std::max(delta, (m.z_star.col(i) - m.z_lin.col(i)).cwiseAbs().maxCoeff());
  }
  for (int i = 0; i < N; ++i) m.v_star.col(i) = x_qp.segment(m.iv(i), nu);
  for (int i = 0; i <= N; ++i) {
    const bool moved = s.linearization != Linearization::Reuse || i > n ||
                       (m.z_star.col(i) - m.z_lin.col(i)).cwiseAbs().maxCoeff() >= s.scp_eps;
    m.eval_c(i) = moved;
    if (i < N) m.eval_d(i) = moved;
    if (!moved) continue;
    m.z_lin.col(i) = m.z_star.col(i);
    if (i < N) m.v_lin.col(i) = m.v_star.col(i);
  }
  return delta;
}

// Phase 8: apply the plan: the ancillary law u = v_0 + K (x_k - z_0), saturated; keep the plan and
// (when converged) the model data for the next step.
const StepResult& TubeMPC::finish(const StepContext& c, bool converged, bool inaccurate) {
  Impl& m = *impl_;
  StepResult& res = m.result;
  res.z = m.z_star;
  res.v = m.v_star;
  m.z_plan = m.z_star;
  m.v_plan = m.v_star;
  m.have_plan = true;
  m.plan_k = c.k;
  m.e = c.x_k - res.z.col(0);
  res.u = res.v.col(0);
  res.u.noalias() += c.tube.K * m.e;
  res.u = res.u.cwiseMax(-c.s.u_max).cwiseMin(c.s.u_max);
  res.status = !converged ? Status::MaxIterations : (inaccurate ? Status::SolvedInaccurate : Status::Solved);
  if (!res.u.allFinite()) return fallback(c, Status::NumericalError);
  if (converged) {
    m.lin_k = c.k;
    m.lin_n = c.n;
  }
  m.as_set_k = c.k;
  res.timings.total = seconds_since(c.t_start);
  return res;
}

const StepResult& TubeMPC::step(int k, const Eigen::Ref<const Eigen::VectorXd>& x_k, const Tube& tube) {
  Impl& m = *impl_;
  const Settings& s = settings_;
  if (m.T == 0) throw std::invalid_argument("TubeMPC::step: call setup first");
  if (k < 0 || k >= m.T) throw std::invalid_argument("TubeMPC::step: k must be in [0, T)");
  if (x_k.size() != m.nx) throw std::invalid_argument("TubeMPC::step: x_k must have n_x entries");
  if (tube.K.rows() != m.nu || tube.K.cols() != m.nx || tube.Pe.rows() != m.nx || tube.Pe.cols() != m.nx)
    throw std::invalid_argument("TubeMPC::step: tube.K must be n_u x n_x and tube.Pe n_x x n_x");

  StepContext c{s, *model_, x_k, tube, Clock::now()};
  c.k = k;
  c.n = std::min(m.N, m.T - k);
  c.terminal_phase = k >= m.T - m.N;
  StepResult& res = m.result;
  res.timings = Timings{};
  res.scp_iterations = 0;
  res.qp_iterations = 0;
  res.active_set_solves = 0;
  res.active_set_iterations = 0;
  res.model_evaluations = 0;
  res.scp_residual = kInf;
  res.failure = Status::Solved;
  res.horizon = c.n;

  shift_warm_start(c);
  seed_linearization(c);
  if (const Status st = tighten(c); st != Status::Solved) return fallback(c, st);
  write_cost(c);

  // Sequential convex programming (Algorithm 1): linearise, write, solve, until the plan moves less
  // than scp_eps.
  bool converged = false;
  bool inaccurate = false;
  double last_delta = kInf;
  for (int it = 0; it < s.scp_max_iterations; ++it) {
    if (it > 0 && seconds_since(c.t_start) > s.time_limit) return fallback(c, Status::TimeLimit);
    auto t0 = Clock::now();
    const Status lin = linearize(c, it);
    res.timings.linearize += seconds_since(t0);
    if (lin != Status::Solved) return fallback(c, lin);
    if (same_model_data(c, it, last_delta)) {
      res.scp_residual = 0.0;
      converged = true;
      break;
    }
    t0 = Clock::now();
    write_constraints(c);
    res.timings.build += seconds_since(t0);
    t0 = Clock::now();
    const Status qp_status = solve_with_retry(c);
    res.timings.solve += seconds_since(t0);
    res.scp_iterations = it + 1;
    if (qp_status == Status::SolvedInaccurate)
      inaccurate = true;
    else if (qp_status != Status::Solved)
      return fallback(c, qp_status);
    const Eigen::VectorXd& x_qp = m.last_qp_active_set ? m.active_set.w() : m.solver.result().x;
    if (!x_qp.allFinite()) return fallback(c, Status::NumericalError);
    if (seconds_since(c.t_start) > s.time_limit) return fallback(c, Status::TimeLimit);
    const double delta = update_plan(c, x_qp);
    res.scp_residual = delta;
    last_delta = delta;
    res.objective =
        (m.last_qp_active_set ? m.active_set.objective() : m.solver.result().info.primal_obj) + m.constant;
    if (delta < s.scp_eps) {
      converged = true;
      break;
    }
  }
  return finish(c, converged, inaccurate);
}

}  // namespace tubempc::mpc
