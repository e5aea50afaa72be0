// The tube MPC's QP layout and fixed sparsity pattern (see qp_layout.hpp).
#include "qp_layout.hpp"

#include <algorithm>
#include <cmath>

namespace tubempc::mpc::detail {

QpLayout::QpLayout(int nx_, int nu_, int nc_, int N_, const Settings& s) : nx(nx_), nu(nu_), nc(nc_), N(N_) {
  n_var = N * (nx + nu) + nx;
  if (s.initial_condition == InitialCondition::WhitenedBox) {
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
}

Eigen::Array<bool, Eigen::Dynamic, 1> QpLayout::boundable(const Settings& s) const {
  Eigen::Array<bool, Eigen::Dynamic, 1> b = Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(n_var, false);
  for (int i = 0; i < N; ++i) b.segment(iv(i), nu).setConstant(true);
  if (off_s >= 0) b.segment(off_s, nx).setConstant(true);
  if (off_sigma >= 0) b.segment(off_sigma, (N + 1) * nc).setConstant(true);
  for (int i = 1; i <= N && std::isfinite(s.trust_region); ++i) b.segment(iz(i), nx).setConstant(true);
  if (!s.soft_terminal) b.segment(iz(N), nx).setConstant(true);
  return b;
}

Eigen::VectorXi QpLayout::shift_map(const QpLayout& from) const {
  Eigen::VectorXi map(n_in + n_var);
  const int src_in = from.n_in;
  for (int i = 0; i <= N; ++i) {
    const int j = std::min(i + 1, from.N);  // the source node
    for (int c = 0; c < nc; ++c) map(state_row(i) + c) = from.state_row(j) + c;
    for (int r = 0; r < nx; ++r) map(n_in + iz(i) + r) = src_in + from.iz(j) + r;
    if (i < N)
      for (int r = 0; r < nu; ++r) map(n_in + iv(i) + r) = src_in + from.iv(std::min(i + 1, from.N - 1)) + r;
    if (off_sigma >= 0)
      for (int c = 0; c < nc; ++c) map(n_in + off_sigma + i * nc + c) = src_in + from.off_sigma + j * nc + c;
  }
  for (int r = n_in - (off_t >= 0 ? 2 * nx : 0); r < n_in; ++r)
    map(r) = from.terminal_row() + (r - terminal_row());
  for (int r = 0; off_s >= 0 && r < nx; ++r) map(n_in + off_s + r) = src_in + from.off_s + r;
  for (int r = 0; off_t >= 0 && r < nx; ++r) map(n_in + off_t + r) = src_in + from.off_t + r;
  return map;
}

// One pass lays out the variables, the equality, inequality and soft-terminal rows in the order the
// position tables assume; split, that order would be implicit.
void QpPattern::build(const QpLayout& l, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R,
                      const Eigen::MatrixXd& P_term, const Settings& s) {
  const int nx = l.nx, nu = l.nu, nc = l.nc, N = l.N;
  mQ = mask_upper_of(Q);
  mP = mask_upper_of(P_term);
  mR = mask_upper_of(R);
  mA = mask_structure(s.A_structure, nx, nx);
  mB = mask_structure(s.B_structure, nx, nu);
  mG = mask_structure(s.G_structure, nc, nx);
  mL = mask_lower(nx);
  const Mask dx = mask_diagonal(nx), dc = mask_diagonal(nc);
  std::vector<Eigen::Triplet<double, int>> tp, ta, tg;
  for (int i = 0; i <= N; ++i) add_block(tp, l.iz(i), l.iz(i), i < N ? mQ : mP);
  for (int i = 0; i < N; ++i) add_block(tp, l.iv(i), l.iv(i), mR);
  // ||t||^2 on the soft-terminal slacks: they are unique (t = 0) outside the shrinking phase, where
  // their rows are zero and their L1 cost is off; inside it the L1 term keeps the penalty exact.
  if (l.off_t >= 0) add_block(tp, l.off_t, l.off_t, dx);
  add_block(ta, 0, l.iz(0), dx);
  if (l.off_s >= 0) add_block(ta, 0, l.off_s, mL);
  for (int i = 0; i < N; ++i) {
    const int r0 = l.dynamics_row(i);
    add_block(ta, r0, l.iz(i + 1), dx);
    add_block(ta, r0, l.iz(i), mA);
    add_block(ta, r0, l.iv(i), mB);
  }
  for (int i = 0; i <= N; ++i) {
    add_block(tg, l.state_row(i), l.iz(i), mG);
    if (l.off_sigma >= 0) add_block(tg, l.state_row(i), l.off_sigma + i * nc, dc);
  }
  if (s.soft_terminal) {
    const int r0 = l.terminal_row();
    add_block(tg, r0, l.iz(N), dx);
    add_block(tg, r0, l.off_t, dx);
    add_block(tg, r0 + nx, l.iz(N), dx);
    add_block(tg, r0 + nx, l.off_t, dx);
  }
  SpMat &P = qp.P, &A = qp.A, &G = qp.G;
  P.resize(l.n_var, l.n_var);
  P.setFromTriplets(tp.begin(), tp.end());
  A.resize(l.n_eq, l.n_var);
  A.setFromTriplets(ta.begin(), ta.end());
  G.resize(l.n_in, l.n_var);
  G.setFromTriplets(tg.begin(), tg.end());
  P.makeCompressed();
  A.makeCompressed();
  G.makeCompressed();

  posP_z.clear();
  posA_A.clear();
  posA_B.clear();
  posG.clear();
  posG_term.clear();
  for (int i = 0; i <= N; ++i) posP_z.push_back(block_positions(P, l.iz(i), l.iz(i), i < N ? mQ : mP));
  const Eigen::MatrixXd Ix = Eigen::MatrixXd::Identity(nx, nx);
  for (int i = 0; i < N; ++i) {
    write_block(P, block_positions(P, l.iv(i), l.iv(i), mR), R, 2.0, mR);
    const int r0 = l.dynamics_row(i);
    write_block(A, block_positions(A, r0, l.iz(i + 1), dx), Ix, 1.0, dx);
    posA_A.push_back(block_positions(A, r0, l.iz(i), mA));
    posA_B.push_back(block_positions(A, r0, l.iv(i), mB));
  }
  write_block(A, block_positions(A, 0, l.iz(0), dx), Ix, 1.0, dx);
  if (l.off_t >= 0) write_block(P, block_positions(P, l.off_t, l.off_t, dx), Ix, 2.0, dx);
  if (l.off_s >= 0) posA_L = block_positions(A, 0, l.off_s, mL);
  for (int i = 0; i <= N; ++i) {
    posG.push_back(block_positions(G, l.state_row(i), l.iz(i), mG));
    if (l.off_sigma >= 0)
      write_block(G, block_positions(G, l.state_row(i), l.off_sigma + i * nc, dc),
                  Eigen::MatrixXd::Identity(nc, nc), -1.0, dc);
  }
  if (s.soft_terminal) {
    const int r0 = l.terminal_row();
    for (const auto& blk :
         {block_positions(G, r0, l.iz(N), dx), block_positions(G, r0, l.off_t, dx),
          block_positions(G, r0 + nx, l.iz(N), dx), block_positions(G, r0 + nx, l.off_t, dx)})
      posG_term.insert(posG_term.end(), blk.begin(), blk.end());
  }
  qp.q.setZero(l.n_var);
  qp.b.setZero(l.n_eq);
  // Absent rows are zero rows with bounds [-1, 1] (what PIQP would do itself, with a message, for
  // rows whose two sides are infinite).
  qp.h_l.setConstant(l.n_in, -1.0);
  qp.h_u.setConstant(l.n_in, 1.0);
  qp.x_l.setConstant(l.n_var, -kInf);
  qp.x_u.setConstant(l.n_var, kInf);
  qp.constant = 0.0;
}

}  // namespace tubempc::mpc::detail
