#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "tubempc/control/identification.hpp"

using tubempc::control::ForgettingFactorIdentifier;
using tubempc::control::IdentifierSettings;
using tubempc::control::SubMatrix;
using tubempc::control::SubVector;

namespace {

IdentifierSettings settings(double lambda, double prior_weight) {
  IdentifierSettings s;
  s.lambda = lambda;
  s.w0 = (SubVector() << 0.1, -0.2, 0.0, 1e-3, 2e-3, -1e-3).finished();
  s.S0 = (SubVector() << 4e-2, 4e-2, 4e-2, 2.5e-3, 2.5e-3, 2.5e-3).finished().asDiagonal();
  s.prior_weight = prior_weight;
  return s;
}

}  // namespace

// With the steady-state weight zeta_0 = q / (1 - q) and zero inputs about a zero prior mean, the
// recursion gives S^_k = q^k S^_0 exactly (the prior forgotten at the rate q per step).
TEST(ForgettingFactorIdentifier, PriorDecaysAtTheForgettingRate) {
  IdentifierSettings s = settings(0.96, 0.0);
  s.w0.setZero();
  const double q = std::exp(s.lambda - 1.0);
  s.prior_weight = q / (1.0 - q);
  ForgettingFactorIdentifier id(s);
  for (int k = 1; k <= 40; ++k) {
    ASSERT_TRUE(id.update(SubVector::Zero()));
    EXPECT_NEAR(id.zeta(), s.prior_weight, 1e-12 * s.prior_weight);
    EXPECT_LE((id.S_hat() - std::pow(q, k) * s.S0).cwiseAbs().maxCoeff(), 1e-14 * std::pow(q, k)) << k;
  }
}

// The recursion against the closed form it implements: zeta_k = q^k zeta_0 + sum_{i<k} q^(k-i) and
// w^_k = (q^k zeta_0 w^_0 + sum_{i<k} q^(k-i) w_i) / zeta_k, the exponentially weighted mean.
TEST(ForgettingFactorIdentifier, MeanIsTheExponentiallyWeightedMean) {
  const IdentifierSettings s = settings(0.9, 2.5);
  ForgettingFactorIdentifier id(s);
  const double q = id.q();
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<SubVector> w;
  for (int k = 1; k <= 30; ++k) {
    SubVector wk;
    for (int i = 0; i < 6; ++i) wk(i) = n(rng) * std::sqrt(s.S0(i, i));
    w.push_back(wk);
    id.update(wk);
    double zeta = std::pow(q, k) * s.prior_weight;
    SubVector sum = std::pow(q, k) * s.prior_weight * s.w0;
    for (int i = 0; i < k; ++i) {
      zeta += std::pow(q, k - i);
      sum += std::pow(q, k - i) * w[static_cast<std::size_t>(i)];
    }
    EXPECT_NEAR(id.zeta(), zeta, 1e-12 * zeta);
    EXPECT_LE((id.w_hat() - sum / zeta).cwiseAbs().maxCoeff(), 1e-12) << k;
  }
}

// A constant input: the mean converges to it and the covariance to zero, floored at eig_floor times the
// prior's variances (the scaled eigenvalue floor).
TEST(ForgettingFactorIdentifier, ConstantInputConvergesToTheFloor) {
  const IdentifierSettings s = settings(0.5, 1.0);
  ForgettingFactorIdentifier id(s);
  const SubVector c = SubVector::Constant(0.01);
  for (int k = 0; k < 400; ++k) id.update(c);
  EXPECT_LE((id.w_hat() - c).cwiseAbs().maxCoeff(), 1e-12);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(id.S_hat()(i, i), s.eig_floor * s.S0(i, i), 1e-9 * s.S0(i, i));
  EXPECT_TRUE(id.P_W().isApprox(s.pw_scale * id.S_hat()));
}

TEST(ForgettingFactorIdentifier, NonFiniteInputIsIgnored) {
  ForgettingFactorIdentifier id(settings(0.96, 1.0));
  id.update(SubVector::Constant(0.01));
  const SubVector w_hat = id.w_hat();
  const SubMatrix S = id.S_hat();
  SubVector bad = SubVector::Zero();
  bad(2) = std::nan("");
  EXPECT_FALSE(id.update(bad));
  EXPECT_EQ(id.updates(), 1);
  EXPECT_EQ(id.w_hat(), w_hat);
  EXPECT_EQ(id.S_hat(), S);
  id.reset();
  EXPECT_EQ(id.updates(), 0);
  EXPECT_EQ(id.w_hat(), settings(0.96, 1.0).w0);
}

TEST(ForgettingFactorIdentifier, SettingsNameTheField) {
  const auto expect_field = [](IdentifierSettings s, const std::string& field) {
    try {
      s.validate("identification_p");
      ADD_FAILURE() << "accepted " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("identification_p." + field + ":", 0), 0u) << e.what();
    }
  };
  IdentifierSettings s = settings(0.96, 1.0);
  s.lambda = 1.0;
  expect_field(s, "lambda");
  s = settings(0.96, 1.0);
  s.S0(0, 0) = -1.0;
  expect_field(s, "S0");
  s = settings(0.96, 1.0);
  s.S0(0, 1) = 1.0;
  expect_field(s, "S0");
  s = settings(0.96, 1.0);
  s.prior_weight = -1.0;
  expect_field(s, "prior_weight");
  s = settings(0.96, 1.0);
  s.eig_floor = 0.0;
  expect_field(s, "eig_floor");
  s = settings(0.96, 1.0);
  s.pw_scale = std::nan("");
  expect_field(s, "pw_scale");
  s = settings(0.96, 1.0);
  s.w0(3) = INFINITY;
  expect_field(s, "w0");
}
