// Fixed-pattern sparse LDL^T refactorisable from a given column (see partial_ldlt.hpp).
#include "tubempc/mpc/partial_ldlt.hpp"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <cmath>
#include <stdexcept>

namespace tubempc::mpc {

void PartialLdlt::analyze(const SpMat& K_upper) {
  const int n = static_cast<int>(K_upper.rows());
  if (K_upper.cols() != n || !K_upper.isCompressed())
    throw std::invalid_argument("PartialLdlt::analyze: the matrix must be square and compressed");
  // The pattern with unit diagonal and zero off-diagonal entries: Eigen's factorisation of it stores
  // every structural entry of L (its algorithm is symbolic in the pattern), with D = I.
  // written through the iterators' valueRef below, which clang-tidy does not see
  SpMat pattern = K_upper;  // NOLINT(performance-unnecessary-copy-initialization)
  for (int c = 0; c < n; ++c) {
    bool diagonal = false;
    for (SpMat::InnerIterator it(pattern, c); it; ++it) {
      if (it.row() > c)
        throw std::invalid_argument("PartialLdlt::analyze: the matrix must be an upper triangle");
      diagonal = diagonal || it.row() == c;
      it.valueRef() = it.row() == c ? 1.0 : 0.0;
    }
    if (!diagonal) throw std::invalid_argument("PartialLdlt::analyze: every diagonal entry must be stored");
  }
  Eigen::SimplicialLDLT<SpMat, Eigen::Upper, Eigen::NaturalOrdering<int>> symbolic(pattern);
  if (symbolic.info() != Eigen::Success)
    throw std::logic_error("PartialLdlt::analyze: symbolic factorisation failed");
  const SpMat& L = symbolic.matrixL().nestedExpression();
  Lp_ = Eigen::Map<const Eigen::VectorXi>(L.outerIndexPtr(), n + 1);
  Li_ = Eigen::Map<const Eigen::VectorXi>(L.innerIndexPtr(), Lp_(n));
  Lx_.setZero(Lp_(n));
  D_.setZero(n);
  y_.setZero(n);

  // The row view: row k lists the columns i < k with L(k, i) stored, in the topological order in
  // which Eigen's up-looking factorisation visits them (the elimination-tree reach of K(0:k, k)),
  // so that both compute every entry with the same operations in the same order; and the slot of
  // L(k, i) in Lx_ (column i's entries are stored by increasing row).
  Eigen::VectorXi& parent = parent_;
  parent.setConstant(n, -1);
  Eigen::VectorXi tags(n), stack(n), path(n), next(n);
  for (int i = 0; i < n; ++i) {
    if (Lp_(i) < Lp_(i + 1)) parent(i) = Li_(Lp_(i));
    next(i) = Lp_(i);
  }
  row_start_.setZero(n + 1);
  row_col_.resize(Lp_(n));
  row_slot_.resize(Lp_(n));
  const int* Kp = K_upper.outerIndexPtr();
  const int* Ki = K_upper.innerIndexPtr();
  int e = 0;
  for (int k = 0; k < n; ++k) {
    int top = n;
    tags(k) = k;
    for (int p = Kp[k]; p < Kp[k + 1]; ++p) {
      int len = 0;
      for (int i = Ki[p]; tags(i) != k; i = parent(i)) {
        if (i < 0) throw std::logic_error("PartialLdlt::analyze: unexpected factor pattern");
        path(len++) = i;
        tags(i) = k;
      }
      while (len > 0) stack(--top) = path(--len);
    }
    for (; top < n; ++top, ++e) {
      const int i = stack(top);
      if (next(i) >= Lp_(i + 1) || Li_(next(i)) != k)
        throw std::logic_error("PartialLdlt::analyze: unexpected factor pattern");
      row_col_(e) = i;
      row_slot_(e) = next(i)++;
    }
    row_start_(k + 1) = e;
  }
  if (e != Lp_(n)) throw std::logic_error("PartialLdlt::analyze: unexpected factor pattern");
  mark_.setZero(n);
  valid_ = false;
  last_computed_ = 0;
}

// Row k of L and D_kk: the up-looking step L(0:k, 0:k) D l = K(0:k, k), in Eigen's order.
bool PartialLdlt::factorize_row(const SpMat& K_upper, int k) {
  const int* Kp = K_upper.outerIndexPtr();
  const int* Ki = K_upper.innerIndexPtr();
  const double* Kx = K_upper.valuePtr();
  const int* Lp = Lp_.data();
  const int* Li = Li_.data();
  double* Lx = Lx_.data();
  double* y = y_.data();
  for (int p = Kp[k]; p < Kp[k + 1]; ++p) y[Ki[p]] += Kx[p];
  double d = y[k];
  y[k] = 0.0;
  for (int e = row_start_(k); e < row_start_(k + 1); ++e) {
    const int i = row_col_(e), slot = row_slot_(e);
    const double yi = y[i];
    y[i] = 0.0;
    for (int p = Lp[i]; p < slot; ++p) y[Li[p]] -= Lx[p] * yi;
    const double l = yi / D_(i);
    d -= l * yi;
    Lx[slot] = l;
  }
  D_(k) = d;
  return d != 0.0 && std::isfinite(d);
}

bool PartialLdlt::factorize(const SpMat& K_upper) {
  const int n = rows();
  valid_ = false;
  last_computed_ = n;
  for (int k = 0; k < n; ++k)
    if (!factorize_row(K_upper, k)) return false;
  return valid_ = true;
}

bool PartialLdlt::refactorize(const SpMat& K_upper, Eigen::Ref<const Eigen::VectorXi> changed) {
  if (!valid_) return factorize(K_upper);
  const int n = rows();
  // Row k depends on K(:, k) and on the rows of its elimination-tree descendants: the rows to
  // recompute are the changed columns and their ancestors.
  for (Eigen::Index c = 0; c < changed.size(); ++c)
    if (changed(c) < 0 || changed(c) >= n)
      throw std::invalid_argument("PartialLdlt::refactorize: column out of range");
  for (Eigen::Index c = 0; c < changed.size(); ++c)
    for (int i = changed(c); i >= 0 && mark_(i) == 0; i = parent_(i)) mark_(i) = 1;
  valid_ = false;
  last_computed_ = 0;
  bool ok = true;
  for (int k = 0; k < n; ++k) {
    if (mark_(k) == 0) continue;
    mark_(k) = 0;
    ++last_computed_;
    ok = ok && factorize_row(K_upper, k);
  }
  return valid_ = ok;
}

void PartialLdlt::solve_in_place(Eigen::Ref<Eigen::VectorXd> x) const {
  const int n = rows();
  const int* Lp = Lp_.data();
  const int* Li = Li_.data();
  const double* Lx = Lx_.data();
  for (int j = 0; j < n; ++j) {
    const double xj = x(j);
    if (xj != 0.0)
      for (int p = Lp[j]; p < Lp[j + 1]; ++p) x(Li[p]) -= Lx[p] * xj;
  }
  for (int j = 0; j < n; ++j) x(j) /= D_(j);
  for (int j = n - 1; j >= 0; --j) {
    double s = x(j);
    for (int p = Lp[j]; p < Lp[j + 1]; ++p) s -= Lx[p] * x(Li[p]);
    x(j) = s;
  }
}

}  // namespace tubempc::mpc
