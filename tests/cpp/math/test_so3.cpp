#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "tubempc/math/so3.hpp"

using namespace tubempc::math;

namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d random_rotation_vector(std::mt19937& gen, double max_angle) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, max_angle);
  Eigen::Vector3d a(n(gen), n(gen), n(gen));
  return a.normalized() * u(gen);
}

// Independent reference: the matrix exponential of skew(phi) by its power series.
Eigen::Matrix3d expm_series(const Eigen::Matrix3d& S) {
  Eigen::Matrix3d term = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d sum = term;
  for (int k = 1; k < 40; ++k) {
    term = term * S / k;
    sum += term;
  }
  return sum;
}

}  // namespace

TEST(So3, ProductsMatchThePapersDefinitions) {
  const Quaternion q(0.1, -0.2, 0.3, 0.9);
  const Quaternion p(-0.4, 0.5, 0.2, 0.7);
  const Eigen::Vector3d qv = q.head<3>(), pv = p.head<3>();
  const Quaternion x = quat_mul(q, p);
  EXPECT_TRUE(x.head<3>().isApprox(p(3) * qv + q(3) * pv + qv.cross(pv), 1e-15));
  EXPECT_NEAR(x(3), q(3) * p(3) - qv.dot(pv), 1e-15);
  const Quaternion o = quat_mul_odot(q, p);
  EXPECT_TRUE(o.head<3>().isApprox(p(3) * qv + q(3) * pv - qv.cross(pv), 1e-15));
  EXPECT_NEAR(o(3), x(3), 1e-15);
}

TEST(So3, RotationMatrixIsTheSandwichProduct) {
  std::mt19937 gen(1);
  for (int i = 0; i < 200; ++i) {
    const Quaternion q = exp_map(random_rotation_vector(gen, kPi));
    const Eigen::Vector3d v(1.3, -0.7, 2.1);
    const Quaternion vq(v.x(), v.y(), v.z(), 0.0);
    const Eigen::Vector3d rotated = quat_mul(quat_mul(q, vq), quat_conj(q)).head<3>();
    EXPECT_TRUE((rotation_matrix(q) * v).isApprox(rotated, 1e-13));
    // R(q (x) p) = R(q) R(p): the product composes rotations.
    const Quaternion p = exp_map(random_rotation_vector(gen, kPi));
    EXPECT_TRUE(rotation_matrix(quat_mul(q, p)).isApprox(rotation_matrix(q) * rotation_matrix(p), 1e-13));
  }
}

TEST(So3, ExpMatchesMatrixExponentialAndLogInvertsIt) {
  std::mt19937 gen(2);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d phi = random_rotation_vector(gen, kPi * 0.9999);
    const Quaternion q = exp_map(phi);
    EXPECT_NEAR(q.norm(), 1.0, 1e-15);
    EXPECT_TRUE(rotation_matrix(q).isApprox(expm_series(skew(phi)), 1e-12));
    EXPECT_LT((log_map(q) - phi).norm(), 1e-12);
    EXPECT_LT((log_map(-q) - phi).norm(), 1e-12);
  }
}

TEST(So3, MapsAreAccurateNearZeroAndNearPi) {
  for (double t : {0.0, 1e-300, 1e-12, 1e-8, 1e-6, 1e-4, 1e-3}) {
    const Eigen::Vector3d phi = Eigen::Vector3d(0.6, -0.8, 0.0) * t;
    EXPECT_LE((log_map(exp_map(phi)) - phi).norm(), 1e-15 + 1e-14 * t) << t;
  }
  // Half turns and just below: the atan2 form keeps full accuracy where acos would not.
  for (double d : {0.0, 1e-12, 1e-9, 1e-6}) {
    const Eigen::Vector3d axis = Eigen::Vector3d(1.0, 2.0, -2.0).normalized();
    const Eigen::Vector3d phi = axis * (kPi - d);
    const Eigen::Vector3d back = log_map(exp_map(phi));
    EXPECT_NEAR(back.norm(), kPi - d, 1e-14) << d;
    EXPECT_LT((back.normalized() - axis).norm(), 1e-12) << d;
  }
}

TEST(So3, RotationMatrixRoundTrip) {
  std::mt19937 gen(3);
  for (int i = 0; i < 300; ++i) {
    const Quaternion q = exp_map(random_rotation_vector(gen, kPi));
    const Quaternion back = quat_from_rotation_matrix(rotation_matrix(q));
    EXPECT_LT(std::min((back - q).norm(), (back + q).norm()), 1e-13);
  }
  Eigen::Matrix3d not_rotation = Eigen::Matrix3d::Identity();
  not_rotation(0, 0) = -1.0;  // a reflection
  EXPECT_THROW(quat_from_rotation_matrix(not_rotation), std::invalid_argument);
}

TEST(So3, RightJacobianMatchesFiniteDifferences) {
  std::mt19937 gen(4);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d phi = random_rotation_vector(gen, 3.0);
    const Eigen::Matrix3d R = rotation_matrix(exp_map(phi));
    const Eigen::Matrix3d Jr = right_jacobian(phi);
    for (int j = 0; j < 3; ++j) {
      const double h = 1e-6;
      Eigen::Vector3d d = Eigen::Vector3d::Zero();
      d(j) = h;
      // Exp(phi + d) = Exp(phi) Exp(Jr d)  =>  log(R^T Exp(phi + d)) / h = Jr e_j
      const Eigen::Matrix3d Rp = rotation_matrix(exp_map(phi + d));
      const Eigen::Matrix3d Rm = rotation_matrix(exp_map(phi - d));
      const Eigen::Vector3d col = (log_map(quat_from_rotation_matrix(R.transpose() * Rp)) -
                                   log_map(quat_from_rotation_matrix(R.transpose() * Rm))) /
                                  (2 * h);
      EXPECT_LT((col - Jr.col(j)).norm(), 1e-7);
    }
    EXPECT_TRUE((right_jacobian_inverse(phi) * Jr).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  }
  EXPECT_TRUE(right_jacobian(Eigen::Vector3d::Zero()).isIdentity(0.0));
  EXPECT_THROW(right_jacobian_inverse(Eigen::Vector3d(2.0 * kPi, 0.0, 0.0)), std::invalid_argument);
}

TEST(So3, MalformedInputsThrow) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(quat_normalize(Quaternion::Zero()), std::invalid_argument);
  EXPECT_THROW(rotation_matrix(Quaternion(0, 0, 0, 0)), std::invalid_argument);
  EXPECT_THROW(log_map(Quaternion(nan, 0, 0, 1)), std::invalid_argument);
  EXPECT_THROW(exp_map(Eigen::Vector3d(nan, 0, 0)), std::invalid_argument);
  EXPECT_THROW(right_jacobian(Eigen::Vector3d(0, std::numeric_limits<double>::infinity(), 0)),
               std::invalid_argument);
}

TEST(So3, NearestRepresentativeIsTheSameRotationNearestToTheReference) {
  std::mt19937 gen(11);
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Vector3d phi = random_rotation_vector(gen, 2.0 * kPi - 0.01);
    const Eigen::Vector3d ref = random_rotation_vector(gen, 2.0 * kPi);
    const Eigen::Vector3d got = nearest_representative(phi, ref);
    EXPECT_TRUE(rotation_matrix(exp_map(got)).isApprox(rotation_matrix(exp_map(phi)), 1e-12));
    EXPECT_LT(got.norm(), 2.0 * kPi - 1e-3);
    // Brute force over more turns than the function tries: no admissible representative is nearer.
    for (int n = -3; n <= 3; ++n) {
      const Eigen::Vector3d c = phi + (2.0 * kPi * n / phi.norm()) * phi;
      if (c.norm() < 2.0 * kPi - 1e-3) EXPECT_LE((got - ref).norm(), (c - ref).norm() + 1e-12);
    }
  }
  // Across |phi| = pi: 3.1 rad about x seen from -3.1 rad about x is -3.18 rad about x.
  const Eigen::Vector3d near_pi(3.1, 0.0, 0.0);
  EXPECT_NEAR(nearest_representative(near_pi, -near_pi).x(), 3.1 - 2.0 * kPi, 1e-15);
  EXPECT_EQ(nearest_representative(near_pi, near_pi), near_pi);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(nearest_representative(near_pi, Eigen::Vector3d(nan, 0.0, 0.0)), near_pi);
  EXPECT_EQ(nearest_representative(Eigen::Vector3d::Zero(), near_pi), Eigen::Vector3d::Zero());
}
