#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "tubempc/control/tube_update.hpp"
#include "tubempc_testing/control_fixtures.hpp"

using namespace tubempc::control;
using control_test::double_integrator;
using control_test::lqr_design;
using control_test::lqr_gain;

namespace {

SubMatrix random_spd(std::mt19937& rng, double scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  SubMatrix M;
  for (int i = 0; i < 36; ++i) M.data()[i] = n(rng);
  return scale * (M * M.transpose() + 0.1 * SubMatrix::Identity());
}

// Largest e+^T Pe^-1 e+ over sampled e on the tube's boundary and w in W (boundary and inside):
// an independent check of the invariance the certificate claims.
double sampled_invariance(const SubMatrix& Acl, const SubMatrix& Pe, const SubMatrix& P_W, std::mt19937& rng,
                          int n) {
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::LLT<SubMatrix> Le(Pe), Lw(P_W);
  double worst = 0.0;
  for (int i = 0; i < n; ++i) {
    SubVector a, b;
    for (int j = 0; j < 6; ++j) a(j) = g(rng), b(j) = g(rng);
    const SubVector e = Le.matrixL() * a.normalized();
    const SubVector w = Lw.matrixL() * b.normalized() * (i % 2 ? 1.0 : std::pow(u(rng), 1.0 / 6.0));
    const SubVector next = Acl * e + w;
    worst = std::max(worst, next.dot(Le.solve(next)));
  }
  return worst;
}

}  // namespace

// The certified update solves its Lyapunov equation, satisfies (*) with residual <= 0 and keeps every
// sampled successor inside the tube (independent check); on random disturbance sets and gains.
TEST(LyapunovTube, CertifiedTubesAreInvariant) {
  std::mt19937 rng(3);
  SubMatrix A;
  SubInputMatrix B;
  double_integrator(2.0, 1.0, A, B);
  int certified = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const SubMatrix P_W = random_spd(rng, 1e-3 * std::pow(10.0, trial % 4));
    const SubGain K = lqr_gain(A, B, std::pow(10.0, trial % 5 - 1));
    const SubMatrix Acl = A + B * K;
    const double rho = control_test::spectral_radius(Acl);
    const double alpha = rho * rho + (1.0 - rho * rho) * (0.2 + 0.15 * (trial % 5));
    SubsystemTube t;
    ASSERT_EQ(lyapunov_tube(A, B, K, alpha, P_W, 1e9, t), Certification::Certified);
    ++certified;
    EXPECT_LE(t.residual, 0.0);
    EXPECT_LE(lmi_residual(A, B, K, t.Pe, P_W, alpha), 0.0);
    const SubMatrix lyap =
        Acl * t.Pe * Acl.transpose() / alpha + (1.0 + kLyapunovMargin) * P_W / (1.0 - alpha) - t.Pe;
    EXPECT_LE(lyap.cwiseAbs().maxCoeff(), 1e-10 * t.Pe.cwiseAbs().maxCoeff());
    EXPECT_LE(sampled_invariance(Acl, t.Pe, P_W, rng, 2000), 1.0 + 1e-12);
    // the smallest of the family: a slightly smaller tube violates (*)
    EXPECT_GT(lmi_residual(A, B, K, 0.999 * t.Pe, P_W, alpha), 0.0);
  }
  EXPECT_EQ(certified, 40);
}

TEST(LyapunovTube, NamedOutcomes) {
  SubMatrix A;
  SubInputMatrix B;
  double_integrator(2.0, 1.0, A, B);
  const SubGain K = lqr_gain(A, B, 1.0);
  const SubMatrix P_W = 1e-2 * SubMatrix::Identity();
  SubsystemTube t;
  t.alpha = -1.0;
  const double rho = control_test::spectral_radius(A + B * K);
  EXPECT_EQ(lyapunov_tube(A, B, K, 0.99 * rho * rho, P_W, 1e9, t), Certification::NotContractive);
  EXPECT_EQ(lyapunov_tube(A, B, SubGain::Zero(), 0.5, P_W, 1e9, t), Certification::NotContractive);
  EXPECT_EQ(lyapunov_tube(A, B, K, 0.9, P_W, 1e-6, t), Certification::EmptyTightening);
  EXPECT_EQ(t.alpha, -1.0);  // not written unless certified
  EXPECT_STREQ(to_string(Certification::EmptyTightening), "empty_tightening");
}

// cover_ratio against Eigen's generalised eigensolver, and its meaning (containment).
TEST(CoverRatio, IsTheLargestGeneralisedEigenvalue) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const SubMatrix P = random_spd(rng, 1.0), Pc = random_spd(rng, 2.0);
    Eigen::GeneralizedSelfAdjointEigenSolver<SubMatrix> ges(P, Pc, Eigen::EigenvaluesOnly);
    EXPECT_NEAR(cover_ratio(P, Pc), ges.eigenvalues().maxCoeff(), 1e-10 * ges.eigenvalues().maxCoeff());
    EXPECT_NEAR(cover_ratio(P, 3.0 * P), 1.0 / 3.0, 1e-12);
  }
  EXPECT_TRUE(std::isinf(cover_ratio(SubMatrix::Identity(), -SubMatrix::Identity())));
}

namespace {

struct PolicyFixture {
  SubMatrix A;
  SubInputMatrix B;
  SubMatrix P_W0 = 1e-2 * SubMatrix::Identity();
  double u_max = 0.5;
  PolicyFixture() { double_integrator(2.0, 1.0, A, B); }
  SubsystemDesign design(double scale, double r) const { return lqr_design(A, B, scale * P_W0, r); }
};

}  // namespace

TEST(TubePolicy, FixedInitialAndLyapunov) {
  const PolicyFixture f;
  TubePolicySettings s;
  s.adaptive = false;
  const SubsystemDesign initial = f.design(1.0, 1.0);
  TubePolicy fixed(s, f.u_max, initial, {}, "p");
  EXPECT_EQ(fixed.update(3, f.A, f.B, 4.0 * f.P_W0, false), TubeStatus::Fixed);
  EXPECT_EQ(fixed.tube().Pe, initial.Pe);
  // the fixed tube is checked, not certified: its residual for a set it was not designed for is > 0
  EXPECT_EQ(fixed.tube().residual,
            lmi_residual(f.A, f.B, initial.K, initial.Pe, 4.0 * f.P_W0, initial.alpha));
  EXPECT_GT(fixed.tube().residual, 0.0);
  EXPECT_FALSE(certified(TubeStatus::Fixed));
  s.adaptive = true;
  TubePolicy ffa(s, f.u_max, initial, {}, "p");
  EXPECT_EQ(ffa.update(0, f.A, f.B, f.P_W0, false), TubeStatus::Initial);
  EXPECT_EQ(ffa.update(1, f.A, f.B, 0.5 * f.P_W0, false), TubeStatus::Lyapunov);
  SubsystemTube expected;
  ASSERT_EQ(lyapunov_tube(f.A, f.B, initial.K, initial.alpha, 1.2 * 0.5 * f.P_W0, f.u_max, expected),
            Certification::Certified);
  EXPECT_TRUE(ffa.tube().Pe.isApprox(expected.Pe, 1e-14));
}

// A disturbance set too large for the current gain: the margin is dropped, then a gentler library
// design takes over; with nothing certifiable the last tube is flown and the status says so.
TEST(TubePolicy, FallsBackThroughTheNamedLevels) {
  const PolicyFixture f;
  TubePolicySettings s;
  s.redesign_margin = 0.2;
  const SubsystemDesign aggressive = f.design(1.0, 0.01);
  std::vector<SubsystemDesign> library = {f.design(100.0, 1e3), f.design(1.0, 0.01), f.design(10.0, 10.0)};
  // the largest set the aggressive gain still certifies for, without margin
  double lo = 1.0, hi = 1e6;
  for (int i = 0; i < 60; ++i) {
    const double mid = std::sqrt(lo * hi);
    SubsystemTube t;
    (lyapunov_tube(f.A, f.B, aggressive.K, aggressive.alpha, mid * f.P_W0, f.u_max, t) ==
             Certification::Certified
         ? lo
         : hi) = mid;
  }
  ASSERT_GT(lo, 1.0);
  TubePolicy policy(s, f.u_max, aggressive, library, "p");
  EXPECT_EQ(policy.library().front().P_W(0, 0), f.P_W0(0, 0));  // sorted by size
  policy.update(0, f.A, f.B, f.P_W0, false);
  EXPECT_EQ(policy.update(1, f.A, f.B, 0.95 * lo * f.P_W0, false), TubeStatus::LyapunovNoMargin);
  const TubeStatus st = policy.update(2, f.A, f.B, 1.5 * lo * f.P_W0, false);
  EXPECT_TRUE(st == TubeStatus::Library || st == TubeStatus::LibraryNoMargin) << to_string(st);
  EXPECT_NE(policy.design().K, aggressive.K);
  EXPECT_LE(lmi_residual(f.A, f.B, policy.tube().K, policy.tube().Pe, 1.5 * lo * f.P_W0, policy.tube().alpha),
            0.0);
  // an older background design does not replace the library's newer one; a newer one does
  EXPECT_FALSE(policy.adopt(aggressive, 1));
  EXPECT_TRUE(policy.adopt(library[2], 3));
  const SubsystemTube last = policy.tube();
  EXPECT_EQ(policy.update(4, f.A, f.B, 1e8 * f.P_W0, false), TubeStatus::Uncertified);
  EXPECT_EQ(policy.tube().Pe, last.Pe);
  EXPECT_GT(policy.tube().residual, 0.0);  // the last tube's residual for this step, not its old one
}

// Without background designs a due design comes from the library: the smallest design covering
// (1 + margin) P_W that certifies.
TEST(TubePolicy, DueDesignFromTheLibrary) {
  const PolicyFixture f;
  TubePolicySettings s;
  s.redesign_margin = 0.2;
  std::vector<SubsystemDesign> library;
  for (double c : {0.25, 0.5, 1.0, 2.0, 4.0}) library.push_back(f.design(c, 1.0));
  TubePolicy policy(s, f.u_max, f.design(1.0, 1.0), library, "p");
  policy.update(0, f.A, f.B, f.P_W0, false);
  EXPECT_EQ(policy.update(10, f.A, f.B, 1.5 * f.P_W0, true), TubeStatus::Library);
  EXPECT_EQ(policy.design().P_W, library[3].P_W);  // 2 >= 1.2 x 1.5
  s.background_designs = true;
  TubePolicy background(s, f.u_max, f.design(1.0, 1.0), library, "p");
  background.update(0, f.A, f.B, f.P_W0, false);
  EXPECT_EQ(background.update(10, f.A, f.B, 1.5 * f.P_W0, true), TubeStatus::Lyapunov);
}

TEST(TubePolicy, SetUpErrorsNameTheField) {
  const PolicyFixture f;
  SubsystemDesign bad = f.design(1.0, 1.0);
  bad.alpha = 1.0;
  EXPECT_THROW(TubePolicy(TubePolicySettings{}, f.u_max, bad, {}, "p"), std::invalid_argument);
  try {
    TubePolicy(TubePolicySettings{}, f.u_max, f.design(1.0, 1.0), {bad}, "designs.r");
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("designs.r.library[0].alpha:", 0), 0u) << e.what();
  }
  TubePolicySettings s;
  s.alpha_search_period = 0;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  EXPECT_THROW(TubePolicy(TubePolicySettings{}, 0.0, f.design(1.0, 1.0), {}, "p"), std::invalid_argument);
}
