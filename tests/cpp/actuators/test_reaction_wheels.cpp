// Reaction wheels: the torque box that keeps the momentum within its limit, and the dump hysteresis.
#include <gtest/gtest.h>

#include "actuator_fixtures.hpp"

using namespace tubempc::actuators;

TEST(ReactionWheels, MomentumNeverExceedsItsLimit) {
  ReactionWheels w = actuator_test::pyramid_wheels(0.2, 5.0);
  Eigen::VectorXd u = Eigen::VectorXd::Constant(4, 1.0);  // beyond the torque limit
  for (int k = 0; k < 40; ++k) {
    const Eigen::VectorXd h0 = w.momentum();
    const Eigen::Vector3d T = w.apply(u, 1.0);
    for (int j = 0; j < 4; ++j) {
      EXPECT_LE(std::abs(w.applied_torque()(j)), 0.2);
      EXPECT_LE(std::abs(w.momentum()(j)), 5.0 + 1e-12);
      EXPECT_NEAR(w.momentum()(j), h0(j) - w.applied_torque()(j), 1e-12);  // h' = -u
    }
    EXPECT_TRUE(T.isApprox(w.axes_B() * w.applied_torque(), 1e-14) || T.norm() == 0.0);
  }
  EXPECT_NEAR(w.momentum()(0), -5.0, 1e-12);  // saturated: no further torque that way
  EXPECT_EQ(w.applied_torque()(0), 0.0);
  Eigen::VectorXd lo, hi;
  w.torque_bounds(1.0, lo, hi);
  EXPECT_EQ(lo(0), -0.2);  // u < 0 raises h back from -h_max
  EXPECT_EQ(hi(0), 0.0);
}

TEST(ReactionWheels, DumpStartsAndStopsWithHysteresis) {
  MomentumDumpSettings d;
  d.start_fraction = 0.8;
  d.stop_fraction = 0.2;
  d.time_constant = 100.0;
  ReactionWheels w = actuator_test::pyramid_wheels(0.2, 50.0, d);
  Eigen::VectorXd h = Eigen::VectorXd::Zero(4), pref;
  h(2) = 30.0;  // 0.6: between stop and start, not dumping
  w.set_momentum(h);
  EXPECT_FALSE(w.dumping());
  h(2) = -41.0;  // 0.82
  w.set_momentum(h);
  EXPECT_TRUE(w.dumping());
  w.preferred_torque(pref);
  EXPECT_NEAR(pref(2), -0.2, 1e-15);  // -0.41 clamped to the torque limit
  EXPECT_EQ(pref(0), 0.0);
  h(2) = -30.0;  // 0.6: still dumping
  w.set_momentum(h);
  EXPECT_TRUE(w.dumping());
  w.preferred_torque(pref);
  EXPECT_NEAR(pref(2), -0.2, 1e-15);  // -30 / 100 s = -0.3 N m, clamped to -0.2
  h(2) = -9.0;                        // 0.18
  w.set_momentum(h);
  EXPECT_FALSE(w.dumping());
  h(2) = 51.0;
  EXPECT_THROW(w.set_momentum(h), std::invalid_argument);
}

TEST(ReactionWheels, AFailedWheelGivesNoTorqueKeepsItsMomentumAndLeavesTheDump) {
  MomentumDumpSettings d;
  d.start_fraction = 0.8;
  d.stop_fraction = 0.2;
  ReactionWheels w = actuator_test::pyramid_wheels(0.2, 5.0, d);
  EXPECT_THROW(w.set_failure(4, 1.0), std::out_of_range);
  EXPECT_THROW(w.set_failure(0, std::nan("")), std::invalid_argument);
  Eigen::VectorXd h = Eigen::VectorXd::Zero(4);
  h(1) = 4.5;  // 0.9 of the limit: dumping while healthy
  w.set_momentum(h);
  EXPECT_TRUE(w.dumping());
  w.set_failure(1, 10.0);
  w.update_failures(9.9);
  EXPECT_EQ(w.failed(), 0);
  EXPECT_TRUE(w.dumping());
  w.update_failures(10.0);
  EXPECT_EQ(w.failed(), 1);
  EXPECT_FALSE(w.dumping());  // its momentum cannot be dumped: the others are below the stop fraction
  Eigen::VectorXd lo, hi, pref;
  w.torque_bounds(1.0, lo, hi);
  EXPECT_EQ(lo(1), 0.0);
  EXPECT_EQ(hi(1), 0.0);
  EXPECT_EQ(hi(0), 0.2);
  const Eigen::Vector3d T = w.apply(Eigen::VectorXd::Constant(4, 0.1), 1.0);
  EXPECT_EQ(w.applied_torque()(1), 0.0);
  EXPECT_EQ(w.momentum()(1), 4.5);
  EXPECT_TRUE(T.isApprox(w.axes_B() * w.applied_torque()));
  w.preferred_torque(pref);
  EXPECT_EQ(pref(1), 0.0);
}
