// The inner box of achievable wrenches and the certified actuation-error box.
#include <gtest/gtest.h>

#include <random>

#include "actuator_fixtures.hpp"
#include "tubempc/actuators/achievable_set.hpp"

using namespace tubempc::actuators;

TEST(AchievableBox, IsAchievableAndNearlyMaximal) {
  const ThrusterCluster c = actuator_test::cube_cluster();
  const ReactionWheels w = actuator_test::pyramid_wheels();
  AllocationSettings as;
  as.period = 1.0;
  AchievableBoxSettings bs;
  bs.tolerate_one_failure = false;
  bs.shape << 1.0, 1.0, 1.0, 0.5, 0.5, 0.5;
  const AchievableBox box = achievable_box(c, w, as, 1000.0, bs);
  ASSERT_GT(box.scale, 0.0);
  // A pure force along x: two thrusters of 4.5 N, so the healthy box cannot exceed 9 N on any force axis.
  EXPECT_LE(box.half_width_B(0), 9.0);
  // Random points of the box are delivered; the box grown by 1 % has an undelivered vertex.
  Allocator a(c, w, as);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    Vector6 cmd;
    for (int i = 0; i < 6; ++i) cmd(i) = u(rng) * box.half_width_B(i);
    EXPECT_EQ(a.solve(c, w, 0.0, cmd).info.status, AllocationStatus::Ok) << cmd.transpose();
  }
  bool undelivered = false;
  for (int v = 0; v < 64; ++v) {
    Vector6 cmd;
    for (int i = 0; i < 6; ++i) cmd(i) = ((v >> i) & 1 ? 1.01 : -1.01) * box.half_width_B(i);
    undelivered = undelivered || a.solve(c, w, 0.0, cmd).info.status != AllocationStatus::Ok;
  }
  EXPECT_TRUE(undelivered);
  EXPECT_NEAR(box.input_half_width(0), box.half_width_B.head<3>().minCoeff() / (1000.0 * std::sqrt(3.0)),
              1e-15);
  EXPECT_EQ(box.input_half_width(4), box.half_width_B(4));
}

TEST(AchievableBox, OneFailureShrinksItAndStillHolds) {
  ThrusterCluster c = actuator_test::cube_cluster();
  const ReactionWheels w = actuator_test::pyramid_wheels();
  AllocationSettings as;
  AchievableBoxSettings bs;
  bs.tolerate_one_failure = false;
  const AchievableBox healthy = achievable_box(c, w, as, 1000.0, bs);
  bs.tolerate_one_failure = true;
  const AchievableBox box = achievable_box(c, w, as, 1000.0, bs);
  ASSERT_GT(box.scale, 0.0);  // the wheels cover the torque of a lone thruster of a pair
  EXPECT_LT(box.scale, healthy.scale);
  EXPECT_GE(box.limiting_failure, 0);
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  ReactionWheels wheels = w;
  for (int j = 0; j < c.size(); ++j) {
    ThrusterCluster failed = c;
    failed.set_fault(j, FaultKind::FailedOff, 0.0);
    Allocator a(failed, wheels, as);
    for (int k = 0; k < 20; ++k) {
      Vector6 cmd;
      for (int i = 0; i < 6; ++i) cmd(i) = u(rng) * box.half_width_B(i);
      EXPECT_EQ(a.solve(failed, wheels, 0.0, cmd).info.status, AllocationStatus::ThrusterFailed) << j;
    }
  }
}

// Every sampled error (allocated minus delivered wrench, with truth errors drawn within their bounds and the
// modulation's quantisation and minimum impulse) lies in the certified box, and the box is not loose by more
// than a factor of 5 on some component.
TEST(ActuationErrorBound, ContainsEverySampledError) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto specs = actuator_test::cube_specs(4.5, 0.02);
  for (auto& s : specs) {
    s.scale_error_bound = 0.05;
    s.misalignment_bound = 0.5 * M_PI / 180;
    s.scale_error = 0.05 * u(rng);
    Eigen::Vector3d axis(u(rng), u(rng), u(rng));
    s.misalignment_B = axis.normalized() * s.misalignment_bound * std::abs(u(rng));
  }
  const ThrusterCluster c(specs);
  ReactionWheels w = actuator_test::pyramid_wheels();
  AllocationSettings as;
  as.period = 2.0;
  ModulationSettings ms;
  ms.period = 2.0;
  ms.on_time_resolution = 0.01;
  PulseModulator mod(c, ms);
  const ActuationErrorBound bound = actuation_error_bound(c, mod, 1200.0);
  Allocator a(c, w, as);
  Vector6 worst = Vector6::Zero();
  for (int k = 0; k < 2000; ++k) {
    Vector6 cmd;
    const double s = k % 3 == 0 ? 0.02 : (k % 3 == 1 ? 1.0 : 4.0);  // below the minimum impulse; saturating
    for (int i = 0; i < 6; ++i) cmd(i) = s * u(rng) * (i < 3 ? 3.0 : 0.5);
    const AllocationResult& r = a.solve(c, w, 2.0 * k, cmd);
    const Firing& f = mod.modulate(c, 2.0 * k, r.thrust);
    const Vector6 e = f.commanded_B - f.delivered_B;  // the wheels deliver their allocation exactly
    for (int i = 0; i < 6; ++i) {
      ASSERT_LE(std::abs(e(i)), bound.wrench_B(i)) << "component " << i << " step " << k;
      worst(i) = std::max(worst(i), std::abs(e(i)) / bound.wrench_B(i));
    }
  }
  EXPECT_GT(worst.maxCoeff(), 0.2);
  EXPECT_NEAR(bound.input(0), bound.wrench_B.head<3>().norm() / 1200.0, 1e-15);
  EXPECT_TRUE(bound.wrench_B.isApprox(bound.modulation_B + bound.misalignment_B));
  // The torque ellipsoid contains the torque box: its 8 vertices lie on it.
  for (int v = 0; v < 8; ++v) {
    Eigen::Vector3d c;
    for (int i = 0; i < 3; ++i) c(i) = ((v >> i) & 1 ? 1.0 : -1.0) * bound.wrench_B(3 + i);
    EXPECT_NEAR(c.dot(bound.shape_T.ldlt().solve(c)), 1.0, 1e-12);
  }
}

// For commands inside a box the thrusters alone can deliver with the wheels' torques on top, the thrust norm is
// bounded (while the wheels dump too), and so is every sampled error, by a box tighter than the one for any
// command.
TEST(ActuationErrorBound, InABoxBoundsTheThrustNormAndTheErrors) {
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto specs = actuator_test::cube_specs(4.5, 0.02);
  for (auto& s : specs) {
    s.scale_error_bound = 0.05;
    s.misalignment_bound = 0.5 * M_PI / 180;
    s.scale_error = 0.05 * u(rng);
    s.misalignment_B =
        Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * s.misalignment_bound * std::abs(u(rng));
  }
  const ThrusterCluster c(specs);
  MomentumDumpSettings dump;
  dump.time_constant = 30.0;
  ReactionWheels w = actuator_test::pyramid_wheels(0.2, 8.0, dump);
  AllocationSettings as;
  as.period = 1.0;
  ModulationSettings ms;
  ms.period = 1.0;
  ms.on_time_resolution = 0.005;
  PulseModulator mod(c, ms);
  AchievableBoxSettings bs;
  bs.tolerate_one_failure = false;
  const Vector6 half = 0.5 * achievable_box(c, w, as, 800.0, bs).half_width_B;
  const ActuationErrorBound any = actuation_error_bound(c, mod, 800.0);
  const ActuationErrorBound in_box = actuation_error_bound(c, mod, 800.0, w, as, half, 0.0, false);
  EXPECT_LT(in_box.thrust_norm, 0.5 * any.thrust_norm);
  for (int i = 0; i < 6; ++i) EXPECT_LE(in_box.wrench_B(i), any.wrench_B(i));
  EXPECT_LT(in_box.wrench_B(0), 0.8 * any.wrench_B(0));
  Eigen::VectorXd h(4);
  h << 7.0, -7.0, 7.0, -7.0;
  w.set_momentum(h);
  Allocator a(c, w, as);
  int dumping = 0;
  Vector6 worst = Vector6::Zero();
  for (int k = 0; k < 600; ++k) {
    Vector6 cmd;
    for (int i = 0; i < 6; ++i) cmd(i) = u(rng) * half(i);
    const AllocationResult& r = a.solve(c, w, k, cmd);
    ASSERT_EQ(r.info.status, AllocationStatus::Ok);
    ASSERT_LE(r.thrust.norm(), in_box.thrust_norm) << k;
    const Firing& f = mod.modulate(c, k, r.thrust);
    w.apply(r.wheel_torque, 1.0);
    dumping += r.info.dumping;
    const Vector6 e = f.commanded_B - f.delivered_B;
    for (int i = 0; i < 6; ++i) {
      ASSERT_LE(std::abs(e(i)), in_box.wrench_B(i)) << "component " << i << " step " << k;
      worst(i) = std::max(worst(i), std::abs(e(i)) / in_box.wrench_B(i));
    }
  }
  EXPECT_GT(dumping, 10);
  EXPECT_GT(worst.maxCoeff(), 0.1);
  // Forces of norm <= rho (the octahedral cut of the force box): a smaller thrust norm, which still bounds the
  // allocation of every such command, and errors within the cut bound.
  const double rho = half.head<3>().minCoeff();
  Vector6 cut_half = half;
  cut_half.head<3>().setConstant(rho);
  cut_half.tail<3>() *= 0.1;  // torques small: the forces set the thrust norm
  const ActuationErrorBound boxed = actuation_error_bound(c, mod, 800.0, w, as, cut_half, 0.0, false);
  const ActuationErrorBound cut = actuation_error_bound(c, mod, 800.0, w, as, cut_half, 0.0, false, rho);
  EXPECT_LT(cut.thrust_norm, 0.9 * boxed.thrust_norm);
  for (int i = 0; i < 6; ++i) EXPECT_LE(cut.wrench_B(i), boxed.wrench_B(i));
  std::normal_distribution<double> g(0.0, 1.0);
  double nearest_norm = 0.0;
  for (int k = 0; k < 600; ++k) {
    Vector6 cmd;
    cmd.head<3>() = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized() * rho * std::cbrt(std::abs(u(rng)));
    for (int i = 3; i < 6; ++i) cmd(i) = u(rng) * cut_half(i);
    const AllocationResult& r = a.solve(c, w, 600 + k, cmd);
    ASSERT_EQ(r.info.status, AllocationStatus::Ok);
    ASSERT_LE(r.thrust.norm(), cut.thrust_norm) << k;
    nearest_norm = std::max(nearest_norm, r.thrust.norm() / cut.thrust_norm);
    const Firing& f = mod.modulate(c, 600 + k, r.thrust);
    w.apply(r.wheel_torque, 1.0);
    const Vector6 e = f.commanded_B - f.delivered_B;
    for (int i = 0; i < 6; ++i)
      ASSERT_LE(std::abs(e(i)), cut.wrench_B(i)) << "component " << i << " step " << k;
  }
  EXPECT_GT(nearest_norm, 0.5);
  // Nearest rounding halves the modulation part exactly; the misalignment part keeps its thrust norm.
  ms.rounding = PulseRounding::Nearest;
  const ActuationErrorBound nearest =
      actuation_error_bound(c, PulseModulator(c, ms), 800.0, w, as, half, 0.0, false);
  EXPECT_TRUE(nearest.modulation_B.isApprox(0.5 * in_box.modulation_B, 1e-14));
  EXPECT_NEAR(nearest.thrust_norm, in_box.thrust_norm, 1e-12);
  for (int i = 0; i < 6; ++i) EXPECT_LE(nearest.misalignment_B(i), in_box.misalignment_B(i));
  // Opposed pairs: the same modulation part, a larger misalignment part (a pair fires tau_min against a
  // sub-minimum net), and every sampled error within the bound.
  ms.opposed_pairs = true;
  PulseModulator paired(c, ms);
  const ActuationErrorBound pairs = actuation_error_bound(c, paired, 800.0, w, as, half, 0.0, false);
  EXPECT_TRUE(pairs.modulation_B.isApprox(nearest.modulation_B, 1e-14));
  for (int i = 0; i < 6; ++i) EXPECT_GE(pairs.misalignment_B(i), nearest.misalignment_B(i));
  worst.setZero();
  for (int k = 0; k < 600; ++k) {
    Vector6 cmd;
    for (int i = 0; i < 6; ++i) cmd(i) = u(rng) * half(i) * (k % 2 ? 1.0 : 0.01);
    const AllocationResult& r = a.solve(c, w, 1200 + k, cmd);
    ASSERT_EQ(r.info.status, AllocationStatus::Ok);
    const Firing& f = paired.modulate(c, 1200 + k, r.thrust);
    w.apply(r.wheel_torque, 1.0);
    const Vector6 e = f.commanded_B - f.delivered_B;
    for (int i = 0; i < 6; ++i) {
      ASSERT_LE(std::abs(e(i)), pairs.wrench_B(i)) << "component " << i << " step " << k;
      worst(i) = std::max(worst(i), std::abs(e(i)) / pairs.wrench_B(i));
    }
  }
  EXPECT_GT(worst.maxCoeff(), 0.05);
}

// The box tolerating one failure is the smallest of the boxes with each thruster failed in turn; a stuck-on
// thruster the others balance leaves a box, and the boxes respect the fault time.
TEST(AchievableBox, OneFailureBoxIsTheSmallestSingleFaultBox) {
  ThrusterCluster c = actuator_test::cube_cluster();
  const ReactionWheels w = actuator_test::pyramid_wheels();
  AllocationSettings as;
  AchievableBoxSettings bs;
  bs.bisection_steps = 30;
  const AchievableBox tolerant = achievable_box(c, w, as, 1000.0, bs);
  bs.tolerate_one_failure = false;
  double smallest = 1e300;
  for (int j = 0; j < c.size(); ++j) {
    ThrusterCluster failed = c;
    failed.set_fault(j, FaultKind::FailedOff, 10.0);
    bs.time = 10.0;
    const AchievableBox b = achievable_box(failed, w, as, 1000.0, bs);
    EXPECT_GE(b.scale, tolerant.scale * (1 - 1e-6)) << j;
    smallest = std::min(smallest, b.scale);
    bs.time = 9.0;  // before the fault: the healthy box
    if (j == 0) EXPECT_GT(achievable_box(failed, w, as, 1000.0, bs).scale, b.scale);
  }
  EXPECT_NEAR(smallest, tolerant.scale, 1e-6 * tolerant.scale);
  c.set_fault(0, FaultKind::StuckOn, 0.0);
  bs.time = 0.0;
  const AchievableBox stuck = achievable_box(c, w, as, 1000.0, bs);
  EXPECT_FALSE(stuck.empty);  // its opposite thruster cancels it
  EXPECT_GT(stuck.scale, 0.0);
  // Four thrusters along +z, one stuck on: nothing cancels its force, not even a zero wrench is delivered.
  std::vector<ThrusterSpec> up;
  for (double x : {1.0, -1.0})
    for (double y : {1.0, -1.0}) {
      ThrusterSpec s;
      s.position_B = Eigen::Vector3d(x, y, -1.0);
      up.push_back(s);
    }
  ThrusterCluster u(up);
  u.set_fault(2, FaultKind::StuckOn, 0.0);
  const AchievableBox none = achievable_box(u, ReactionWheels({}), as, 1000.0, bs);
  EXPECT_TRUE(none.empty);
  EXPECT_EQ(none.half_width_B.norm(), 0.0);
}
