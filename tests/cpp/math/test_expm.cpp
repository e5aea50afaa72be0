// Pade(13) matrix exponential and zero-order-hold discretisation against closed forms.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tubempc/math/expm.hpp"
#include "tubempc/math/so3.hpp"

namespace tubempc::math {
namespace {

TEST(Expm, RotationGeneratorGivesRodriguesAtEveryPadeDegree) {
  // ||theta [a]x||_1 spans every branch: degrees 3, 5, 7, 9, 13 and 13 with squarings.
  const Eigen::Vector3d a = Eigen::Vector3d(0.2, -0.5, 0.8).normalized();
  for (double th : {1e-3, 0.1, 0.5, 1.0, 2.5, 40.0, 1e3}) {
    const Eigen::Matrix3d M = math::skew(th * a);
    Eigen::Matrix3d E;
    ASSERT_TRUE(expm<3>(M, E));
    const Eigen::Matrix3d R = math::rotation_matrix(math::exp_map(th * a));
    EXPECT_LE((E - R).cwiseAbs().maxCoeff(), 2e-15 * std::max(1.0, th)) << th;
  }
}

TEST(Expm, DiagonalAndNilpotentClosedForms) {
  Eigen::Matrix<double, 4, 4> D = Eigen::Vector4d(-3.0, 0.5, 2.0, 7.0).asDiagonal();
  Eigen::Matrix<double, 4, 4> E;
  ASSERT_TRUE(expm<4>(D, E));
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(E(i, i) / std::exp(D(i, i)), 1.0, 1e-14);
  EXPECT_EQ((E - Eigen::Matrix4d(E.diagonal().asDiagonal())).cwiseAbs().maxCoeff(), 0.0);
  // Jordan block lambda I + N: e^lambda (I + N + N^2/2 + N^3/6).
  Eigen::Matrix4d N = Eigen::Matrix4d::Zero();
  N(0, 1) = N(1, 2) = N(2, 3) = 3.0;
  const double lam = -0.4;
  ASSERT_TRUE(expm<4>((lam * Eigen::Matrix4d::Identity() + N).eval(), E));
  const Eigen::Matrix4d ref =
      std::exp(lam) * (Eigen::Matrix4d::Identity() + N + N * N / 2.0 + N * N * N / 6.0);
  EXPECT_LE((E - ref).cwiseAbs().maxCoeff(), 1e-14 * ref.cwiseAbs().maxCoeff());
}

TEST(Expm, InverseIsExponentialOfNegative) {
  std::mt19937 rng(3u);
  std::normal_distribution<double> N(0.0, 1.0);
  for (double scale : {0.01, 0.3, 1.0, 3.0, 20.0}) {
    Eigen::Matrix<double, 19, 19> M;
    for (int i = 0; i < M.size(); ++i) M(i) = scale * N(rng) / std::sqrt(19.0);
    Eigen::Matrix<double, 19, 19> Ep;
    Eigen::Matrix<double, 19, 19> Em;
    ASSERT_TRUE(expm<19>(M, Ep));
    ASSERT_TRUE(expm<19>((-M).eval(), Em));
    const double cond = Ep.norm() * Em.norm();
    EXPECT_LE(((Ep * Em) - Eigen::Matrix<double, 19, 19>::Identity()).cwiseAbs().maxCoeff(), 1e-14 * cond)
        << scale;
  }
  Eigen::Matrix<double, 19, 19> M = Eigen::Matrix<double, 19, 19>::Zero();
  M(3, 4) = NAN;
  Eigen::Matrix<double, 19, 19> E;
  EXPECT_FALSE(expm<19>(M, E));
}

TEST(ZohDiscretize, ScalarAffineSystemClosedForm) {
  // x' = a x + b u + c: Ad = e^{a dt}, Bd = (e^{a dt} - 1)/a b, cd = (e^{a dt} - 1)/a c.
  for (double a : {-0.7, 1e-9, 0.3}) {
    const Eigen::Matrix<double, 1, 1> A(a);
    const Eigen::Matrix<double, 1, 1> B(2.0);
    const Eigen::Matrix<double, 1, 1> c(-0.5);
    Eigen::Matrix<double, 1, 1> Ad;
    Eigen::Matrix<double, 1, 1> Bd;
    Eigen::Matrix<double, 1, 1> cd;
    const double dt = 2.0;
    ASSERT_TRUE((zoh_discretize<1, 1>(A, B, c, dt, Ad, Bd, cd)));
    const double phi1 = std::abs(a) < 1e-6 ? dt * (1.0 + a * dt / 2.0) : std::expm1(a * dt) / a;
    EXPECT_NEAR(Ad(0), std::exp(a * dt), 1e-15);
    EXPECT_NEAR(Bd(0), 2.0 * phi1, 1e-14);
    EXPECT_NEAR(cd(0), -0.5 * phi1, 1e-14);
  }
}

}  // namespace
}  // namespace tubempc::math
