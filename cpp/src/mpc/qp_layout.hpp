// The tube MPC's QP (see tube_mpc.hpp) as data (not installed): the index arithmetic of its variables
// and rows (QpLayout), its values on the fixed sparsity pattern (QpProblem) and the positions of
// every block in that pattern (QpPattern), all set up once.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "sparse_blocks.hpp"
#include "tubempc/mpc/settings.hpp"

namespace tubempc::mpc::detail {

// Variables w = [dz_0, v_0, ..., dz_{N-1}, v_{N-1}, dz_N, s, sigma, t]; equality rows: the initial
// condition (node 0), then the dynamics into node i + 1; inequality rows: n_c state constraints per
// node 0..N, then the soft-terminal rows dz_N - t (n_x) and dz_N + t (n_x).
struct QpLayout {
  int nx = 0, nu = 0, nc = 0, N = 0;
  int n_var = 0, n_eq = 0, n_in = 0;
  int off_s = -1, off_sigma = -1, off_t = -1;  // -1: the block is absent

  QpLayout() = default;
  // The layout of horizon N (1 <= N <= Settings::horizon: the shrinking phase's QPs have N = T - k).
  QpLayout(int nx, int nu, int nc, int N, const Settings& s);
  int iz(int i) const { return i < N ? i * (nx + nu) : N * (nx + nu); }  // dz_i
  int iv(int i) const { return i * (nx + nu) + nx; }                     // v_i
  int dynamics_row(int i) const { return (i + 1) * nx; }  // rows of dz_{i+1} - A dz_i - B v_i = ...
  int state_row(int i) const { return i * nc; }           // node i's state constraints
  int terminal_row() const { return (N + 1) * nc; }       // the soft-terminal rows
  // Variables that may carry finite bounds: the inputs, s, sigma, the states with a finite trust
  // region and z_N with the hard terminal constraint.
  Eigen::Array<bool, Eigen::Dynamic, 1> boundable(const Settings& s) const;
  // Active-set index map of a one-node shift from the set of a QP laid out by `from` (entries: G rows,
  // then one per variable; values: indices into from's set): node i's rows and variables take node
  // i + 1's (from's last node where i + 1 is past it; from has this horizon or one node more), the
  // slacks s, sigma and t and the terminal rows their own.
  Eigen::VectorXi shift_map(const QpLayout& from) const;
};

// The QP in PIQP's form with P's upper triangle, on the fixed pattern.
struct QpProblem {
  SpMat P, A, G;
  Eigen::VectorXd q, b, h_l, h_u, x_l, x_u;
  double constant = 0.0;  // dropped from the cost: cost = 1/2 w^T P w + q^T w + constant
};

// The QP's pattern and the value positions of its blocks.
struct QpPattern {
  QpProblem qp;
  std::vector<std::vector<int>> posP_z, posA_A, posA_B, posG;
  std::vector<int> posA_L, posG_term;  // posG_term: the soft-terminal rows' four diagonals
  Mask mQ, mP, mR, mA, mB, mG, mL;

  // Lays out the matrices and writes the constant entries (identities, 2 R, the slacks' rows).
  void build(const QpLayout& l, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R,
             const Eigen::MatrixXd& P_term, const Settings& s);
};

}  // namespace tubempc::mpc::detail
