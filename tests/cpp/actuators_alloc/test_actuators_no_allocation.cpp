// The per-step actuator path (allocation, pulse modulation, wheel update) must not allocate after set-up,
// including the Saturated/Infeasible cone test, a fault's re-setup and momentum dumping: every malloc-family
// call and operator new is counted around it (tests/cpp/support/tubempc_testing/allocation_counter.hpp, glibc only).
#include <gtest/gtest.h>

#include <random>

#include "../actuators/actuator_fixtures.hpp"
#include "tubempc/actuators/allocation.hpp"
#include "tubempc/actuators/system.hpp"
#include "tubempc_testing/allocation_counter.hpp"

using namespace tubempc::actuators;
using tubempc_testing::AllocationWindow;

TEST(ActuatorsAllocation, CounterSeesAllocations) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  AllocationWindow window;
  Eigen::VectorXd v(100);
  v.setZero();
  EXPECT_GE(window.count(), 1);
}

TEST(ActuatorsAllocation, StepDoesNotAllocateAfterSetup) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  ThrusterCluster cluster = actuator_test::cube_cluster();
  cluster.set_fault(5, FaultKind::FailedOff, 100.0);
  cluster.set_fault(8, FaultKind::StuckOn, 200.0);
  MomentumDumpSettings dump;
  dump.time_constant = 50.0;
  ReactionWheels wheels = actuator_test::pyramid_wheels(0.2, 2.0, dump);  // small: dumps often
  AllocationSettings as;
  as.period = 1.0;
  ModulationSettings ms;
  ms.period = 1.0;
  Allocator alloc(cluster, wheels, as);
  PulseModulator mod(cluster, ms);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6 cmd;
  long allocations = 0;
  int statuses[6] = {0, 0, 0, 0, 0, 0};
  int dumping = 0;
  for (int k = 0; k < 300; ++k) {
    for (int i = 0; i < 6; ++i) cmd(i) = (k % 4 == 0 ? 20.0 : 0.5) * n(rng) * (i < 3 ? 1.0 : 0.3);
    if (k == 150) cmd(0) = std::nan("");
    {
      AllocationWindow window;
      const AllocationResult& r = alloc.solve(cluster, wheels, k, cmd);
      mod.modulate(cluster, k, r.thrust);
      wheels.apply(r.wheel_torque, ms.period);
      ++statuses[static_cast<int>(r.info.status)];
      dumping += r.info.dumping;
      allocations += window.count();
    }
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(statuses[static_cast<int>(AllocationStatus::Ok)], 0);
  EXPECT_GT(statuses[static_cast<int>(AllocationStatus::Saturated)], 0);
  EXPECT_GT(statuses[static_cast<int>(AllocationStatus::ThrusterFailed)], 0);
  EXPECT_EQ(statuses[static_cast<int>(AllocationStatus::InvalidCommand)], 1);
  EXPECT_GT(dumping, 0);
}

TEST(ActuatorsAllocation, ActuationSystemStepDoesNotAllocate) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  ThrusterCluster cluster = actuator_test::cube_cluster();
  cluster.set_fault(3, FaultKind::FailedOff, 80.0);
  cluster.set_fault(9, FaultKind::StuckOn, 240.0);
  MomentumDumpSettings dump;
  dump.time_constant = 50.0;
  ActuationSettings settings;
  settings.mass = 200.0;
  settings.modulation.period = 1.0;
  settings.modulation.rounding = PulseRounding::Nearest;
  settings.modulation.opposed_pairs =
      true;  // the pairs' path (thrusters 3 and 9 fail: their partners round alone)
  settings.allocation.period = 1.0;
  ActuationSystem sys(cluster, actuator_test::pyramid_wheels(0.2, 2.0, dump), settings);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6 u;
  Eigen::Matrix3d C_BL = Eigen::Matrix3d::Identity();
  long allocations = 0;
  int statuses[6] = {0, 0, 0, 0, 0, 0};
  for (int k = 0; k < 300; ++k) {
    for (int i = 0; i < 6; ++i) u(i) = (k % 5 == 0 ? 0.1 : 0.005) * n(rng) * (i < 3 ? 1.0 : 20.0);
    if (k == 100) u(4) = std::nan("");
    C_BL = Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
    AllocationWindow window;
    const ActuationStep& st = sys.step(k, u, C_BL);
    ++statuses[static_cast<int>(st.status)];
    allocations += window.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(statuses[static_cast<int>(AllocationStatus::Ok)], 0);
  EXPECT_GT(statuses[static_cast<int>(AllocationStatus::Saturated)], 0);
  EXPECT_GT(statuses[static_cast<int>(AllocationStatus::ThrusterFailed)], 0);
  EXPECT_EQ(statuses[static_cast<int>(AllocationStatus::InvalidCommand)], 1);
}
