#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

#include "tubempc/gravity/gravity_model.hpp"

using tubempc::gravity::GravitySample;
using tubempc::gravity::PointMassGravity;

TEST(PointMass, AccelerationAndGradientMatchFiniteDifferences) {
  const PointMassGravity g(5.236);  // Bennu-like GM (m^3/s^2)
  const Eigen::Vector3d r(400.0, -250.0, 310.0);
  GravitySample s, sp, sm;
  g.evaluate(r, s);
  const double h = 1e-3;
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d(i) = h;
    g.evaluate(r + d, sp);
    g.evaluate(r - d, sm);
    EXPECT_NEAR((sp.potential - sm.potential) / (2 * h), s.acceleration(i), 1e-12);
    EXPECT_LT(((sp.acceleration - sm.acceleration) / (2 * h) - s.gradient.col(i)).norm(), 1e-14);
  }
  EXPECT_NEAR(s.gradient.trace(), 0.0, 1e-20);  // Laplace outside the mass
}

TEST(PointMass, RejectsBadInput) {
  EXPECT_THROW(PointMassGravity(-1.0), std::invalid_argument);
  EXPECT_THROW(PointMassGravity(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  GravitySample s;
  EXPECT_THROW(PointMassGravity(1.0).evaluate(Eigen::Vector3d::Zero(), s), std::domain_error);
}
