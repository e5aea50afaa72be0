// Allocation: optimality (KKT of the bounded least squares), statuses, faults, momentum dumping, frames.
#include <gtest/gtest.h>

#include <random>

#include "actuator_fixtures.hpp"
#include "tubempc/actuators/allocation.hpp"

using namespace tubempc::actuators;

namespace {

// KKT of min ||A x - b||^2 on the box: the gradient vanishes on free variables and points inwards at bounds.
void expect_kkt(const Allocator& a, const AllocationResult& r) {
  Eigen::MatrixXd A;
  Eigen::VectorXd b, lo, hi;
  a.last_problem(A, b, lo, hi);
  Eigen::VectorXd x(A.cols());
  x << r.thrust, r.wheel_torque;
  const Eigen::VectorXd g = A.transpose() * (A * x - b);
  const double tol = 1e-9 * (1.0 + (A.transpose() * b).cwiseAbs().maxCoeff());
  for (int i = 0; i < x.size(); ++i) {
    ASSERT_GE(x(i), lo(i));
    ASSERT_LE(x(i), hi(i));
    if (x(i) > lo(i) + 1e-12 && x(i) < hi(i) - 1e-12) {
      EXPECT_NEAR(g(i), 0.0, tol) << i;
    } else if (x(i) <= lo(i) + 1e-12 && lo(i) < hi(i)) {
      EXPECT_GE(g(i), -tol) << i;
    } else if (lo(i) < hi(i)) {
      EXPECT_LE(g(i), tol) << i;
    }
  }
}

}  // namespace

TEST(Allocation, RandomCommandsSatisfyTheOptimalityConditions) {
  const ThrusterCluster c = actuator_test::cube_cluster();
  ReactionWheels w = actuator_test::pyramid_wheels();
  Allocator a(c, w);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  int ok = 0, saturated = 0;
  for (int k = 0; k < 300; ++k) {
    Vector6 cmd;
    const double scale = k % 2 ? 1.0 : 12.0;  // half of them beyond the cluster's reach
    for (int i = 0; i < 6; ++i) cmd(i) = scale * n(rng);
    const AllocationResult& r = a.solve(c, w, 0.0, cmd);
    expect_kkt(a, r);
    EXPECT_TRUE((r.wrench_B + r.remainder_B).isApprox(cmd, 1e-12));
    ok += r.info.status == AllocationStatus::Ok;
    saturated += r.info.status == AllocationStatus::Saturated;
    if (r.info.status == AllocationStatus::Ok)
      EXPECT_LT(r.remainder_B.cwiseAbs().maxCoeff(), 1e-4 * (1 + cmd.norm()));
  }
  EXPECT_GT(ok, 100);
  EXPECT_GT(saturated, 100);
  EXPECT_EQ(ok + saturated, 300);
}

TEST(Allocation, AchievableCommandIsDeliveredExactly) {
  const ThrusterCluster c = actuator_test::cube_cluster();
  ReactionWheels w = actuator_test::pyramid_wheels();
  Allocator a(c, w);
  Vector6 cmd;
  cmd << 1.0, -2.0, 0.5, 0.3, -0.1, 0.2;
  const AllocationResult& r = a.solve(c, w, 0.0, cmd);
  EXPECT_EQ(r.info.status, AllocationStatus::Ok);
  EXPECT_EQ(to_string(r.info.status), "ok");
  EXPECT_LT(r.remainder_B.norm(), 1e-5);
  EXPECT_TRUE(
      (a.mapping() * (Eigen::VectorXd(16) << r.thrust, r.wheel_torque).finished()).isApprox(r.wrench_B));
  EXPECT_GE(r.thrust.minCoeff(), 0.0);
  EXPECT_LE(r.thrust.maxCoeff(), 4.5);
}

TEST(Allocation, DirectionNoThrusterProducesIsInfeasible) {
  // Four thrusters that all push along +z: a force along -z cannot be produced at any magnitude.
  std::vector<ThrusterSpec> specs;
  for (double x : {1.0, -1.0})
    for (double y : {1.0, -1.0}) {
      ThrusterSpec s;
      s.position_B = Eigen::Vector3d(x, y, -1.0);
      specs.push_back(s);
    }
  const ThrusterCluster c(specs);
  ReactionWheels w({}, MomentumDumpSettings{});
  Allocator a(c, w);
  Vector6 up = Vector6::Zero(), down = Vector6::Zero();
  up(2) = 100.0;
  down(2) = -0.1;
  EXPECT_EQ(a.solve(c, w, 0.0, up).info.status, AllocationStatus::Saturated);
  EXPECT_NEAR(a.solve(c, w, 0.0, up).remainder_B(2), 96.0, 1e-3);
  const AllocationResult& r = a.solve(c, w, 0.0, down);
  EXPECT_EQ(r.info.status, AllocationStatus::Infeasible);
  EXPECT_EQ(to_string(r.info.status), "infeasible");
  EXPECT_NEAR(r.remainder_B(2), -0.1, 1e-9);
  EXPECT_LT(r.thrust.maxCoeff(), 1e-9);
}

TEST(Allocation, FailedThrusterIsReSolvedAroundWithANamedStatus) {
  ThrusterCluster c = actuator_test::cube_cluster();
  ReactionWheels w = actuator_test::pyramid_wheels();
  Allocator a(c, w);
  Vector6 cmd;
  cmd << 0.0, 0.0, 0.0, 0.0, 0.0, 0.3;  // torque about z: the x thrusters' couples or the wheels
  const AllocationResult& r0 = a.solve(c, w, 0.0, cmd);
  EXPECT_EQ(r0.info.status, AllocationStatus::Ok);
  EXPECT_GT(r0.thrust(1), 0.02);  // the +x thruster at y = -0.5 is in the +z couple
  c.set_fault(1, FaultKind::FailedOff, 5.0);
  EXPECT_EQ(a.solve(c, w, 4.0, cmd).info.status, AllocationStatus::Ok);
  const AllocationResult& r1 = a.solve(c, w, 5.0, cmd);
  EXPECT_TRUE(r1.info.resetup);
  EXPECT_EQ(r1.info.failed_thrusters, 1);
  EXPECT_EQ(r1.info.status, AllocationStatus::ThrusterFailed);
  EXPECT_EQ(to_string(r1.info.status), "thruster_failed");
  EXPECT_EQ(r1.thrust(1), 0.0);
  EXPECT_LT(r1.remainder_B.norm(), 1e-5);
  EXPECT_FALSE(a.solve(c, w, 6.0, cmd).info.resetup);
  // Stuck on: fixed at full thrust, the others cancel its force and torque.
  c.set_fault(1, FaultKind::StuckOn, 7.0);
  const AllocationResult& r2 = a.solve(c, w, 7.0, Vector6::Zero());
  EXPECT_EQ(r2.info.status, AllocationStatus::ThrusterFailed);
  EXPECT_EQ(r2.thrust(1), 4.5);
  EXPECT_LT(r2.wrench_B.norm(), 1e-4);
}

TEST(Allocation, WheelsAreUnloadedByThrusterTorque) {
  ThrusterCluster c = actuator_test::cube_cluster();
  ReactionWheels w = actuator_test::pyramid_wheels(0.2, 50.0);
  Eigen::VectorXd h(4);
  h << 45.0, 0.0, -10.0, 0.0;
  w.set_momentum(h);
  ASSERT_TRUE(w.dumping());
  Allocator a(c, w);
  const AllocationResult& r = a.solve(c, w, 0.0, Vector6::Zero());
  EXPECT_TRUE(r.info.dumping);
  EXPECT_EQ(r.info.status, AllocationStatus::Ok);
  Eigen::VectorXd pref;
  w.preferred_torque(pref);
  EXPECT_LT((r.wheel_torque - pref).norm(), 1e-3 * pref.norm());  // the wheels unload at the preferred rate
  EXPECT_LT(r.wrench_B.norm(), 1e-5);                             // while the thrusters hold the attitude
  const Eigen::VectorXd h0 = w.momentum();
  w.apply(r.wheel_torque, 1.0);
  EXPECT_LT(std::abs(w.momentum()(0)), std::abs(h0(0)));
}

TEST(Allocation, NonFiniteCommandGivesAFiniteRestAllocation) {
  const ThrusterCluster c = actuator_test::cube_cluster();
  ReactionWheels w = actuator_test::pyramid_wheels();
  Allocator a(c, w);
  Vector6 cmd = Vector6::Zero();
  cmd(4) = std::nan("");
  const AllocationResult& r = a.solve(c, w, 0.0, cmd);
  EXPECT_EQ(r.info.status, AllocationStatus::InvalidCommand);
  EXPECT_TRUE(r.thrust.allFinite() && r.wheel_torque.allFinite() && r.remainder_B.allFinite());
  EXPECT_EQ(r.thrust.norm(), 0.0);
  AllocationSettings bad;
  bad.thrust_weight = 0.0;
  try {
    Allocator b(c, w, bad);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("allocation.thrust_weight"), std::string::npos);
  }
}

TEST(Allocation, InputAndWrenchAreInverseWithMassAndFrame) {
  Eigen::Matrix3d C_BL = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Vector6 u;
  u << 1e-3, -2e-3, 5e-4, 0.1, 0.2, -0.3;
  const Vector6 w = wrench_from_input(u, C_BL, 1500.0);
  EXPECT_NEAR(w.head<3>().norm(), 1500.0 * u.head<3>().norm(), 1e-12);
  EXPECT_TRUE(w.head<3>().isApprox(1500.0 * C_BL * u.head<3>()));
  EXPECT_TRUE(input_from_wrench(w, C_BL, 1500.0).isApprox(u, 1e-14));
}

// A whole dump: allocation, modulation and wheel update in a loop with no command. The wheels unload below
// the stop fraction, and the torque the spacecraft receives (thrusters' delivered plus wheels') sums to a
// total angular impulse within one modulation remainder per thruster (the attitude is held).
TEST(Allocation, DumpUnloadsTheWheelsWhileHoldingTheAttitude) {
  const ThrusterCluster c = actuator_test::cube_cluster(4.5, 0.02);
  MomentumDumpSettings dump;
  dump.time_constant = 60.0;
  ReactionWheels w = actuator_test::pyramid_wheels(0.2, 20.0, dump);
  Eigen::VectorXd h(4);
  h << 17.0, -6.0, 3.0, 9.0;
  w.set_momentum(h);
  ASSERT_TRUE(w.dumping());
  const Eigen::Vector3d H0 = w.momentum_B();
  AllocationSettings as;
  as.period = 1.0;
  ModulationSettings ms;
  ms.period = 1.0;
  Allocator a(c, w, as);
  PulseModulator mod(c, ms);
  Eigen::Vector3d angular_impulse = Eigen::Vector3d::Zero(), linear_impulse = Eigen::Vector3d::Zero();
  int k = 0;
  for (; k < 2000 && w.dumping(); ++k) {
    const AllocationResult& r = a.solve(c, w, k, Vector6::Zero());
    ASSERT_EQ(r.info.status, AllocationStatus::Ok) << k;
    const Firing& f = mod.modulate(c, k, r.thrust);
    angular_impulse += f.delivered_B.tail<3>() + w.apply(r.wheel_torque, ms.period);
    linear_impulse += f.delivered_B.head<3>();
  }
  EXPECT_FALSE(w.dumping());
  EXPECT_LE(w.momentum().cwiseAbs().maxCoeff(), 0.2 * 20.0);
  EXPECT_GT(k, 50);
  // The body's angular momentum change is the external (thruster) impulse: the wheels' change plus it is 0.
  double slack_T = 0.0, slack_F = 0.0;
  for (int j = 0; j < c.size(); ++j) {
    slack_T += c.mapping().col(j).tail<3>().norm() * 4.5 * mod.remainder_bound(c, j);
    slack_F += 4.5 * mod.remainder_bound(c, j);
  }
  EXPECT_LT(angular_impulse.norm(), slack_T + 1e-6 * k);
  EXPECT_LT(linear_impulse.norm(), slack_F + 1e-6 * k);
  EXPECT_LT(w.momentum_B().norm(), 0.3 * H0.norm());
}
