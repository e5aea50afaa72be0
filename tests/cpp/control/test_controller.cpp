#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "tubempc/control/controller.hpp"
#include "tubempc_testing/control_fixtures.hpp"

using namespace tubempc::control;
using control_test::double_integrator;
using control_test::lqr_design;
using tubempc::mpc::Reference;
using tubempc::mpc::Settings;

namespace {

constexpr double kDt = 2.0;
constexpr int kT = 30;

struct Mission {
  std::shared_ptr<tubempc::mpc::LtiModel> model = control_test::plant_12_6(kDt);
  Settings mpc;
  ControllerSettings settings;
  ControllerDesigns designs;
  Reference ref;

  explicit Mission(Method method, MeasuredInput input = MeasuredInput::Residual) {
    mpc.horizon = 10;
    mpc.dt = kDt;
    mpc.R = Eigen::VectorXd((Eigen::VectorXd(6) << 1e3, 1e3, 1e3, 1e4, 1e4, 1e4).finished()).asDiagonal();
    mpc.u_max = (Eigen::VectorXd(6) << 0.55, 0.55, 0.55, 3.0, 3.0, 3.0).finished();
    mpc.time_limit = 10.0;
    settings.method = method;
    settings.measured_input = input;
    settings.identification_p.S0 = SubMatrix::Identity() * 1e-4;
    settings.identification_r.S0 = SubMatrix::Identity() * 1e-8;
    settings.identification_p.prior_weight = settings.identification_r.prior_weight = 10.0;
    SubMatrix A;
    SubInputMatrix B;
    for (int s = 0; s < 2; ++s) {
      double_integrator(kDt, s == 0 ? 1.0 : 1.0 / 2750, A, B);
      const SubMatrix P0 = 9.0 * (s == 0 ? settings.identification_p.S0 : settings.identification_r.S0);
      const double r = s == 0 ? 1e2 : 1e-4;
      (s == 0 ? designs.initial_p : designs.initial_r) = lqr_design(A, B, 1.2 * P0, r);
      auto& lib = s == 0 ? designs.library_p : designs.library_r;
      for (double c : {0.5, 2.0, 8.0, 32.0}) lib.push_back(lqr_design(A, B, c * P0, r * c));
    }
    ref.z = Eigen::MatrixXd::Zero(12, kT + 1);
    ref.u = Eigen::MatrixXd::Zero(6, kT);
    for (int j = 0; j <= kT; ++j) ref.z(0, j) = 20.0 * (1.0 - static_cast<double>(j) / kT);
    ref.z.block(3, 0, 1, kT).setConstant(-20.0 / (kT * kDt));
  }
};

// The disturbance of step k: deterministic, growing in the attitude subsystem.
Eigen::Matrix<double, 12, 1> disturbance(int k, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Matrix<double, 12, 1> w;
  for (int i = 0; i < 12; ++i) w(i) = n(rng) * (i < 6 ? 3e-3 : 3e-5 * (1.0 + 0.1 * k));
  return w;
}

}  // namespace

// On a linear plant the residual input is the injected disturbance; the identifiers equal stand-alone
// ones fed the same inputs; every tube is certified for its step; every command is finite.
TEST(Controller, ClosedLoopOnALinearPlant) {
  Mission m(Method::Ffa);
  Controller ctrl(m.model, m.mpc, m.settings);
  ctrl.setup(m.ref, m.designs);
  ForgettingFactorIdentifier oracle_p(m.settings.identification_p), oracle_r(m.settings.identification_r);
  ForgettingFactorIdentifier before_p = oracle_p, before_r = oracle_r;  // the oracles one input behind
  std::mt19937 rng(11);
  Eigen::VectorXd x = m.ref.z.col(0);
  Eigen::MatrixXd A(12, 12), B(12, 6);
  Eigen::VectorXd c(12);
  Eigen::Matrix<double, 12, 1> w_last = Eigen::Matrix<double, 12, 1>::Zero();
  for (int k = 0; k < kT; ++k) {
    const ControlStep& r = ctrl.step(k, x);
    ASSERT_TRUE(r.u.allFinite());
    EXPECT_EQ(r.identified, k > 0);
    if (k > 0) {
      EXPECT_LE((r.w_measured - w_last).cwiseAbs().maxCoeff(), 1e-12) << k;
      oracle_p.update(r.w_measured.head<6>());
      oracle_r.update(r.w_measured.tail<6>());
    }
    if (k > 0) {  // the input's innovation against the identification before it was folded in
      for (int sub = 0; sub < 2; ++sub) {
        const ForgettingFactorIdentifier& before = sub == 0 ? before_p : before_r;
        const SubVector d = r.w_measured.segment<6>(6 * sub) - before.w_hat();
        const double nis = d.dot(before.S_hat().fullPivLu().solve(d)) / 6.0;
        EXPECT_NEAR(r.input_nis[sub], nis, 1e-9 * nis) << k;
      }
    } else {
      EXPECT_EQ(r.input_nis[0], 0.0);
    }
    before_p = oracle_p;
    before_r = oracle_r;
    EXPECT_EQ(ctrl.identifier(0).S_hat(), oracle_p.S_hat());
    EXPECT_EQ(ctrl.identifier(1).w_hat(), oracle_r.w_hat());
    for (int s = 0; s < 2; ++s) {
      EXPECT_TRUE(certified(r.tube_status[s])) << k << " " << to_string(r.tube_status[s]);
      const SubMatrix Pe = r.tube.Pe.block<6, 6>(6 * s, 6 * s);
      const SubGain K = r.tube.K.block<3, 6>(3 * s, 6 * s);
      EXPECT_LE(lmi_residual(r.A[s], r.B[s], K, Pe, r.P_W[s], r.alpha[s]), 0.0) << k;
      EXPECT_EQ(r.P_W[s], ctrl.identifier(s).P_W());
    }
    if (k == 0) EXPECT_FALSE(r.design_due);
    if (k > 0 && k % m.settings.tube.alpha_search_period == 0) EXPECT_TRUE(r.design_due) << k;
    EXPECT_GE(r.timings.total, r.timings.mpc);
    m.model->discretize(0.0, kDt, x, r.u, A, B, c);
    w_last = disturbance(k, rng);
    x = A * x + B * r.u + c + w_last;
  }
  EXPECT_TRUE(ctrl.identify(kT, x));
  EXPECT_LE((ctrl.last_measured_input() - w_last).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_FALSE(ctrl.identify(kT, x));  // once per period
}

// The excursion of a state in the last step's tube: 0 at the plan's next nominal state, 1 on the tube's boundary
// (e = Pe^1/2 u, |u| = 1, built from Pe's eigen-decomposition), and the quadratic form of the full 12 x 12 tube
// (an independent solve) elsewhere; the disturbance ratio is the generalised eigenvalue of (P_W, P_W0) by a
// general eigen-solver, 1 at the prior.
TEST(Controller, ExcursionAndDisturbanceRatio) {
  Mission m(Method::Ffa);
  Controller ctrl(m.model, m.mpc, m.settings);
  ctrl.setup(m.ref, m.designs);
  EXPECT_EQ(ctrl.excursion(m.ref.z.col(0))[0], 0.0);  // no step yet
  std::mt19937 rng(5);
  Eigen::VectorXd x = m.ref.z.col(0);
  Eigen::MatrixXd A(12, 12), B(12, 6);
  Eigen::VectorXd c(12);
  for (int k = 0; k < 12; ++k) {
    const ControlStep& r = ctrl.step(k, x);
    for (int s = 0; s < 2; ++s) {
      const IdentifierSettings& id = s == 0 ? m.settings.identification_p : m.settings.identification_r;
      const SubMatrix P0 = id.pw_scale * id.S0;
      const Eigen::GeneralizedSelfAdjointEigenSolver<SubMatrix> ges(ctrl.identifier(s).P_W(), P0);
      EXPECT_NEAR(r.disturbance_ratio[s], ges.eigenvalues().maxCoeff(), 1e-9 * ges.eigenvalues().maxCoeff());
      if (k == 0) EXPECT_NEAR(r.disturbance_ratio[s], 1.0, 1e-12);
    }
    const Eigen::VectorXd z1 = r.mpc->z.col(1);
    const std::array<double, 2> at_nominal = ctrl.excursion(z1);
    EXPECT_EQ(at_nominal[0], 0.0);
    EXPECT_EQ(at_nominal[1], 0.0);
    for (int s = 0; s < 2; ++s) {  // a boundary point of subsystem s's tube, the other at its nominal
      const Eigen::SelfAdjointEigenSolver<SubMatrix> es(r.tube.Pe.block<6, 6>(6 * s, 6 * s));
      SubVector u = SubVector::Zero();
      u(k % 6) = 1.0;
      Eigen::VectorXd xb = z1;
      xb.segment<6>(6 * s) += es.eigenvectors() * es.eigenvalues().cwiseSqrt().asDiagonal() * u;
      EXPECT_NEAR(ctrl.excursion(xb)[s], 1.0, 1e-9) << k;
      EXPECT_LE(ctrl.excursion(xb)[1 - s], 1e-30) << k;
    }
    m.model->discretize(0.0, kDt, x, r.u, A, B, c);
    x = A * x + B * r.u + c + 4.0 * disturbance(k, rng);
    const Eigen::VectorXd e = x - z1;
    const Eigen::MatrixXd Pe = r.tube.Pe;
    const double full = e.dot(Pe.fullPivLu().solve(e));
    const std::array<double, 2> exc = ctrl.excursion(x);
    EXPECT_NEAR(exc[0] + exc[1], full, 1e-9 * full) << k;
  }
  EXPECT_THROW(ctrl.excursion(Eigen::VectorXd::Zero(6)), std::invalid_argument);
  Eigen::VectorXd nan_state = x;
  nan_state(7) = std::nan("");  // a non-finite state is outside the tube, not a silent NaN
  EXPECT_EQ(ctrl.excursion(nan_state)[1], std::numeric_limits<double>::infinity());
  EXPECT_LT(ctrl.excursion(nan_state)[0], std::numeric_limits<double>::infinity());
}

// A state whose rotation vector is given in the other chart (phi - 2 pi phi/|phi|, the same attitude: the
// navigation switches there near |phi| = pi) gives the same measured input and excursion as in the prediction's
// chart, not a 2 pi jump folded into the identification.
TEST(Controller, AChartSwitchOfTheAttitudeIsTheSameAttitude) {
  Mission m(Method::Ffa);
  m.ref.z.row(6).setConstant(3.1);  // |phi| near pi
  Controller same(m.model, m.mpc, m.settings), switched(m.model, m.mpc, m.settings);
  same.setup(m.ref, m.designs);
  switched.setup(m.ref, m.designs);
  std::mt19937 rng(3);
  Eigen::VectorXd x = m.ref.z.col(0);
  Eigen::MatrixXd A(12, 12), B(12, 6);
  Eigen::VectorXd c(12);
  for (int k = 0; k < 4; ++k) {
    const ControlStep& r = same.step(k, x);
    switched.step(k, x);
    m.model->discretize(0.0, kDt, x, r.u, A, B, c);
    x = A * x + B * r.u + c + disturbance(k, rng);
    const Eigen::Vector3d phi = x.segment<3>(6);
    Eigen::VectorXd x_other = x;
    x_other.segment<3>(6) = phi * ((phi.norm() - 2.0 * 3.141592653589793) / phi.norm());
    ASSERT_GT((x_other - x).norm(), 6.0);
    const std::array<double, 2> e_same = same.excursion(x), e_switched = switched.excursion(x_other);
    EXPECT_NEAR(e_switched[1], e_same[1], 1e-9 * e_same[1] + 1e-12) << k;
    EXPECT_EQ(e_switched[0], e_same[0]);
    ASSERT_TRUE(same.identify(k + 1, x));
    ASSERT_TRUE(switched.identify(k + 1, x_other));
    EXPECT_LT((switched.last_measured_input() - same.last_measured_input()).norm(), 1e-12) << k;
    EXPECT_LT(switched.last_measured_input().segment<3>(6).norm(), 1e-2) << k;  // not a 2 pi jump
    EXPECT_LT((switched.identifier(1).w_hat() - same.identifier(1).w_hat()).norm(), 1e-12) << k;
  }
}

// TBMPC flies its initial design's tube at every step; the identification still runs (the paper's
// literal reference-deviation input here).
TEST(Controller, TbmpcKeepsItsTube) {
  Mission m(Method::Tbmpc, MeasuredInput::ReferenceDeviation);
  Controller ctrl(m.model, m.mpc, m.settings);
  ctrl.setup(m.ref, m.designs);
  Eigen::VectorXd x = m.ref.z.col(0);
  for (int k = 0; k < 5; ++k) {
    const ControlStep& r = ctrl.step(k, x);
    EXPECT_EQ(r.tube_status[0], TubeStatus::Fixed);
    EXPECT_TRUE((r.tube.Pe.block<6, 6>(0, 0) - m.designs.initial_p.Pe).isZero(0.0));
    EXPECT_FALSE(r.design_due);
    x = m.ref.z.col(k + 1) + Eigen::VectorXd::Constant(12, 1e-4);
    if (k > 0) EXPECT_LE((r.w_measured - Eigen::VectorXd::Constant(12, 1e-4)).cwiseAbs().maxCoeff(), 1e-15);
  }
}

TEST(Controller, BadInputIsAStatusOrAClearError) {
  Mission m(Method::Ffa);
  Controller ctrl(m.model, m.mpc, m.settings);
  EXPECT_THROW(ctrl.step(0, m.ref.z.col(0)), std::invalid_argument);  // before setup
  ctrl.setup(m.ref, m.designs);
  EXPECT_THROW(ctrl.step(kT, m.ref.z.col(0)), std::invalid_argument);
  EXPECT_THROW(ctrl.step(0, Eigen::VectorXd::Zero(11)), std::invalid_argument);
  ctrl.step(0, m.ref.z.col(0));
  Eigen::VectorXd nan_x = m.ref.z.col(1);
  nan_x(2) = std::numeric_limits<double>::quiet_NaN();
  const ControlStep& r = ctrl.step(1, nan_x);
  EXPECT_TRUE(r.u.allFinite());
  EXPECT_FALSE(r.identified);
  ControllerSettings bad = m.settings;
  bad.identification_r.lambda = 0.0;
  EXPECT_THROW(Controller(m.model, m.mpc, bad), std::invalid_argument);
  ControllerDesigns no_design = m.designs;
  no_design.initial_r.Pe = -no_design.initial_r.Pe;
  Controller other(m.model, m.mpc, m.settings);
  EXPECT_THROW(other.setup(m.ref, no_design), std::invalid_argument);
}

// The feed-forward's input-error set: the ball case by hand, the degenerate cases, and every sum of a point of E
// and of the box inside it.
TEST(Controller, InputErrorWithFeedforwardContainsTheSum) {
  const Eigen::Matrix3d ball =
      input_error_with_feedforward(4.0 * Eigen::Matrix3d::Identity(), Eigen::Vector3d::Constant(0.5));
  EXPECT_TRUE(ball.isApprox(std::pow(2.0 + std::sqrt(3.0) * 0.5, 2) * Eigen::Matrix3d::Identity(), 1e-14));
  const Eigen::Vector3d rho(0.1, 0.2, 0.3);
  EXPECT_TRUE(input_error_with_feedforward(Eigen::Matrix3d::Zero(), rho)
                  .isApprox(3.0 * rho.cwiseAbs2().asDiagonal().toDenseMatrix(), 1e-15));
  Eigen::Matrix3d E;
  E << 2.0, 0.3, -0.1, 0.3, 1.0, 0.2, -0.1, 0.2, 0.5;
  EXPECT_EQ(input_error_with_feedforward(E, Eigen::Vector3d::Zero()), E);
  const Eigen::Matrix3d G = input_error_with_feedforward(E, rho);
  const Eigen::LLT<Eigen::Matrix3d> E_llt(E), G_llt(G);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  double worst = 0.0;
  for (int k = 0; k < 20000; ++k) {
    Eigen::Vector3d y(n(rng), n(rng), n(rng));
    const Eigen::Vector3d e = E_llt.matrixL() * y.normalized();  // on E's boundary
    Eigen::Vector3d z;
    for (int i = 0; i < 3; ++i) z(i) = (n(rng) > 0.0 ? 1.0 : -1.0) * rho(i);  // a corner of the box
    const Eigen::Vector3d v = e + z;
    const double level = v.dot(G_llt.solve(v));
    ASSERT_LE(level, 1.0 + 1e-12) << k;
    worst = std::max(worst, level);
  }
  EXPECT_GT(worst, 0.7);
}

// The feed-forward (ControllerSettings::feedforward) is -(B^T B)^-1 B^T w^ of each subsystem, within its limit and
// clipped so that the command stays within u_max; the controller carries its box in the input-error sets;
// against a constant input bias it removes most of the offset the tube's feedback leaves; TBMPC ignores it.
TEST(Controller, FeedforwardCancelsAnInputBias) {
  const Eigen::VectorXd bias = (Eigen::VectorXd(6) << 0.02, -0.01, 0.015, 0.05, -0.02, 0.03).finished();
  auto fly = [&bias](Method method, bool feedforward, double& offset) {
    Mission m(method);
    m.settings.feedforward = feedforward;
    m.settings.feedforward_limit = 0.2;  // room for the bias
    Controller ctrl(m.model, m.mpc, m.settings);
    ctrl.setup(m.ref, m.designs);
    for (int s = 0; s < 2;
         ++s) {  // the feed-forward's box in the tube's input-error set (ideal actuators: E = 0)
      const Eigen::Matrix3d want =
          feedforward && method == Method::Ffa
              ? input_error_with_feedforward(Eigen::Matrix3d::Zero(), 0.2 * m.mpc.u_max.segment<3>(3 * s))
              : Eigen::Matrix3d::Zero();
      EXPECT_EQ(ctrl.settings().actuation_error[s], want);
    }
    Eigen::VectorXd x = m.ref.z.col(0);
    Eigen::MatrixXd A(12, 12), B(12, 6);
    Eigen::VectorXd c(12);
    bool fed = false;
    offset = 0.0;
    for (int k = 0; k < kT; ++k) {
      const ControlStep& r = ctrl.step(k, x);
      ASSERT_TRUE(r.u.allFinite());
      Eigen::Matrix<double, 6, 1> want = Eigen::Matrix<double, 6, 1>::Zero();
      if (feedforward && method == Method::Ffa)
        for (int s = 0; s < 2; ++s)
          want.segment<3>(3 * s) =
              -(r.B[s].transpose() * r.B[s]).ldlt().solve(r.B[s].transpose() * ctrl.identifier(s).w_hat());
      for (int j = 0; j < 6; ++j) {
        const double u_mpc = r.u(j) - r.u_feedforward(j), rho = m.settings.feedforward_limit * m.mpc.u_max(j);
        ASSERT_LE(std::abs(r.u(j)), std::max(m.mpc.u_max(j), std::abs(u_mpc)) + 1e-15) << k;
        ASSERT_LE(std::abs(r.u_feedforward(j)), rho * (1.0 + 1e-15)) << k;
        // Unclipped, the feed-forward is the formula; clipped, at its limit or the command at its bound.
        if (std::abs(r.u(j)) < m.mpc.u_max(j) * (1.0 - 1e-12) &&
            std::abs(r.u_feedforward(j)) < rho * (1.0 - 1e-12))
          EXPECT_NEAR(r.u_feedforward(j), want(j), 1e-12 * (1.0 + std::abs(want(j)))) << k << " " << j;
      }
      fed = fed || r.u_feedforward.norm() > 0.0;
      m.model->discretize(0.0, kDt, x, r.u, A, B, c);
      x = A * x + B * (r.u + bias) + c;
      if (k >= kT - 5) offset = std::max(offset, (x - m.ref.z.col(k + 1)).head<3>().norm());
    }
    EXPECT_EQ(fed, feedforward && method == Method::Ffa);
  };
  double with = 0.0, without = 0.0, tbmpc = 0.0;
  fly(Method::Ffa, true, with);
  fly(Method::Ffa, false, without);
  fly(Method::Tbmpc, true, tbmpc);
  EXPECT_GT(without, 0.0);
  EXPECT_LT(with, 0.5 * without) << with << " " << without;
}

// Bad numbers never escape a step as an exception: every component of x_k and of the estimation-error set
// NaN, +-inf or huge gives a finite command, and the next good step flies on.
TEST(Controller, NoExceptionEscapesAStepOnBadNumbers) {
  for (const Method method : {Method::Ffa, Method::Tbmpc}) {
    Mission m(method);
    Controller ctrl(m.model, m.mpc, m.settings);
    ctrl.setup(m.ref, m.designs);
    const double bad[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                          -std::numeric_limits<double>::infinity(), 1e300};
    int k = 0;
    for (const double v : bad) {
      for (int i = 0; i < 12; ++i, k = (k + 1) % kT) {
        Eigen::VectorXd x = m.ref.z.col(k);
        x(i) = v;
        const ControlStep* r = nullptr;
        ASSERT_NO_THROW(r = &ctrl.step(k, x)) << i << " " << v;
        EXPECT_TRUE(r->u.allFinite()) << i << " " << v;
        Eigen::MatrixXd P_est = 1e-6 * Eigen::MatrixXd::Identity(12, 12);
        P_est(i, i) = v;
        ASSERT_NO_THROW(ctrl.set_estimation_error(P_est)) << i << " " << v;
        ASSERT_NO_THROW(r = &ctrl.step(k, m.ref.z.col(k))) << i << " " << v;
        EXPECT_TRUE(r->u.allFinite()) << i << " " << v;
        ctrl.set_estimation_error(Eigen::MatrixXd());
      }
    }
    const ControlStep& good = ctrl.step(0, m.ref.z.col(0));
    EXPECT_TRUE(good.u.allFinite());
    EXPECT_FALSE(tubempc::mpc::is_fallback(good.mpc->status)) << tubempc::mpc::to_string(good.mpc->status);
  }
}
