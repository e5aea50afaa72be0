// Thruster cluster mapping, truth errors, faults and the remainder carry-over modulation.
#include <gtest/gtest.h>

#include <random>

#include "actuator_fixtures.hpp"

using namespace tubempc::actuators;

TEST(ThrusterCluster, MappingIsForceAndMomentArm) {
  ThrusterSpec s;
  s.position_B = Eigen::Vector3d(1.0, 0.0, 0.0);
  s.direction_B = Eigen::Vector3d(0.0, 1.0, 0.0);
  ThrusterSpec s2 = s;
  s2.position_B = Eigen::Vector3d(0.0, 0.0, 2.0);
  ThrusterCluster c({s, s2});
  Vector6 col0, col1;
  col0 << 0, 1, 0, 0, 0, 1;   // r x F = x x y = z
  col1 << 0, 1, 0, -2, 0, 0;  // 2 z x y = -2 x
  EXPECT_TRUE(c.mapping().col(0).isApprox(col0));
  EXPECT_TRUE(c.mapping().col(1).isApprox(col1));
  EXPECT_TRUE(c.true_mapping().isApprox(c.mapping()));
}

TEST(ThrusterCluster, TruthErrorsScaleAndTurnTheDirection) {
  ThrusterSpec s;
  s.position_B = Eigen::Vector3d(0.3, -0.2, 1.0);
  s.direction_B = Eigen::Vector3d(0.0, 0.0, 1.0);
  s.scale_error_bound = 0.05;
  s.scale_error = -0.03;
  s.misalignment_bound = 0.02;
  s.misalignment_B = Eigen::Vector3d(0.01, 0.0, 0.0);  // perpendicular to d: turns it by 0.01 rad
  ThrusterCluster c({s});
  const Eigen::Vector3d F = c.true_mapping().col(0).head<3>();
  EXPECT_NEAR(F.norm(), 0.97, 1e-14);
  EXPECT_NEAR(std::acos(F.normalized().dot(s.direction_B)), 0.01, 1e-12);
  EXPECT_NEAR(F.normalized().y(), -std::sin(0.01), 1e-14);  // right-handed about +x: z turns towards -y
  EXPECT_TRUE(c.true_mapping().col(0).tail<3>().isApprox(s.position_B.cross(F)));
}

TEST(ThrusterCluster, BadInputNamesTheField) {
  auto specs = actuator_test::cube_specs();
  specs[3].direction_B *= 2.0;
  try {
    ThrusterCluster c(specs);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("thrusters[3].direction_B"), std::string::npos) << e.what();
  }
  specs = actuator_test::cube_specs();
  specs[0].scale_error = 0.1;  // bound 0
  EXPECT_THROW(ThrusterCluster{specs}, std::invalid_argument);
  EXPECT_THROW(fault_kind_from_string("stuck"), std::invalid_argument);
  EXPECT_EQ(fault_kind_from_string("stuck_on"), FaultKind::StuckOn);
  ThrusterCluster c(actuator_test::cube_specs());
  EXPECT_THROW(c.set_fault(12, FaultKind::FailedOff, 0.0), std::invalid_argument);
  ModulationSettings m;
  m.period = 0.0;
  EXPECT_THROW(PulseModulator(c, m), std::invalid_argument);
  m.period = 0.015;  // shorter than the 20 ms minimum on-time
  try {
    PulseModulator p(c, m);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("thrusters[0].min_on_time"), std::string::npos) << e.what();
  }
}

// Binary fractions keep the arithmetic exact: tau_c = 7/1024 s per period with tau_min = 20/1024 s fires
// 21/1024 s every third period and never otherwise.
TEST(PulseModulator, MinimumImpulseCarriesTheRemainderExactly) {
  ThrusterSpec s;
  s.max_thrust = 4.0;
  s.min_on_time = 20.0 / 1024;
  s.isp = 200.0;
  ThrusterCluster c({s});
  ModulationSettings ms;
  ms.period = 1.0;
  ms.on_time_resolution = 1.0 / 1024;
  PulseModulator mod(c, ms);
  Eigen::VectorXd f(1);
  f << 4.0 * 7.0 / 1024;
  double impulse = 0.0;
  for (int k = 1; k <= 30; ++k) {
    const Firing& fr = mod.modulate(c, k, f);
    EXPECT_EQ(fr.on_time(0), k % 3 == 0 ? 21.0 / 1024 : 0.0) << k;
    EXPECT_EQ(fr.delivered_B(2), k % 3 == 0 ? 4.0 * 21.0 / 1024 : 0.0);
    impulse += fr.impulse(0);
  }
  EXPECT_EQ(impulse, 10 * 4.0 * 21.0 / 1024);
  EXPECT_EQ(mod.remainder()(0), 0.0);
  EXPECT_EQ(mod.pulse_counts()(0), 10);
  EXPECT_DOUBLE_EQ(mod.propellant(), impulse / (200.0 * kStandardGravity));
}

// Over any sequence of commands: delivered = commanded impulse - F r_K, with 0 <= r_K < r_max.
TEST(PulseModulator, DeliveredImpulseMatchesTheCommandUpToTheRemainder) {
  const ThrusterCluster c = actuator_test::cube_cluster(4.5, 0.02);
  ModulationSettings ms;
  ms.period = 0.5;
  ms.on_time_resolution = 0.004;  // tau_min rounds up to 0.02
  PulseModulator mod(c, ms);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::VectorXd f(c.size()), commanded = Eigen::VectorXd::Zero(c.size()), delivered = commanded;
  for (int k = 0; k < 500; ++k) {
    for (int j = 0; j < c.size(); ++j) f(j) = 4.5 * std::pow(u(rng), 3.0);  // many below the minimum impulse
    const Firing& fr = mod.modulate(c, 0.5 * k, f);
    commanded += f * ms.period;
    delivered += fr.impulse;
    for (int j = 0; j < c.size(); ++j) {
      EXPECT_GE(mod.remainder()(j), 0.0);
      EXPECT_LT(mod.remainder()(j), mod.remainder_bound(c, j));
      EXPECT_TRUE(fr.on_time(j) == 0.0 || fr.on_time(j) >= 0.02 - 1e-15);
    }
  }
  for (int j = 0; j < c.size(); ++j) EXPECT_NEAR(delivered(j), commanded(j) - 4.5 * mod.remainder()(j), 1e-9);
  EXPECT_NEAR(mod.remainder_bound(c, 0), 0.02, 1e-15);
}

// Nearest rounding: the levels by hand (tau_min 0.02 s, q 0.004 s), nothing carried.
TEST(PulseModulator, NearestRoundingFiresTheNearestLevel) {
  const ThrusterCluster c = actuator_test::cube_cluster(4.5, 0.02);
  ModulationSettings ms;
  ms.period = 0.5;
  ms.on_time_resolution = 0.004;
  ms.rounding = PulseRounding::Nearest;
  PulseModulator mod(c, ms);
  const std::vector<std::pair<double, double>> cases = {{0.0, 0.0},    {0.009, 0.0},    {0.0101, 0.02},
                                                        {0.019, 0.02}, {0.0291, 0.028}, {0.0301, 0.032},
                                                        {0.4999, 0.5}, {0.5, 0.5}};
  for (const auto& [tau_c, tau] : cases) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(c.size());
    f(0) = 4.5 * tau_c / ms.period;
    const Firing& fr = mod.modulate(c, 0.0, f);
    EXPECT_NEAR(fr.on_time(0), tau, 1e-15) << tau_c;
    EXPECT_EQ(mod.remainder()(0), 0.0);
  }
  EXPECT_NEAR(mod.on_time_error_bound(c, 0), 0.01, 1e-15);
  ms.rounding = PulseRounding::Carry;
  EXPECT_NEAR(PulseModulator(c, ms).on_time_error_bound(c, 0), 0.02, 1e-15);
}

// Per period, |tau - tau_c| <= on_time_error_bound for both roundings, and Nearest reaches its bound.
TEST(PulseModulator, OnePeriodsOnTimeErrorIsWithinItsBound) {
  const ThrusterCluster c = actuator_test::cube_cluster(4.5, 0.02);
  for (const PulseRounding rounding : {PulseRounding::Carry, PulseRounding::Nearest}) {
    ModulationSettings ms;
    ms.period = 0.5;
    ms.on_time_resolution = 0.004;
    ms.rounding = rounding;
    PulseModulator mod(c, ms);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Eigen::VectorXd f(c.size());
    double worst = 0.0;
    for (int k = 0; k < 500; ++k) {
      for (int j = 0; j < c.size(); ++j) f(j) = 4.5 * std::pow(u(rng), 3.0);
      const Firing& fr = mod.modulate(c, 0.5 * k, f);
      for (int j = 0; j < c.size(); ++j) {
        const double err = std::abs(fr.on_time(j) - f(j) * ms.period / 4.5);
        EXPECT_LE(err, mod.on_time_error_bound(c, j) + 1e-15) << to_string(rounding) << " " << k;
        worst = std::max(worst, err / mod.on_time_error_bound(c, j));
      }
    }
    EXPECT_GT(worst, 0.9) << to_string(rounding);
  }
}

// Opposed pairs (the cube cluster's thrusters 0 and 2 push along +-x on one line): the net command by hand
// (tau_min 0.02 s, q 0.001 s, dt 0.5 s), a sub-minimum net fired as tau_min + d against tau_min.
TEST(PulseModulator, OpposedPairsFireTheNetCommand) {
  const ThrusterCluster c = actuator_test::cube_cluster(4.5, 0.02);
  ModulationSettings ms;
  ms.period = 0.5;
  ms.on_time_resolution = 0.001;
  ms.rounding = PulseRounding::Nearest;
  ms.opposed_pairs = true;
  PulseModulator mod(c, ms);
  for (int j = 0; j < c.size(); ++j) {
    ASSERT_GE(mod.partner(j), 0) << j;
    EXPECT_EQ(mod.partner(mod.partner(j)), j);
    EXPECT_TRUE(c.mapping().col(j).isApprox(-c.mapping().col(mod.partner(j)))) << j;
  }
  ASSERT_EQ(mod.partner(0), 2);
  // {tau_c of 0, tau_c of 2} -> {tau of 0, tau of 2}.
  const std::vector<std::array<double, 4>> cases = {
      {0.0, 0.0, 0.0, 0.0},       {0.0004, 0.0, 0.0, 0.0},   {0.0123, 0.0, 0.032, 0.02},
      {0.0, 0.0019, 0.02, 0.022}, {0.0507, 0.0, 0.051, 0.0}, {0.3, 0.29, 0.03, 0.02},
      {0.1, 0.35, 0.0, 0.25},     {0.0196, 0.0, 0.04, 0.02}, {0.5, 0.0, 0.5, 0.0}};
  for (const auto& [tc0, tc2, t0, t2] : cases) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(c.size());
    f(0) = 4.5 * tc0 / ms.period;
    f(2) = 4.5 * tc2 / ms.period;
    const Firing& fr = mod.modulate(c, 0.0, f);
    EXPECT_NEAR(fr.on_time(0), t0, 1e-15) << tc0 << " " << tc2;
    EXPECT_NEAR(fr.on_time(2), t2, 1e-15) << tc0 << " " << tc2;
  }
  EXPECT_NEAR(mod.on_time_excess_bound(c, 0), 0.0205, 1e-15);
  // A failed partner: the other rounds alone to its nearest level.
  ThrusterCluster failed = c;
  failed.set_fault(2, FaultKind::FailedOff, 1.0);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(c.size());
  f(0) = 4.5 * 0.0123 / ms.period;
  EXPECT_NEAR(mod.modulate(failed, 0.5, f).on_time(0), 0.032, 1e-15);
  EXPECT_NEAR(mod.modulate(failed, 1.0, f).on_time(0), 0.02, 1e-15);
  EXPECT_EQ(mod.modulate(failed, 1.0, f).on_time(2), 0.0);
  // Set-up errors name the field.
  ms.rounding = PulseRounding::Carry;
  EXPECT_THROW(ms.validate(), std::invalid_argument);
  ms.rounding = PulseRounding::Nearest;
  ms.period = 0.039;
  try {
    PulseModulator too_short(c, ms);
    ADD_FAILURE() << "2 tau_min > period accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("modulation.opposed_pairs"), std::string::npos) << e.what();
  }
  ms.period = 0.5;
  // The +-x thrusters only (pairs 0-2 and 1-3), the -x ones weaker: no pair.
  auto specs = actuator_test::cube_specs(4.5, 0.02);
  specs.resize(4);
  specs[2].max_thrust = specs[3].max_thrust = 4.4;
  EXPECT_THROW(PulseModulator(ThrusterCluster(specs), ms), std::invalid_argument);
  specs[3].max_thrust = 4.5;
  EXPECT_EQ(PulseModulator(ThrusterCluster(specs), ms).partner(1), 3);
}

// With opposed pairs, per period and pair the net on-time error is at most q / 2, each thruster's on-time
// exceeds its command by at most on_time_excess_bound, and the nominal wrench error is within the modulation
// part of the error bound (M36).
TEST(PulseModulator, OpposedPairsErrorsAreWithinTheirBounds) {
  const ThrusterCluster c = actuator_test::cube_cluster(4.5, 0.02);
  ModulationSettings ms;
  ms.period = 0.5;
  ms.on_time_resolution = 0.004;
  ms.rounding = PulseRounding::Nearest;
  ms.opposed_pairs = true;
  PulseModulator mod(c, ms);
  Vector6 mod_bound = Vector6::Zero();
  for (int j = 0; j < c.size(); ++j)
    mod_bound += c.mapping().col(j).cwiseAbs() * (4.5 * mod.on_time_error_bound(c, j) / ms.period);
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::VectorXd f(c.size());
  double worst_net = 0.0, worst_excess = 0.0;
  for (int k = 0; k < 2000; ++k) {
    // Mostly sub-minimum commands, some large, often both of a pair.
    for (int j = 0; j < c.size(); ++j) f(j) = 4.5 * std::pow(u(rng), k % 2 ? 6.0 : 1.5) * (u(rng) < 0.7);
    const Firing& fr = mod.modulate(c, 0.5 * k, f);
    const Eigen::VectorXd tau_c = f * ms.period / 4.5;
    for (int j = 0; j < c.size(); ++j) {
      const int p = mod.partner(j);
      const double net = std::abs((fr.on_time(j) - fr.on_time(p)) - (tau_c(j) - tau_c(p)));
      ASSERT_LE(net, 0.5 * ms.on_time_resolution + 1e-15) << k;
      worst_net = std::max(worst_net, net / (0.5 * ms.on_time_resolution));
      const double excess = fr.on_time(j) - tau_c(j);
      ASSERT_LE(excess, mod.on_time_excess_bound(c, j) + 1e-15) << k;
      worst_excess = std::max(worst_excess, excess / mod.on_time_excess_bound(c, j));
      ASSERT_TRUE(fr.on_time(j) == 0.0 || fr.on_time(j) >= 0.02 - 1e-15) << k;
    }
    const Vector6 e = (fr.commanded_B - c.mapping() * (fr.on_time * 4.5 / ms.period)).cwiseAbs();
    for (int i = 0; i < 6; ++i) ASSERT_LE(e(i), mod_bound(i) + 1e-12) << k;
  }
  EXPECT_GT(worst_net, 0.9);
  EXPECT_GT(worst_excess, 0.9);
}

TEST(PulseModulator, FaultsOverrideTheCommandFromTheirTime) {
  ThrusterCluster c = actuator_test::cube_cluster();
  c.set_fault(0, FaultKind::StuckOn, 10.0);
  c.set_fault(1, FaultKind::FailedOff, 10.0);
  EXPECT_EQ(c.faults_at(9.99), 0);
  EXPECT_EQ(c.faults_at(10.0), 2);
  ModulationSettings ms;
  ms.period = 2.0;
  PulseModulator mod(c, ms);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(c.size());
  f(1) = 4.5;
  const Firing& before = mod.modulate(c, 8.0, f);
  EXPECT_EQ(before.on_time(0), 0.0);
  EXPECT_EQ(before.on_time(1), 2.0);
  const Firing& after = mod.modulate(c, 10.0, f);
  EXPECT_EQ(after.on_time(0), 2.0);
  EXPECT_EQ(after.on_time(1), 0.0);
  EXPECT_TRUE(after.delivered_B.isApprox(c.mapping().col(0) * 4.5));
}
