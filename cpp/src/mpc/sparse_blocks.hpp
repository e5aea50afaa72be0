// Shared helpers of the tube MPC's sources (not installed): the clock, and the dense blocks of a
// fixed-pattern sparse matrix (a Mask selects the stored entries, a position table locates them in
// the matrix's values).
#pragma once

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <vector>

namespace tubempc::mpc::detail {

using SpMat = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;
using Clock = std::chrono::steady_clock;
constexpr double kInf = std::numeric_limits<double>::infinity();

inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Structural pattern of a block (true: stored entry, explicit zero or not).
using Mask = Eigen::Array<bool, Eigen::Dynamic, Eigen::Dynamic>;

inline Mask mask_dense(Eigen::Index m, Eigen::Index n) { return Mask::Constant(m, n, true); }
inline Mask mask_diagonal(Eigen::Index n) { return Eigen::MatrixXd::Identity(n, n).array() != 0.0; }
inline Mask mask_upper(Eigen::Index n) {
  return Eigen::MatrixXd::Ones(n, n).triangularView<Eigen::Upper>().toDenseMatrix().array() != 0.0;
}
inline Mask mask_lower(Eigen::Index n) {
  return Eigen::MatrixXd::Ones(n, n).triangularView<Eigen::Lower>().toDenseMatrix().array() != 0.0;
}
// Upper triangle of W's nonzeros plus the diagonal.
inline Mask mask_upper_of(const Eigen::MatrixXd& W) {
  return (W.array() != 0.0 || mask_diagonal(W.rows())) && mask_upper(W.rows());
}
// A user structure (entries != 0 structural; empty -> dense).
inline Mask mask_structure(const Eigen::MatrixXd& S, Eigen::Index m, Eigen::Index n) {
  return S.size() == 0 ? mask_dense(m, n) : Mask(S.array() != 0.0);
}

inline void add_block(std::vector<Eigen::Triplet<double, int>>& trip, int r0, int c0, const Mask& p) {
  for (int c = 0; c < p.cols(); ++c)
    for (int r = 0; r < p.rows(); ++r)
      if (p(r, c)) trip.emplace_back(r0 + r, c0 + c, 1.0);
}

// Positions in M.valuePtr() of the block's entries, in column-major order of the block.
inline std::vector<int> block_positions(const SpMat& M, int r0, int c0, const Mask& p) {
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

inline void zero_block(SpMat& M, const std::vector<int>& pos) {
  for (int i : pos) M.valuePtr()[i] = 0.0;
}

// Zeroes row j of a block written with mask p.
inline void zero_block_row(SpMat& M, const std::vector<int>& pos, const Mask& p, Eigen::Index j) {
  std::size_t k = 0;
  for (Eigen::Index c = 0; c < p.cols(); ++c)
    for (Eigen::Index r = 0; r < p.rows(); ++r)
      if (p(r, c)) {
        if (r == j) M.valuePtr()[pos[k]] = 0.0;
        ++k;
      }
}

// True if W has a nonzero outside the structural pattern p.
inline bool outside_structure(const Eigen::MatrixXd& W, const Mask& p) {
  for (Eigen::Index c = 0; c < W.cols(); ++c)
    for (Eigen::Index r = 0; r < W.rows(); ++r)
      if (!p(r, c) && W(r, c) != 0.0) return true;
  return false;
}

}  // namespace tubempc::mpc::detail
