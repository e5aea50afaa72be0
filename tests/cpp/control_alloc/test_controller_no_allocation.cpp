// Controller::step (identification, tube update and MPC) and Controller::identify must not allocate
// after setup: every malloc-family call and operator new is counted around them
// (tests/cpp/support/tubempc_testing/allocation_counter.hpp, glibc only).
#include <gtest/gtest.h>

#include <random>

#include "tubempc/control/abort.hpp"
#include "tubempc/control/controller.hpp"
#include "tubempc_testing/allocation_counter.hpp"
#include "tubempc_testing/control_fixtures.hpp"

using namespace tubempc::control;
using tubempc_testing::AllocationWindow;

TEST(ControllerAllocation, CounterSeesAllocations) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  void* (*volatile allocate)(std::size_t) = std::malloc;
  void (*volatile release)(void*) = std::free;
  AllocationWindow window;
  release(allocate(64));
  Eigen::VectorXd v(100);
  v.setZero();
  EXPECT_GE(window.count(), 3);  // malloc and free, the vector's allocation (freed after the check)
}

TEST(ControllerAllocation, StepDoesNotAllocateAfterSetup) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  const double dt = 2.0;
  const int T = 40;
  auto model = control_test::plant_12_6(dt);
  const tubempc::mpc::Settings mpc = control_test::plant_12_6_mpc(dt, 15);
  ControllerSettings settings;
  settings.identification_p.S0 = SubMatrix::Identity() * 1e-4;
  settings.identification_r.S0 = SubMatrix::Identity() * 1e-8;
  settings.tube.alpha_search_period = 3;  // many due designs: the library path runs often
  // An actuation-error set per subsystem: every step grows P_W by B E (its Minkowski bound runs in the step).
  settings.actuation_error = {Eigen::Matrix3d::Identity() * 1e-6, Eigen::Matrix3d::Identity() * 1e-4};
  settings.feedforward = true;  // the identified mean's feed-forward runs in the step too
  const ControllerDesigns designs = control_test::plant_12_6_designs(
      dt, settings.identification_p.S0, settings.identification_r.S0, {0.25, 1.0, 4.0, 16.0}, 1e-6);
  Controller ctrl(model, mpc, settings);
  tubempc::mpc::Reference ref;
  ref.z = Eigen::MatrixXd::Zero(12, T + 1);
  ref.u = Eigen::MatrixXd::Zero(6, T);
  for (int j = 0; j <= T; ++j) ref.z(0, j) = 30.0 * (1.0 - static_cast<double>(j) / T);
  ctrl.setup(ref, designs);
  Eigen::VectorXd x = ref.z.col(0), x_next(12), c(12);
  Eigen::MatrixXd Ad(12, 12), Bd(12, 6);
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0.0, 1.0);
  long allocations = 0;
  int library_steps = 0, grown = 0, fed = 0;
  for (int k = 0; k < T; ++k) {
    {
      AllocationWindow window;
      const ControlStep& r = ctrl.step(k, x);
      model->discretize(0.0, dt, x, r.u, Ad, Bd, c);
      x_next.noalias() = Ad * x;
      x_next.noalias() += Bd * r.u;
      library_steps += r.tube_status[0] == TubeStatus::Library || r.tube_status[1] == TubeStatus::Library;
      allocations += window.count();
      fed += r.u_feedforward.norm() > 0.0;
      for (int s = 0; s < 2; ++s) grown += (r.P_W[s] - ctrl.identifier(s).P_W()).trace() > 0.0;
    }
    for (int i = 0; i < 12; ++i) x_next(i) += c(i) + n(rng) * (i < 6 ? 1e-2 : 1e-4 * (1 + k));
    x = x_next;
  }
  {
    AllocationWindow window;
    ctrl.identify(T, x);
    allocations += window.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(library_steps, 0);  // the library path was exercised too
  EXPECT_EQ(grown, 2 * T);      // every step certified its tube for the grown set
  EXPECT_GT(fed, 0);            // and fed the identified mean forward
}

// The abort supervision and the abort controller's steps: nothing allocated after setup either.
TEST(ControllerAllocation, AbortMonitorAndStepDoNotAllocate) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  const double dt = 2.0;
  const int T = 30;
  auto model = control_test::plant_12_6(dt);
  ControllerSettings settings;
  settings.identification_p.S0 = SubMatrix::Identity() * 1e-4;
  settings.identification_r.S0 = SubMatrix::Identity() * 1e-8;
  const ControllerDesigns designs = control_test::plant_12_6_designs(
      dt, settings.identification_p.S0, settings.identification_r.S0, {1.0, 4.0});
  AbortSettings abort_settings;
  abort_settings.commit_step = 5;
  SafeAbort abort(model, control_test::plant_12_6_mpc(dt, 10), settings, abort_settings);
  tubempc::mpc::Reference hover;
  hover.z = Eigen::MatrixXd::Zero(12, T + 1);
  hover.u = Eigen::MatrixXd::Zero(6, T);
  hover.z.row(0).setConstant(40.0);
  abort.setup(hover, designs);
  const Eigen::MatrixXd P_est = Eigen::MatrixXd::Identity(12, 12) * 1e-6;
  abort.set_estimation_error(P_est);  // allocates its storage on the first call (set-up)
  Eigen::VectorXd x = Eigen::VectorXd::Zero(12), x_next(12), c(12);
  x(0) = 10.0;
  Eigen::MatrixXd Ad(12, 12), Bd(12, 6);
  // the descent: a controller flying the same hover, whose step feeds the supervision's triggers
  Controller descent(model, control_test::plant_12_6_mpc(dt, 10), settings);
  descent.setup(hover, designs);
  long allocations = 0;
  int aborting = 0;
  AbortTriggers triggers;
  for (int k = 0; k < T; ++k) {
    AllocationWindow window;
    triggers.navigation_fault = k >= 3;
    abort.monitor(k, triggers, &descent);  // entering copies the descent's identifiers
    const ControlStep& r = abort.aborting() ? abort.step(k, x) : descent.step(k, x);
    if (abort.aborting()) {
      abort.set_estimation_error(P_est);
      ++aborting;
    } else {
      triggers.disturbance_ratio = r.disturbance_ratio;
      triggers.input_nis = r.input_nis;
    }
    model->discretize(0.0, dt, x, r.u, Ad, Bd, c);
    x_next.noalias() = Ad * x;
    x_next.noalias() += Bd * r.u;
    x = x_next + c;
    if (!abort.aborting()) triggers.excursion = descent.excursion(x);
    allocations += window.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(aborting, T - 3);
  EXPECT_EQ(abort.decision().cause, AbortCause::NavigationFault);
}
