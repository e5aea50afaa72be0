// The held first-order expansion of a gravity field (docs/model.md M42): the hold distance against
// the formula evaluated independently, the error inside the hold against the exact field, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "gravity_test_meshes.hpp"
#include "tubempc/gravity/expansion_hold.hpp"
#include "tubempc/gravity/gravity_model.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc/gravity/shape.hpp"

using tubempc::gravity::ExpansionHold;
using tubempc::gravity::GravitySample;
using tubempc::gravity::PointMassGravity;
using tubempc::gravity::PolyhedronGravity;

TEST(ExpansionHold, HoldsTheFirstPointThenSetsTheDistanceFromTheGradientsChange) {
  const PointMassGravity field(4.89);  // Bennu's GM (m^3/s^2)
  const double tol = 1e-9;
  ExpansionHold hold(0.0, tol);
  EXPECT_FALSE(hold.valid());
  const Eigen::Vector3d r0(300.0, -40.0, 120.0);
  ASSERT_TRUE(hold.hold(field, r0));
  EXPECT_EQ(hold.evaluations(), 1);
  EXPECT_EQ(hold.distance(), 0.0);  // d_min at the first evaluation
  GravitySample g0, g1;
  field.evaluate(r0, g0);
  EXPECT_EQ(hold.acceleration(r0), g0.acceleration);
  const Eigen::Vector3d r1 = r0 + Eigen::Vector3d(0.01, 0.02, -0.005);
  ASSERT_TRUE(hold.hold(field, r1));  // a hold of 0: evaluated again
  EXPECT_EQ(hold.evaluations(), 2);
  field.evaluate(r1, g1);
  const double c = (g1.gradient - g0.gradient).norm() / (r1 - r0).norm();
  EXPECT_NEAR(hold.distance(), std::sqrt(2.0 * tol / c), 1e-12);
  EXPECT_EQ(hold.point_A(), r1);
  EXPECT_EQ(hold.gradient_A(), g1.gradient);
  // inside the hold nothing is evaluated; at its edge the field is
  const Eigen::Vector3d dir = Eigen::Vector3d(1.0, -2.0, 0.5).normalized();
  ASSERT_TRUE(hold.hold(field, r1 + 0.99 * hold.distance() * dir));
  EXPECT_EQ(hold.evaluations(), 2);
  ASSERT_TRUE(hold.hold(field, r1 + 1.01 * hold.distance() * dir));
  EXPECT_EQ(hold.evaluations(), 3);
  EXPECT_GT(hold.largest_error(), 0.0);
}

TEST(ExpansionHold, ErrorAlongAPathStaysNearTheTolerance) {
  // A path from about 410 m down to 250 m from the centre of a lumpy body (at most 230 m), 1.6 cm a step: the expansion's error against the exact
  // field at every point, and the evaluations it saves. The tolerance is a predicted error, not a bound: it is
  // checked here to a factor of 2.
  const gravity_test::Mesh m = gravity_test::lumpy_body(16, 32, 200.0);
  const PolyhedronGravity field(tubempc::gravity::Shape(m.v, m.f), 1190.0);
  for (double tol : {1e-8, 1e-9, 1e-10}) {
    ExpansionHold hold(0.0, tol);
    double worst = 0.0;
    int points = 0;
    const Eigen::Vector3d top(380.0, 80.0, -120.0);
    const Eigen::Vector3d bottom = top.normalized() * 250.0;
    for (double s = 0.0; s <= 1.0; s += 1e-4) {
      const Eigen::Vector3d r = top + s * (bottom - top);
      ASSERT_TRUE(hold.hold(field, r));
      worst = std::max(worst, (hold.acceleration(r) - field.acceleration(r)).norm());
      ++points;
    }
    EXPECT_LT(worst, 2.0 * tol) << tol;
    // on a straight path the error grows with the distance from the point: the error found where the
    // expansion was given up, just past its hold, bounds the errors made inside it
    EXPECT_LE(worst, hold.largest_error() * (1.0 + 1e-9)) << tol;
    EXPECT_LT(hold.largest_error(), 2.0 * tol) << tol;
    EXPECT_LT(hold.evaluations(), points / 20) << tol;
  }
}

TEST(ExpansionHold, MinimumDistanceAloneHoldsThatFar) {
  const PointMassGravity field(4.89);
  ExpansionHold hold(1.0, 0.0);
  const Eigen::Vector3d r0(300.0, 0.0, 0.0);
  ASSERT_TRUE(hold.hold(field, r0));
  ASSERT_TRUE(hold.hold(field, r0 + Eigen::Vector3d(0.0, 0.999, 0.0)));
  EXPECT_EQ(hold.evaluations(), 1);
  ASSERT_TRUE(hold.hold(field, r0 + Eigen::Vector3d(0.0, 1.0, 0.0)));
  EXPECT_EQ(hold.evaluations(), 2);
  EXPECT_EQ(hold.distance(), 1.0);
  hold.reset();
  EXPECT_FALSE(hold.valid());
  EXPECT_EQ(hold.evaluations(), 0);
  EXPECT_EQ(hold.min_distance(), 1.0);
}

TEST(ExpansionHold, RejectsBadSettingsAndKeepsItsExpansionWhereTheFieldFails) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ExpansionHold(-1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(ExpansionHold(0.0, -1e-9), std::invalid_argument);
  EXPECT_THROW(ExpansionHold(kNaN, 0.0), std::invalid_argument);
  EXPECT_THROW(ExpansionHold(0.0, std::numeric_limits<double>::infinity()), std::invalid_argument);
  const PointMassGravity field(4.89);
  ExpansionHold hold(0.0, 1e-9);
  EXPECT_FALSE(hold.hold(field, Eigen::Vector3d::Zero()));  // the point mass's singular point
  EXPECT_FALSE(hold.valid());
  const Eigen::Vector3d r0(300.0, 0.0, 0.0);
  ASSERT_TRUE(hold.hold(field, r0));
  EXPECT_FALSE(hold.hold(field, Eigen::Vector3d(kNaN, 0.0, 0.0)));
  EXPECT_FALSE(hold.hold(field, Eigen::Vector3d::Zero()));
  EXPECT_TRUE(hold.valid());
  EXPECT_EQ(hold.point_A(), r0);
  EXPECT_EQ(hold.evaluations(), 1);
}
