/// @file partial_ldlt.hpp
/// Sparse LDL^T of a symmetric (quasi-definite) matrix with a fixed pattern that refactorises only
/// the rows a change of values reaches: the numeric kernel of the active-set QP solver
/// (active_set_qp.hpp).
///
/// The factorisation is up-looking: row k of L and D_kk depend only on column k of the matrix's
/// upper triangle and on the rows of k's descendants in the elimination tree. When an active-set
/// iteration changes a few columns of the KKT matrix, only those rows and their ancestors in the
/// tree change, and `refactorize` recomputes them alone (in the tube MPC's KKT matrix, 10 to 30 of
/// 1226 rows on the mission QPs inspected; the tree is up to 555 rows deep). Eigen's SimplicialLDLT (the same
/// algorithm, without the partial step) does the symbolic analysis. The row patterns of L, each in the order
/// Eigen visits it, and the storage slot of every entry are then fixed, so every entry is computed by the
/// same operations in the same order as Eigen's factorisation, with no elimination-tree traversal and no
/// allocation.
#pragma once

#include <Eigen/Dense>
#include <Eigen/SparseCore>

namespace tubempc::mpc {

/// LDL^T (L unit lower triangular, D diagonal) of a fixed-pattern sparse symmetric matrix, without
/// pivoting: the matrix must already be in its fill-reducing order and have an LDL^T in that order
/// (quasi-definite matrices do for every order).
class PartialLdlt {
 public:
  using SpMat = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;  ///< Compressed column storage.

  /// Symbolic analysis of the pattern of `K_upper` (square, compressed, upper triangle with every
  /// diagonal entry stored; its values are ignored). Throws std::invalid_argument otherwise. Allocates.
  void analyze(const SpMat& K_upper);

  /// Numeric factorisation of `K_upper` (the analysed pattern). Returns false on a zero or
  /// non-finite pivot. Allocates nothing.
  bool factorize(const SpMat& K_upper);

  /// Refactorisation of `K_upper` whose values differ from those of the last factorisation only in
  /// the columns listed in `changed` (indices in [0, n), any order, repeats allowed): recomputes
  /// those rows of L and D and their elimination-tree ancestors. After a failed factorisation it
  /// refactorises everything. Returns false on a zero or non-finite pivot. Allocates nothing;
  /// throws std::invalid_argument on an index out of range.
  bool refactorize(const SpMat& K_upper, Eigen::Ref<const Eigen::VectorXi> changed);

  /// x <- K^{-1} x with the last successful factorisation. Allocates nothing.
  void solve_in_place(Eigen::Ref<Eigen::VectorXd> x) const;

  /// Dimension n (0 before analyze).
  int rows() const { return static_cast<int>(D_.size()); }
  /// Stored entries of L below the diagonal.
  Eigen::Index nonzeros_L() const { return Lx_.size(); }
  /// Rows of L and D that the last factorisation computed.
  int last_rows_computed() const { return last_computed_; }
  /// The diagonal D.
  const Eigen::VectorXd& D() const { return D_; }

 private:
  bool factorize_row(const SpMat& K_upper, int k);

  Eigen::VectorXi Lp_, Li_;  // L by columns: column starts, row indices (increasing)
  Eigen::VectorXd Lx_, D_;
  Eigen::VectorXi row_start_, row_col_, row_slot_;  // L by rows: columns (Eigen's order), slots in Lx_
  Eigen::VectorXi parent_;                          // elimination tree (-1: root)
  Eigen::VectorXi mark_;                            // rows to recompute, zero between calls
  Eigen::VectorXd y_;                               // dense work row, zero between calls
  bool valid_ = false;                              // the last factorisation succeeded
  int last_computed_ = 0;
};

}  // namespace tubempc::mpc
