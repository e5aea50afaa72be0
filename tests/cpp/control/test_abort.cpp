// The safe abort's supervision (latching, precedence, commit) and its controller flying the back-away to the
// hover reference, certified at every step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "tubempc/control/abort.hpp"
#include "tubempc_testing/control_fixtures.hpp"

using namespace tubempc::control;

namespace {

constexpr double kAbortDt = 2.0;
constexpr int kAbortT = 40;

ControllerSettings abort_controller_settings() {
  ControllerSettings s;
  s.identification_p.S0 = SubMatrix::Identity() * 1e-4;
  s.identification_r.S0 = SubMatrix::Identity() * 1e-8;
  return s;
}

ControllerDesigns abort_designs(const ControllerSettings& settings) {
  return control_test::plant_12_6_designs(kAbortDt, settings.identification_p.S0,
                                          settings.identification_r.S0, {1.0, 4.0, 16.0});
}

// A hover at x_0 = 40 m (position 0 of the fixture's plane), at rest, over the whole mission.
tubempc::mpc::Reference hover_reference() {
  tubempc::mpc::Reference ref;
  ref.z = Eigen::MatrixXd::Zero(12, kAbortT + 1);
  ref.u = Eigen::MatrixXd::Zero(6, kAbortT);
  ref.z.row(0).setConstant(40.0);
  return ref;
}

SafeAbort new_abort(AbortSettings settings) {
  const ControllerSettings cs = abort_controller_settings();
  return SafeAbort(control_test::plant_12_6(kAbortDt), control_test::plant_12_6_mpc(kAbortDt, 10), cs,
                   settings);
}

}  // namespace

TEST(SafeAbort, SettingsAreValidated) {
  AbortSettings s;
  s.commit_step = -2;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  s.commit_step = -1;
  EXPECT_NO_THROW(s.validate());
  s.commit_step = -3;
  EXPECT_THROW(new_abort(s), std::invalid_argument);
}

TEST(SafeAbort, MonitorLatchesTheFirstCauseBeforeTheCommitStep) {
  AbortSettings s;
  s.commit_step = 10;
  SafeAbort abort = new_abort(s);
  EXPECT_EQ(abort.monitor(0, {}).mode, AbortMode::Armed);
  AbortTriggers t;
  t.allocation_infeasible = true;
  t.navigation_fault = true;  // both at one step: the navigation's fault takes precedence
  const AbortDecision& d = abort.monitor(4, t);
  EXPECT_EQ(d.mode, AbortMode::Aborting);
  EXPECT_EQ(d.cause, AbortCause::NavigationFault);
  EXPECT_EQ(d.entered_at, 4);
  EXPECT_TRUE(abort.aborting());
  AbortTriggers command;
  command.command = true;
  EXPECT_EQ(abort.monitor(5, command).cause, AbortCause::NavigationFault);  // latched
  EXPECT_EQ(abort.monitor(30, {}).mode, AbortMode::Aborting);
  EXPECT_THROW(abort.monitor(-1, {}), std::invalid_argument);
  abort.reset();
  EXPECT_EQ(abort.decision().mode, AbortMode::Armed);
  EXPECT_EQ(abort.decision().entered_at, -1);
}

TEST(SafeAbort, TriggersPastTheCommitStepAreRefusedAndRecorded) {
  AbortSettings s;
  s.commit_step = 10;
  SafeAbort abort = new_abort(s);
  AbortTriggers t;
  t.tube_uncertified = true;
  EXPECT_EQ(abort.monitor(10, {}).mode, AbortMode::Armed);
  const AbortDecision& d = abort.monitor(11, t);
  EXPECT_EQ(d.mode, AbortMode::Committed);
  EXPECT_EQ(d.cause, AbortCause::None);
  EXPECT_EQ(d.refused_cause, AbortCause::TubeUncertified);
  EXPECT_EQ(d.refused_at, 11);
  AbortTriggers command;
  command.command = true;
  EXPECT_EQ(abort.monitor(12, command).refused_at, 11);  // the first refusal is kept
  EXPECT_FALSE(abort.aborting());
}

TEST(SafeAbort, DisabledTriggersDoNotAbortButACommandDoes) {
  AbortSettings s;
  s.commit_step = 20;
  s.on_navigation_fault = s.on_tube_uncertified = s.on_allocation_infeasible = false;
  SafeAbort abort = new_abort(s);
  AbortTriggers t;
  t.navigation_fault = t.tube_uncertified = t.allocation_infeasible = true;
  EXPECT_EQ(abort.monitor(1, t).mode, AbortMode::Armed);
  t.command = true;
  EXPECT_EQ(abort.monitor(2, t).cause, AbortCause::Command);
}

// The estimate outside the descent's last tube (beyond the excursion tolerance) and an identified set beyond the
// limit enter the abort, in this precedence; at the thresholds they do not; disabled, they do not.
TEST(SafeAbort, EstimateOutsideTubeAndDisturbanceBeyondLimit) {
  AbortSettings s;
  s.commit_step = 20;
  s.disturbance_limit = 3.0;
  {
    SafeAbort abort = new_abort(s);
    AbortTriggers t;
    t.excursion = {1.0 + 0.5 * kExcursionTolerance, 0.2};  // on the boundary: rounding, not an exit
    t.disturbance_ratio = {0.1, 3.0};                      // at the limit: qualified
    EXPECT_EQ(abort.monitor(1, t).mode, AbortMode::Armed);
    t.excursion = {0.3, 1.0 + 1e-6};
    t.disturbance_ratio = {0.1, 3.0 + 1e-6};  // both: the estimate's exit takes precedence
    const AbortDecision& d = abort.monitor(2, t);
    EXPECT_EQ(d.cause, AbortCause::EstimateOutsideTube);
    EXPECT_EQ(d.entered_at, 2);
  }
  {
    SafeAbort abort = new_abort(s);
    AbortTriggers t;
    t.disturbance_ratio = {3.5, 0.0};
    EXPECT_EQ(abort.monitor(3, t).cause, AbortCause::DisturbanceBeyondLimit);
    EXPECT_STREQ(to_string(AbortCause::DisturbanceBeyondLimit), "disturbance_beyond_limit");
  }
  for (int which : {0, 1}) {  // a value that cannot be judged (NaN) is beyond its limit
    SafeAbort abort = new_abort(s);
    AbortTriggers t;
    (which == 0 ? t.excursion : t.disturbance_ratio)[1] = std::nan("");
    EXPECT_EQ(abort.monitor(3, t).cause,
              which == 0 ? AbortCause::EstimateOutsideTube : AbortCause::DisturbanceBeyondLimit);
  }
  {
    AbortSettings off = s;
    off.on_estimate_outside_tube = off.on_disturbance_beyond_limit = false;
    SafeAbort abort = new_abort(off);
    AbortTriggers t;
    t.excursion = {50.0, 50.0};
    t.disturbance_ratio = {50.0, 50.0};
    EXPECT_EQ(abort.monitor(3, t).mode, AbortMode::Armed);
  }
  AbortSettings bad = s;
  for (double limit : {0.0, -1.0, std::nan("")}) {
    bad.disturbance_limit = limit;
    EXPECT_THROW(bad.validate(), std::invalid_argument) << limit;
  }
  bad.disturbance_limit = std::numeric_limits<double>::infinity();  // no limit
  EXPECT_NO_THROW(bad.validate());
}

// The input innovation's window: the mean of the last input_nis_window values (0 before the first), its oldest value
// dropped as a new one comes; beyond the limit it enters the abort (after the estimate's exit in precedence).
TEST(SafeAbort, InputNisWindowMean) {
  AbortSettings s;
  s.commit_step = 40;
  s.input_nis_window = 4;
  s.input_nis_limit = 3.0;
  SafeAbort abort = new_abort(s);
  AbortTriggers t;
  const double values[] = {1.0, 2.0, 6.0, 3.0, 2.0, 4.5};
  double expected[] = {0.25, 0.75, 2.25, 3.0, 3.25, 0.0};
  for (int k = 0; k < 5; ++k) {
    t.input_nis = {0.5, values[k]};
    const AbortDecision& d = abort.monitor(k, t);
    EXPECT_NEAR(abort.input_nis_mean()[1], expected[k], 1e-15) << k;
    EXPECT_NEAR(abort.input_nis_mean()[0], 0.5 * std::min(k + 1, 4) / 4.0, 1e-15) << k;
    EXPECT_EQ(d.mode, k < 4 ? AbortMode::Armed : AbortMode::Aborting)
        << k;  // 3.0 is at the limit, 3.25 beyond
  }
  EXPECT_EQ(abort.decision().cause, AbortCause::InputNis);
  EXPECT_EQ(abort.decision().entered_at, 4);
  abort.reset();
  EXPECT_EQ(abort.input_nis_mean()[1], 0.0);
  t.input_nis = {std::nan(""), std::numeric_limits<double>::infinity()};  // non-finite: counted as 0
  EXPECT_EQ(abort.monitor(0, t).mode, AbortMode::Armed);
  EXPECT_EQ(abort.input_nis_mean()[1], 0.0);
  AbortSettings bad = s;
  for (int window : {0, kMaxInputNisWindow + 1}) {
    bad.input_nis_window = window;
    EXPECT_THROW(bad.validate(), std::invalid_argument) << window;
  }
  bad = s;
  bad.input_nis_limit = 0.0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

TEST(SafeAbort, NeverArmedWithoutACertifiedEntry) {
  SafeAbort abort = new_abort(AbortSettings{});  // commit_step -1: the library certified no entry
  AbortTriggers command;
  command.command = true;
  const AbortDecision& d = abort.monitor(0, command);
  EXPECT_EQ(d.mode, AbortMode::Committed);
  EXPECT_EQ(d.refused_cause, AbortCause::Command);
}

TEST(SafeAbort, FliesBackToTheHoverCertifiedAtEveryStep) {
  AbortSettings s;
  s.commit_step = kAbortT - 1;
  SafeAbort abort = new_abort(s);
  abort.setup(hover_reference(), abort_designs(abort_controller_settings()));
  EXPECT_EQ(abort.controller().settings().method, Method::Ffa);  // enforced: the tube certified per step
  auto model = control_test::plant_12_6(kAbortDt);
  // Entered at k = 8 from 5 m, descending at 0.5 m/s: the plan climbs back to the hover at 40 m.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(12), c(12);
  x(0) = 5.0;
  x(3) = -0.5;
  Eigen::MatrixXd Ad(12, 12), Bd(12, 6);
  AbortTriggers command;
  command.command = true;
  ASSERT_TRUE(abort.monitor(8, command).mode == AbortMode::Aborting);
  double lowest = x(0);
  for (int k = 8; k < kAbortT; ++k) {
    const ControlStep& r = abort.step(k, x);
    ASSERT_TRUE(r.u.allFinite());
    for (int sub = 0; sub < 2; ++sub) {
      EXPECT_TRUE(certified(r.tube_status[sub])) << "k = " << k;
      EXPECT_LE(r.residual[sub], 0.0) << "k = " << k;
    }
    model->discretize(0.0, kAbortDt, x, r.u, Ad, Bd, c);
    x = Ad * x + Bd * r.u + c;
    lowest = std::min(lowest, x(0));
  }
  EXPECT_NEAR(x(0), 40.0, 0.5);
  EXPECT_NEAR(x(3), 0.0, 0.05);
  EXPECT_GT(lowest, 0.0);  // the descent was stopped before it reached the plane's origin
}

TEST(SafeAbort, SetupNeedsALibrary) {
  SafeAbort abort = new_abort(AbortSettings{});
  ControllerDesigns designs = abort_designs(abort_controller_settings());
  designs.library_r.clear();
  EXPECT_THROW(abort.setup(hover_reference(), designs), std::invalid_argument);
}

TEST(SafeAbort, EnteringTakesOverTheDescentsIdentification) {
  AbortSettings s;
  s.commit_step = kAbortT - 1;
  const ControllerDesigns designs = abort_designs(abort_controller_settings());
  // The "descent": a controller flown a few noisy steps, so that its identifiers moved off the prior.
  SafeAbort descent = new_abort(s);
  descent.setup(hover_reference(), designs);
  auto model = control_test::plant_12_6(kAbortDt);
  Eigen::VectorXd x = hover_reference().z.col(0), c(12);
  Eigen::MatrixXd Ad(12, 12), Bd(12, 6);
  for (int k = 0; k < 6; ++k) {
    const ControlStep& r = descent.step(k, x);
    model->discretize(0.0, kAbortDt, x, r.u, Ad, Bd, c);
    x = Ad * x + Bd * r.u + c;
    x(0) += (k % 2 == 0 ? 0.02 : -0.02);  // a translational input beyond the prior: P_W grows
  }
  SafeAbort abort = new_abort(s);
  abort.setup(hover_reference(), designs);
  const SubMatrix prior = abort.controller().identifier(0).S_hat();
  ASSERT_GT((descent.controller().identifier(0).S_hat() - prior).norm(), 0.0);
  AbortTriggers command;
  command.command = true;
  abort.monitor(6, command, &descent.controller());
  EXPECT_EQ(abort.controller().identifier(0).S_hat(), descent.controller().identifier(0).S_hat());
  EXPECT_EQ(abort.controller().identifier(1).S_hat(), descent.controller().identifier(1).S_hat());
  // Its first step is certified for the inherited set: a design is due at a first step past k = 0.
  const ControlStep& r = abort.step(6, x);
  EXPECT_TRUE(r.design_due);
  EXPECT_TRUE(certified(r.tube_status[0]));
  EXPECT_TRUE((r.P_W[0] - descent.controller().identifier(0).P_W()).norm() <= 1e-12 * r.P_W[0].norm());
}
