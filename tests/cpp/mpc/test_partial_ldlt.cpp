// PartialLdlt against Eigen's SimplicialLDLT (an independent factorisation of the same algorithm):
// the full factorisation, refactorisation after changed columns, recovery after a zero pivot, and
// errors on bad input.
#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "tubempc/mpc/partial_ldlt.hpp"

using tubempc::mpc::PartialLdlt;
using SpMat = PartialLdlt::SpMat;

namespace {

// The upper triangle of a random sparse quasi-definite matrix [[H, B^T], [B, -C]] (H, C positive
// definite by diagonal dominance) of size n_p + n_d, a fraction `density` of off-diagonal entries.
SpMat random_quasidefinite(std::mt19937& gen, int n_p, int n_d, double density) {
  std::uniform_real_distribution<double> U(-1.0, 1.0), coin(0.0, 1.0);
  const int n = n_p + n_d;
  std::vector<Eigen::Triplet<double, int>> t;
  for (int c = 0; c < n; ++c) {
    for (int r = 0; r < c; ++r)
      if (coin(gen) < density) t.emplace_back(r, c, U(gen));
    const double diag = 2.0 + n * density + U(gen);
    t.emplace_back(c, c, c < n_p ? diag : -diag);
  }
  SpMat K(n, n);
  K.setFromTriplets(t.begin(), t.end());
  K.makeCompressed();
  return K;
}

using EigenLdlt = Eigen::SimplicialLDLT<SpMat, Eigen::Upper, Eigen::NaturalOrdering<int>>;

// PartialLdlt's factorisation reproduces Eigen's bit for bit (same operations in the same order).
void expect_same_as_eigen(const PartialLdlt& f, const SpMat& K) {
  const EigenLdlt ref(K);
  ASSERT_EQ(ref.info(), Eigen::Success);
  ASSERT_EQ(f.D().size(), ref.vectorD().size());
  for (Eigen::Index i = 0; i < K.rows(); ++i) EXPECT_EQ(f.D()(i), ref.vectorD()(i)) << "D(" << i << ")";
  std::mt19937 gen(7);
  std::normal_distribution<double> N01;
  const Eigen::VectorXd b = Eigen::VectorXd::NullaryExpr(K.rows(), [&] { return N01(gen); });
  Eigen::VectorXd x = b;
  f.solve_in_place(x);
  const Eigen::VectorXd x_ref = ref.solve(b);
  EXPECT_LE((x - x_ref).lpNorm<Eigen::Infinity>(), 1e-13 * (1.0 + x_ref.lpNorm<Eigen::Infinity>()));
  // And it solves the system itself.
  const SpMat K_full = K.selfadjointView<Eigen::Upper>();
  EXPECT_LE((K_full * x - b).lpNorm<Eigen::Infinity>(), 1e-11 * (1.0 + b.lpNorm<Eigen::Infinity>()));
}

}  // namespace

TEST(PartialLdlt, FactorisationMatchesEigen) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    std::mt19937 gen(seed);
    const SpMat K = random_quasidefinite(gen, 40, 25, 0.06);
    PartialLdlt f;
    f.analyze(K);
    ASSERT_TRUE(f.factorize(K));
    EXPECT_EQ(f.last_rows_computed(), K.rows());
    EXPECT_GT(f.nonzeros_L(), 0);
    expect_same_as_eigen(f, K);
  }
}

TEST(PartialLdlt, RefactorisationOfChangedColumnsMatchesAFullOne) {
  for (unsigned seed = 11; seed <= 20; ++seed) {
    std::mt19937 gen(seed);
    SpMat K = random_quasidefinite(gen, 50, 30, 0.04);
    const int n = static_cast<int>(K.rows());
    PartialLdlt f;
    f.analyze(K);
    ASSERT_TRUE(f.factorize(K));
    // Change the values of a few columns (as an active-set change does) and refactorise those alone.
    std::uniform_int_distribution<int> column(0, n - 1);
    std::uniform_real_distribution<double> U(0.5, 1.5);
    Eigen::VectorXi changed(3);
    for (int c = 0; c < changed.size(); ++c) {
      changed(c) = column(gen);
      for (SpMat::InnerIterator it(K, changed(c)); it; ++it) it.valueRef() *= U(gen);
    }
    ASSERT_TRUE(f.refactorize(K, changed));
    EXPECT_GE(f.last_rows_computed(), 1);
    EXPECT_LE(f.last_rows_computed(), n);
    expect_same_as_eigen(f, K);
  }
}

TEST(PartialLdlt, RefactorisationComputesOnlyTheAncestors) {
  // Block-diagonal pattern: two independent 3x3 blocks. A change in the first block leaves the
  // second block's rows alone, and an unchanged matrix recomputes nothing.
  std::vector<Eigen::Triplet<double, int>> t;
  for (int b = 0; b < 2; ++b)
    for (int c = 0; c < 3; ++c) {
      t.emplace_back(3 * b + c, 3 * b + c, 4.0);
      if (c > 0) t.emplace_back(3 * b + c - 1, 3 * b + c, 1.0);
    }
  SpMat K(6, 6);
  K.setFromTriplets(t.begin(), t.end());
  K.makeCompressed();
  PartialLdlt f;
  f.analyze(K);
  ASSERT_TRUE(f.factorize(K));
  K.coeffRef(1, 1) = 5.0;
  ASSERT_TRUE(f.refactorize(K, Eigen::VectorXi::Constant(1, 1)));
  EXPECT_EQ(f.last_rows_computed(), 2);  // rows 1 and 2 (its ancestor); not 0, nor 3..5
  expect_same_as_eigen(f, K);
  ASSERT_TRUE(f.refactorize(K, Eigen::VectorXi(0)));
  EXPECT_EQ(f.last_rows_computed(), 0);
}

TEST(PartialLdlt, ZeroPivotFailsAndTheNextRefactorisationIsComplete) {
  std::mt19937 gen(3);
  SpMat K = random_quasidefinite(gen, 20, 10, 0.1);
  PartialLdlt f;
  f.analyze(K);
  // D(0) = K(0, 0) = 0: the first pivot is zero.
  const double d0 = K.coeff(0, 0);
  K.coeffRef(0, 0) = 0.0;
  EXPECT_FALSE(f.factorize(K));
  K.coeffRef(0, 0) = d0;
  // Only column 0 changed; everything after the failed pivot must still be recomputed.
  ASSERT_TRUE(f.refactorize(K, Eigen::VectorXi::Constant(1, 0)));
  EXPECT_EQ(f.last_rows_computed(), K.rows());
  expect_same_as_eigen(f, K);
  K.coeffRef(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(f.refactorize(K, Eigen::VectorXi::Constant(1, 0)));
}

TEST(PartialLdlt, RejectsBadPatterns) {
  PartialLdlt f;
  SpMat rect(3, 4);
  rect.makeCompressed();
  EXPECT_THROW(f.analyze(rect), std::invalid_argument);
  SpMat lower(2, 2);
  lower.insert(0, 0) = 1.0;
  lower.insert(1, 1) = 1.0;
  lower.insert(1, 0) = 1.0;
  lower.makeCompressed();
  EXPECT_THROW(f.analyze(lower), std::invalid_argument);
  SpMat no_diag(2, 2);
  no_diag.insert(0, 0) = 1.0;
  no_diag.insert(0, 1) = 1.0;
  no_diag.makeCompressed();
  EXPECT_THROW(f.analyze(no_diag), std::invalid_argument);
  SpMat uncompressed(2, 2);
  uncompressed.insert(0, 0) = 1.0;
  uncompressed.insert(1, 1) = 1.0;
  EXPECT_THROW(f.analyze(uncompressed), std::invalid_argument);
  SpMat ok(2, 2);
  ok.insert(0, 0) = 1.0;
  ok.insert(1, 1) = -1.0;
  ok.makeCompressed();
  f.analyze(ok);
  ASSERT_TRUE(f.factorize(ok));
  EXPECT_THROW(f.refactorize(ok, Eigen::VectorXi::Constant(1, 2)), std::invalid_argument);
  EXPECT_THROW(f.refactorize(ok, Eigen::VectorXi::Constant(1, -1)), std::invalid_argument);
}
