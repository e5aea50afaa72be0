#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

#include "tubempc/math/expm.hpp"
#include "tubempc/mpc/lti_model.hpp"
#include "tubempc/mpc/tube_mpc.hpp"

using namespace tubempc::mpc;

namespace {

constexpr double kUnbounded = std::numeric_limits<double>::infinity();

// 1-D double integrator per axis: x = [p; v], u = a; constraints p <= p_max and -v <= v_max.
std::shared_ptr<LtiModel> double_integrator(double dt, double p_max = 10.0, double v_max = 1.0) {
  Eigen::MatrixXd A_c(2, 2), B_c(2, 1), G(2, 2);
  A_c << 0, 1, 0, 0;
  B_c << 0, 1;
  G << 1, 0, 0, -1;
  Eigen::VectorXd h(2);
  h << p_max, v_max;
  return std::make_shared<LtiModel>(A_c, B_c, Eigen::VectorXd::Zero(2), dt, G, h);
}

Reference straight_reference(const Eigen::VectorXd& x0, const Eigen::VectorXd& xf, int T, int nu) {
  Reference r;
  r.z.resize(x0.size(), T + 1);
  for (int j = 0; j <= T; ++j) r.z.col(j) = x0 + (xf - x0) * (static_cast<double>(j) / T);
  r.u = Eigen::MatrixXd::Zero(nu, T);
  return r;
}

Tube small_tube(int nx, int nu, double scale) {
  Tube t;
  t.K = Eigen::MatrixXd::Zero(nu, nx);
  t.Pe = scale * Eigen::MatrixXd::Identity(nx, nx);
  return t;
}

Settings di_settings(int N, double dt) {
  Settings s;
  s.horizon = N;
  s.dt = dt;
  s.u_max = Eigen::VectorXd::Constant(1, 0.5);
  s.time_limit = kUnbounded;
  return s;
}

// Pendulum theta'' = -w2 (1 + time_variation sin t) sin(theta) + u, discretised about the linearisation
// point (ZOH).
class Pendulum final : public tubempc::math::LinearizedModel {
 public:
  int nx() const override { return 2; }
  int nu() const override { return 1; }
  int n_constraints() const override { return 0; }
  void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x,
                  const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override {
    const double w = w2 * (1.0 + time_variation * std::sin(t));
    Eigen::MatrixXd A_c(2, 2), B_c(2, 1);
    A_c << 0, 1, -w * std::cos(x(0)), 0;
    B_c << 0, 1;
    Eigen::VectorXd f(2);
    f << x(1), -w * std::sin(x(0)) + u(0);
    Eigen::VectorXd c_c = f - A_c * x - B_c * u;
    Eigen::MatrixXd Ad, Bd;
    Eigen::VectorXd cd;
    tubempc::math::zoh_discretize<Eigen::Dynamic, Eigen::Dynamic>(A_c, B_c, c_c, dt, Ad, Bd, cd);
    A = Ad;
    B = Bd;
    c = cd;
  }
  void constraints(double, const Eigen::Ref<const Eigen::VectorXd>&, Eigen::Ref<Eigen::MatrixXd>,
                   Eigen::Ref<Eigen::VectorXd>) const override {}
  double w2 = 9.81;
  double time_variation = 0.0;
};

// Settings and terminal weight's (A, B) of the pendulum tests (dt = 0.1 s).
Settings pendulum_settings(int horizon) {
  Settings s;
  s.horizon = horizon;
  s.dt = 0.1;
  s.u_max = Eigen::VectorXd::Constant(1, 20.0);
  s.R = 1e-2 * Eigen::MatrixXd::Identity(1, 1);
  s.Q = 10.0 * Eigen::MatrixXd::Identity(2, 2);
  s.time_limit = kUnbounded;
  s.input_cost = InputCost::Deviation;
  return s;
}

void setup_pendulum(TubeMPC& mpc, const Reference& ref) {
  mpc.setup(ref, Eigen::MatrixXd::Identity(2, 2) + 0.1 * (Eigen::MatrixXd(2, 2) << 0, 1, 0, 0).finished(),
            (Eigen::MatrixXd(2, 1) << 0.005, 0.1).finished());
}

// Wraps a plant; its constraints can be made contradictory or its dynamics non-finite on demand.
class Sabotaged final : public tubempc::math::LinearizedModel {
 public:
  explicit Sabotaged(std::shared_ptr<tubempc::math::LinearizedModel> inner) : inner_(std::move(inner)) {}
  int nx() const override { return inner_->nx(); }
  int nu() const override { return inner_->nu(); }
  int n_constraints() const override { return inner_->n_constraints(); }
  void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x,
                  const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override {
    inner_->discretize(t, dt, x, u, A, B, c);
    if (nan_dynamics) c(0) = std::numeric_limits<double>::quiet_NaN();
  }
  void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Ref<Eigen::MatrixXd> G,
                   Eigen::Ref<Eigen::VectorXd> h) const override {
    inner_->constraints(t, x, G, h);
    if (contradict) {  // p <= -5 and -p <= -5
      G.setZero();
      G(0, 0) = 1.0;
      G(1, 0) = -1.0;
      h.setConstant(-5.0);
    }
  }
  bool contradict = false;
  bool nan_dynamics = false;

 private:
  std::shared_ptr<tubempc::math::LinearizedModel> inner_;
};

}  // namespace

TEST(SolveDare, SatisfiesTheRiccatiEquation) {
  std::mt19937 gen(3);
  std::normal_distribution<double> nd(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 2 + trial % 5, m = 1 + trial % 3;
    Eigen::MatrixXd A(n, n), B(n, m), Qh(n, n), Rh(m, m);
    for (int i = 0; i < A.size(); ++i) A.data()[i] = 0.6 * nd(gen);
    for (int i = 0; i < B.size(); ++i) B.data()[i] = nd(gen);
    for (int i = 0; i < Qh.size(); ++i) Qh.data()[i] = nd(gen);
    for (int i = 0; i < Rh.size(); ++i) Rh.data()[i] = nd(gen);
    const Eigen::MatrixXd Q = Qh * Qh.transpose() + 0.1 * Eigen::MatrixXd::Identity(n, n);
    const Eigen::MatrixXd R = Rh * Rh.transpose() + 0.1 * Eigen::MatrixXd::Identity(m, m);
    const Eigen::MatrixXd X = solve_dare(A, B, Q, R);
    const Eigen::MatrixXd S = R + B.transpose() * X * B;
    const Eigen::MatrixXd rhs =
        A.transpose() * X * A - A.transpose() * X * B * S.ldlt().solve(B.transpose() * X * A) + Q;
    EXPECT_LT((X - rhs).cwiseAbs().maxCoeff(), 1e-8 * std::max(1.0, X.cwiseAbs().maxCoeff())) << trial;
    // Stabilising: the closed loop A - B K has spectral radius < 1.
    const Eigen::MatrixXd K = S.ldlt().solve(B.transpose() * X * A);
    EXPECT_LT((A - B * K).eigenvalues().cwiseAbs().maxCoeff(), 1.0) << trial;
  }
}

TEST(SolveDare, FailsClearlyWhenNotStabilisable) {
  Eigen::MatrixXd A(2, 2), B(2, 1);
  A << 1.5, 0, 0, 0.5;  // the unstable mode is not actuated
  B << 0, 1;
  EXPECT_THROW(solve_dare(A, B, Eigen::MatrixXd::Identity(2, 2), Eigen::MatrixXd::Identity(1, 1)),
               std::runtime_error);
  EXPECT_THROW(solve_dare(A, B, Eigen::MatrixXd::Identity(3, 3), Eigen::MatrixXd::Identity(1, 1)),
               std::invalid_argument);
}

TEST(TubeMPCSettings, ValidateNamesTheField) {
  Settings s = di_settings(10, 0.5);
  s.u_max.resize(0);
  try {
    s.validate(2, 1);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("u_max"), std::string::npos);
  }
  s = di_settings(10, 0.5);
  s.R = -Eigen::MatrixXd::Identity(1, 1);
  EXPECT_THROW(s.validate(2, 1), std::invalid_argument);
  s = di_settings(0, 0.5);
  EXPECT_THROW(s.validate(2, 1), std::invalid_argument);
  s = di_settings(10, 0.5);
  s.qp_preconditioner_iterations = -1;
  try {
    s.validate(2, 1);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("qp_preconditioner_iterations"), std::string::npos);
  }
  for (double bad : {0.0, -1e-8, std::numeric_limits<double>::quiet_NaN()}) {
    s = di_settings(10, 0.5);
    s.qp_reg_lower_limit = bad;
    try {
      s.validate(2, 1);
      FAIL() << "no exception for " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("qp_reg_lower_limit"), std::string::npos);
    }
  }
  s = di_settings(10, 0.5);
  s.qp_retry_reg_lower_limit = -1.0;
  EXPECT_THROW(s.validate(2, 1), std::invalid_argument);
}

// KKT conditions of the QP PIQP returned, evaluated independently from the exported data.
TEST(TubeMPC, KktConditionsHoldAtTheReturnedSolution) {
  for (bool soft : {false, true}) {
    auto model = double_integrator(0.5, 1.2, 0.3);
    Settings s = di_settings(15, 0.5);
    s.soft_state_constraints = soft;
    s.soft_penalty = 1e3;
    TubeMPC mpc(model, s);
    Eigen::VectorXd x0(2), xf(2);
    x0 << 0, 0;
    xf << 2, 0;  // the reference passes p_max: the position constraint becomes active
    mpc.setup(straight_reference(x0, xf, 20, 1));
    Tube tube = small_tube(2, 1, 1e-3);
    tube.K << -0.5, -1.0;
    Eigen::VectorXd x(2);
    x << 0.01, 0.25;
    const StepResult& r = mpc.step(0, x, tube);
    ASSERT_EQ(r.status, Status::Solved) << to_string(r.failure);
    const QpData d = mpc.qp_data();
    const QpSolution sol = mpc.qp_solution();
    const Eigen::VectorXd& w = sol.w;
    const double tol = 1e-6;
    const Eigen::VectorXd stat =
        d.P * w + d.q + d.A.transpose() * sol.y + d.G.transpose() * (sol.z_u - sol.z_l) + sol.z_bu - sol.z_bl;
    EXPECT_LT(stat.cwiseAbs().maxCoeff(), tol);
    EXPECT_LT((d.A * w - d.b).cwiseAbs().maxCoeff(), tol);
    const Eigen::VectorXd Gw = d.G * w;
    int active = 0;
    for (Eigen::Index i = 0; i < Gw.size(); ++i) {
      EXPECT_LE(Gw(i), d.h_u(i) + tol);
      EXPECT_GE(Gw(i), d.h_l(i) - tol);
      EXPECT_GE(sol.z_u(i), -tol);
      EXPECT_GE(sol.z_l(i), -tol);
      if (std::isfinite(d.h_u(i))) EXPECT_LT(std::abs(sol.z_u(i) * (d.h_u(i) - Gw(i))), tol);
      if (std::isfinite(d.h_l(i))) EXPECT_LT(std::abs(sol.z_l(i) * (Gw(i) - d.h_l(i))), tol);
      if (sol.z_u(i) > 1e-3) ++active;
    }
    for (Eigen::Index i = 0; i < w.size(); ++i) {
      EXPECT_LE(w(i), d.x_u(i) + tol);
      EXPECT_GE(w(i), d.x_l(i) - tol);
      EXPECT_GE(sol.z_bu(i), -tol);
      EXPECT_GE(sol.z_bl(i), -tol);
      if (std::isfinite(d.x_u(i))) EXPECT_LT(std::abs(sol.z_bu(i) * (d.x_u(i) - w(i))), tol);
      if (std::isfinite(d.x_l(i))) EXPECT_LT(std::abs(sol.z_bl(i) * (w(i) - d.x_l(i))), tol);
    }
    EXPECT_GT(active, 0) << "the test should exercise an active state constraint";
    const double obj = 0.5 * w.dot(d.P * w) + d.q.dot(w) + d.constant;
    EXPECT_NEAR(r.objective, obj, 1e-6 * std::max(1.0, std::abs(obj)));
  }
}

// The tightened bounds in the QP equal h - max over the tube ellipsoid's boundary of a^T e.
TEST(TubeMPC, TighteningEqualsTheSupportFunctionOfTheTube) {
  std::mt19937 gen(11);
  std::normal_distribution<double> nd(0.0, 1.0);
  for (int trial = 0; trial < 10; ++trial) {
    Eigen::MatrixXd A_c(2, 2), B_c(2, 1), G(3, 2);
    A_c << 0, 1, 0, 0;
    B_c << 0, 1;
    for (int i = 0; i < G.size(); ++i) G.data()[i] = nd(gen);
    const Eigen::VectorXd h = Eigen::VectorXd::Constant(3, 50.0);
    auto model = std::make_shared<LtiModel>(A_c, B_c, Eigen::VectorXd::Zero(2), 0.5, G, h);
    Settings s = di_settings(5, 0.5);
    s.u_max(0) = 20.0;
    TubeMPC mpc(model, s);
    mpc.setup(straight_reference(Eigen::VectorXd::Zero(2), Eigen::VectorXd::Zero(2), 20, 1));
    Eigen::MatrixXd M(2, 2);
    M << nd(gen), nd(gen), nd(gen), nd(gen);
    Tube tube;
    tube.Pe = M * M.transpose() + 0.05 * Eigen::MatrixXd::Identity(2, 2);
    tube.K = Eigen::MatrixXd(1, 2);
    tube.K << nd(gen), nd(gen);
    mpc.step(0, Eigen::VectorXd::Zero(2), tube);
    const QpData d = mpc.qp_data();
    const Eigen::MatrixXd L = tube.Pe.llt().matrixL();
    // Dense samples of the boundary {L u : |u| = 1}.
    const int n_samples = 200000;
    Eigen::VectorXd best_G = Eigen::VectorXd::Constant(3, -kUnbounded);
    double best_K = -kUnbounded;
    for (int j = 0; j < n_samples; ++j) {
      const double a = 2.0 * M_PI * j / n_samples;
      const Eigen::Vector2d e = L * Eigen::Vector2d(std::cos(a), std::sin(a));
      best_G = best_G.cwiseMax(G * e);
      best_K = std::max(best_K, (tube.K * e)(0));
    }
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(d.h_u(i), h(i) - best_G(i), 1e-7 * (1.0 + best_G(i))) << trial;
    const int iv0 = 2;  // w = [z_0 (2), v_0 (1), ...]
    EXPECT_NEAR(d.x_u(iv0), s.u_max(0) - best_K, 1e-7 * (1.0 + best_K)) << trial;
    EXPECT_NEAR(d.x_l(iv0), -(s.u_max(0) - best_K), 1e-7 * (1.0 + best_K)) << trial;
  }
}

// Shrinking horizon on a linear plant: the closed loop reaches x_f = zbar_T at T.
TEST(TubeMPC, ShrinkingHorizonReachesTheTarget) {
  const double dt = 0.5;
  auto model = double_integrator(dt, 10.0, 2.0);
  for (auto ic : {InitialCondition::WhitenedBox, InitialCondition::Exact}) {
    Settings s = di_settings(10, dt);
    s.initial_condition = ic;
    TubeMPC mpc(model, s);
    const int T = 30;
    Eigen::VectorXd x0(2), xf(2);
    x0 << 0, 0;
    xf << 3, 0;
    mpc.setup(straight_reference(x0, xf, T, 1));
    Tube tube = small_tube(2, 1, 1e-6);
    tube.K << -0.3, -0.8;
    Eigen::MatrixXd A(2, 2), B(2, 1);
    Eigen::VectorXd c(2), x = x0;
    int shrunk = 0;
    for (int k = 0; k < T; ++k) {
      const StepResult& r = mpc.step(k, x, tube);
      ASSERT_TRUE(r.status == Status::Solved)
          << k << " " << to_string(r.status) << " " << to_string(r.failure);
      EXPECT_EQ(r.horizon, std::min(10, T - k));
      // Linear plant: the re-linearised QP is identical, so one QP per step.
      EXPECT_EQ(r.scp_iterations, 1);
      EXPECT_LT(r.scp_residual, s.scp_eps);
      // The QP has the step's horizon: n + 1 nodes of initial condition and dynamics rows.
      EXPECT_EQ(mpc.qp_data().A.rows(), (r.horizon + 1) * 2);
      if (r.horizon < 10) {
        ++shrunk;
        // The nominal plan ends at x_f and stays there past the mission's end, with zero inputs.
        for (int i = r.horizon; i <= 10; ++i) EXPECT_LT((r.z.col(i) - xf).cwiseAbs().maxCoeff(), 1e-6);
        for (int i = r.horizon; i < 10; ++i) EXPECT_EQ(r.v(0, i), 0.0);
        // The previous step's set, carried over from the QP of one node more, is this QP's: one
        // factorisation (a linear plant without disturbance repeats its plan).
        if (ic == InitialCondition::Exact) EXPECT_EQ(r.active_set_iterations, 1) << k;
      }
      model->discretize(0.0, dt, x, r.u, A, B, c);
      x = A * x + B * r.u + c;
    }
    EXPECT_EQ(shrunk, 9);
    // Without disturbance x - z stays in the tube; with z_0 = x_k it is zero.
    const Eigen::VectorXd e = x - xf;
    if (ic == InitialCondition::Exact)
      EXPECT_LT(e.cwiseAbs().maxCoeff(), 1e-6);
    else
      EXPECT_LE(e.dot(tube.Pe.llt().solve(e)), 1.0 + 1e-6);
  }
}

TEST(TubeMPC, InfeasibleStepFallsBackToTheShiftedPlan) {
  const double dt = 0.5;
  auto sab = std::make_shared<Sabotaged>(double_integrator(dt));
  Settings s = di_settings(10, dt);
  TubeMPC mpc(sab, s);
  Eigen::VectorXd x0(2), xf(2);
  x0 << 0, 0;
  xf << 1, 0;
  mpc.setup(straight_reference(x0, xf, 30, 1));
  Tube tube = small_tube(2, 1, 1e-4);
  tube.K << -0.3, -0.8;

  // No previous plan: the documented safe input.
  sab->contradict = true;
  const StepResult& r0 = mpc.step(0, x0, tube);
  EXPECT_EQ(r0.status, Status::FallbackSafeInput);
  EXPECT_EQ(r0.failure, Status::Infeasible);
  EXPECT_TRUE(r0.u.allFinite());

  sab->contradict = false;
  const StepResult r1 = mpc.step(0, x0, tube);
  ASSERT_EQ(r1.status, Status::Solved);
  Eigen::VectorXd x1(2);
  x1 << 0.01, 0.02;
  sab->contradict = true;
  const StepResult& r2 = mpc.step(1, x1, tube);
  EXPECT_EQ(r2.status, Status::FallbackShiftedPlan);
  EXPECT_EQ(r2.failure, Status::Infeasible);
  for (int i = 0; i < 10; ++i) EXPECT_LT((r2.z.col(i) - r1.z.col(i + 1)).cwiseAbs().maxCoeff(), 1e-12);
  for (int i = 0; i < 9; ++i) EXPECT_LT((r2.v.col(i) - r1.v.col(i + 1)).cwiseAbs().maxCoeff(), 1e-12);
  const double u_expected =
      std::clamp((r1.v.col(1) + tube.K * (x1 - r1.z.col(1)))(0), -s.u_max(0), s.u_max(0));
  EXPECT_NEAR(r2.u(0), u_expected, 1e-12);

  sab->contradict = false;
  sab->nan_dynamics = true;
  const StepResult& r3 = mpc.step(2, x1, tube);
  EXPECT_EQ(r3.status, Status::FallbackShiftedPlan);
  EXPECT_EQ(r3.failure, Status::NumericalError);
  EXPECT_TRUE(r3.u.allFinite() && r3.z.allFinite() && r3.v.allFinite());

  sab->nan_dynamics = false;
  Tube fat = tube;
  fat.K << 100.0, 0.0;  // sqrt(K Pe K^T) = 1 > u_max = 0.5
  EXPECT_EQ(mpc.step(3, x1, fat).failure, Status::EmptyTightening);
  Eigen::VectorXd x_nan = x1;
  x_nan(1) = std::nan("");
  const StepResult& r5 = mpc.step(4, x_nan, tube);
  EXPECT_EQ(r5.failure, Status::NumericalError);
  EXPECT_TRUE(r5.u.allFinite());
}

// Soft state constraints keep the contradictory problem solvable (exact L1 penalty).
TEST(TubeMPC, SoftConstraintsSolveTheContradictoryProblem) {
  auto sab = std::make_shared<Sabotaged>(double_integrator(0.5));
  Settings s = di_settings(10, 0.5);
  s.soft_state_constraints = true;
  TubeMPC mpc(sab, s);
  mpc.setup(straight_reference(Eigen::VectorXd::Zero(2), Eigen::VectorXd::Zero(2), 30, 1));
  sab->contradict = true;
  const StepResult& r = mpc.step(0, Eigen::VectorXd::Zero(2), small_tube(2, 1, 1e-4));
  EXPECT_EQ(r.status, Status::Solved) << to_string(r.failure);
}

TEST(TubeMPC, ScpConvergesOnThePendulum) {
  auto model = std::make_shared<Pendulum>();
  Settings s = pendulum_settings(20);
  s.trust_region = 1.0;
  TubeMPC mpc(model, s);
  const int T = 40;
  Eigen::VectorXd x0(2), xf(2);
  x0 << 0.0, 0.0;
  xf << 2.0, 0.0;  // swing up to 2 rad: far from the linearisation about the straight reference
  Reference ref = straight_reference(x0, xf, T, 1);
  for (int j = 0; j <= T; ++j) ref.z(1, j) = 2.0 / (T * 0.1);
  ref.z(1, 0) = 0.0;
  ref.z(1, T) = 0.0;
  setup_pendulum(mpc, ref);
  const StepResult& r = mpc.step(0, x0, small_tube(2, 1, 1e-8));
  EXPECT_EQ(r.status, Status::Solved) << to_string(r.status) << " " << to_string(r.failure);
  EXPECT_GE(r.scp_iterations, 2);
  EXPECT_LT(r.scp_residual, s.scp_eps);
  // At the fixed point the plan follows the nonlinear pendulum (RK4 over each interval) closely.
  double worst = 0.0;
  for (int i = 0; i < 20; ++i) {
    Eigen::Vector2d y = r.z.col(i);
    const double u = r.v(0, i), h = 0.1 / 50;
    auto f = [&](const Eigen::Vector2d& q) { return Eigen::Vector2d(q(1), -9.81 * std::sin(q(0)) + u); };
    for (int j = 0; j < 50; ++j) {
      const Eigen::Vector2d k1 = f(y), k2 = f(y + 0.5 * h * k1), k3 = f(y + 0.5 * h * k2), k4 = f(y + h * k3);
      y += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
    }
    worst = std::max(worst, (y - r.z.col(i + 1)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 5e-3);

  Settings s1 = s;
  s1.scp_max_iterations = 1;
  TubeMPC one(model, s1);
  setup_pendulum(one, ref);
  EXPECT_EQ(one.step(0, x0, small_tube(2, 1, 1e-8)).status, Status::MaxIterations);
}

// A declared sparser structure gives the same plan as the dense pattern; a model that breaks it is caught.
TEST(TubeMPC, DeclaredStructureIsUsedAndChecked) {
  auto model = double_integrator(0.5, 1.2, 0.3);
  Eigen::VectorXd x0(2), xf(2), x(2);
  x0 << 0, 0;
  xf << 2, 0;
  x << 0.01, 0.25;
  Tube tube = small_tube(2, 1, 1e-3);
  tube.K << -0.5, -1.0;
  Settings dense = di_settings(15, 0.5);
  TubeMPC a(model, dense);
  a.setup(straight_reference(x0, xf, 20, 1));
  const StepResult ra = a.step(0, x, tube);
  Settings sparse = dense;
  sparse.A_structure = (Eigen::MatrixXd(2, 2) << 1, 1, 0, 1).finished();  // the DI's A is upper triangular
  sparse.G_structure = (Eigen::MatrixXd(2, 2) << 1, 0, 0, 1).finished();
  TubeMPC b(model, sparse);
  b.setup(straight_reference(x0, xf, 20, 1));
  const StepResult rb = b.step(0, x, tube);
  ASSERT_EQ(rb.status, Status::Solved);
  EXPECT_LT(b.qp_data().A.nonZeros(), a.qp_data().A.nonZeros());
  EXPECT_LT(b.qp_data().G.nonZeros(), a.qp_data().G.nonZeros());
  EXPECT_LT((ra.z - rb.z).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_NEAR(ra.objective, rb.objective, 1e-8 * std::abs(ra.objective));
  Settings wrong = dense;
  wrong.A_structure = Eigen::MatrixXd::Identity(2, 2);  // misses A(0, 1) = dt
  TubeMPC c(model, wrong);
  c.setup(straight_reference(x0, xf, 20, 1));
  const StepResult& rc = c.step(0, x, tube);
  EXPECT_EQ(rc.failure, Status::ModelStructure);
  EXPECT_EQ(rc.status, Status::FallbackSafeInput);
  Settings bad_size = dense;
  bad_size.B_structure = Eigen::MatrixXd::Ones(1, 1);
  EXPECT_THROW(TubeMPC(model, bad_size), std::invalid_argument);
}

// Repeating a step reproduces it; a skipped step still starts from the plan shifted by the gap.
TEST(TubeMPC, RepeatedAndSkippedStepsUseThePlanShiftedByTheGap) {
  auto sab = std::make_shared<Sabotaged>(double_integrator(0.5));
  TubeMPC mpc(sab, di_settings(10, 0.5));
  Eigen::VectorXd x0(2), xf(2);
  x0 << 0, 0;
  xf << 1, 0;
  mpc.setup(straight_reference(x0, xf, 30, 1));
  Tube tube = small_tube(2, 1, 1e-4);
  tube.K << -0.3, -0.8;
  const StepResult a = mpc.step(3, x0, tube);
  const StepResult b = mpc.step(3, x0, tube);
  ASSERT_EQ(a.status, Status::Solved);
  EXPECT_LT((a.z - b.z).cwiseAbs().maxCoeff(), 1e-9);
  sab->contradict = true;
  const StepResult& c =
      mpc.step(6, x0, tube);  // three steps later, infeasible: candidate = plan shifted by 3
  EXPECT_EQ(c.status, Status::FallbackShiftedPlan);
  for (int i = 0; i + 3 <= 10; ++i) EXPECT_LT((c.z.col(i) - b.z.col(i + 3)).cwiseAbs().maxCoeff(), 1e-12);
  for (int i = 8; i <= 10; ++i) EXPECT_LT((c.z.col(i) - b.z.col(10)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(c.v(0, 9), 0.0);
}

namespace {

// Wraps a time-varying pendulum (time_variation 0.5) with one state-dependent constraint
// cos(theta_lin) theta + theta' <= 10; records the output of every model call by node time.
class RecordingPendulum final : public tubempc::math::LinearizedModel {
 public:
  RecordingPendulum() { inner_.time_variation = 0.5; }
  int nx() const override { return 2; }
  int nu() const override { return 1; }
  int n_constraints() const override { return 1; }
  void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x,
                  const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override {
    inner_.discretize(t, dt, x, u, A, B, c);
    dynamics[t] = A;
    points[t] = x;
    inputs[t] = u;
    whole[t].push_back(x);
    call_times.push_back(t);
    ++discretize_calls;
  }
  // Counts the calls whose incoming data and point are not this node's latest model output. With
  // keep_tolerance >= 0 it keeps the incoming data when x moved at most that far from x_prev (as the
  // proximity model keeps its gravity's blocks), and counts the calls whose x_prev is not a point the
  // model computed this node's data about whole (whole_mismatches).
  bool rediscretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_prev,
                    const Eigen::Ref<const Eigen::VectorXd>& u_prev,
                    const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                    Eigen::Ref<Eigen::MatrixXd> A, Eigen::Ref<Eigen::MatrixXd> B,
                    Eigen::Ref<Eigen::VectorXd> c) const override {
    ++rediscretize_calls;
    const bool known = dynamics.count(t) == 1;
    if (!known || !(dynamics[t] == A) || !(points[t] == x_prev) || !(inputs[t] == u_prev))
      ++rediscretize_mismatches;
    bool whole_point = false;
    for (const Eigen::VectorXd& p : whole[t]) whole_point = whole_point || p == x_prev;
    whole_mismatches += whole_point ? 0 : 1;
    if (keep_tolerance >= 0.0 && (x - x_prev).cwiseAbs().maxCoeff() <= keep_tolerance) {
      ++kept_calls;
      kept_from_reference += whole[t].front() == x_prev ? 1 : 0;  // the first whole point: setup's
      dynamics[t] = A;
      return true;
    }
    discretize(t, dt, x, u, A, B, c);
    return false;
  }
  void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x, Eigen::Ref<Eigen::MatrixXd> G,
                   Eigen::Ref<Eigen::VectorXd> h) const override {
    G << std::cos(x(0)), 1.0;
    h << 10.0;
    rows[t] = G;
  }
  mutable std::map<double, Eigen::MatrixXd> dynamics, rows;      // latest output per node time
  mutable std::map<double, Eigen::VectorXd> points, inputs;      // latest linearisation point per node time
  mutable std::vector<double> call_times;                        // node time of every discretize call
  mutable std::map<double, std::vector<Eigen::VectorXd>> whole;  // every point discretize took per node time
  mutable int discretize_calls = 0, rediscretize_calls = 0, rediscretize_mismatches = 0;
  mutable int kept_calls = 0, kept_from_reference = 0, whole_mismatches = 0;
  double keep_tolerance = -1.0;

 private:
  Pendulum inner_;
};

// The re-linearisation tests' reference: a 30-step swing from theta = 0 to 1 rad, starting at t0 = 0.3 s.
Reference swing_reference() {
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(2), xf(2);
  xf << 1.0, 0.0;
  Reference ref = straight_reference(x0, xf, 30, 1);
  ref.t0 = 0.3;
  return ref;
}

}  // namespace

// A step after a converged step calls the model in its first SCP iteration only at the node it appends
// (none in the shrinking phase), later iterations only where the plan moved by scp_eps or more; the QP
// holds exactly the model's latest data for each node's time (no off-by-one shift), taken about points
// within scp_eps of the converged plan, and the plans match those of a controller that calls the model
// everywhere within the SCP tolerance. Re-discretisations receive the node's current data and their point.
TEST(TubeMPC, ReusedLinearizationHoldsEachNodesModelData) {
  auto model = std::make_shared<RecordingPendulum>();
  auto fresh_model = std::make_shared<RecordingPendulum>();
  const Settings s = pendulum_settings(12);
  Settings s_fresh = s;
  s_fresh.linearization = Linearization::EveryIteration;
  TubeMPC mpc(model, s), fresh(fresh_model, s_fresh);
  const Reference ref = swing_reference();
  const int T = static_cast<int>(ref.u.cols());
  const Eigen::VectorXd x0 = ref.z.col(0);
  setup_pendulum(mpc, ref);
  setup_pendulum(fresh, ref);
  const Tube tube = small_tube(2, 1, 1e-8);
  Eigen::VectorXd x = x0;
  int reused_steps = 0;
  for (int k = 0; k < T; ++k) {
    const int calls_before = model->discretize_calls;
    const StepResult r = mpc.step(k, x, tube);
    const StepResult& rf = fresh.step(k, x, tube);
    ASSERT_EQ(r.status, Status::Solved) << k;
    ASSERT_EQ(rf.status, Status::Solved) << k;
    EXPECT_EQ(r.model_evaluations, model->discretize_calls - calls_before);
    EXPECT_EQ(rf.model_evaluations, rf.horizon * rf.scp_iterations);
    {  // the previous step converged (k = 0: setup primed the reference's data), so the first
       // iteration calls the model at the appended node only
      const int appended = r.horizon == s.horizon ? 1 : 0;
      if (r.scp_iterations == 1) EXPECT_EQ(r.model_evaluations, appended) << k;
      EXPECT_LE(r.model_evaluations, appended + (r.scp_iterations - 1) * r.horizon) << k;
      if (appended == 1) EXPECT_EQ(model->call_times[calls_before], ref.t0 + (k + s.horizon - 1) * s.dt) << k;
      reused_steps += r.model_evaluations < r.horizon * r.scp_iterations ? 1 : 0;
    }
    const QpData qp = mpc.qp_data();
    for (int i = 0; i < r.horizon; ++i) {
      const double t = ref.t0 + (k + i) * s.dt;
      ASSERT_EQ(model->dynamics.count(t), 1u) << k << " " << i;
      const Eigen::MatrixXd A_qp = -Eigen::MatrixXd(qp.A.block((i + 1) * 2, i * 3, 2, 2));
      EXPECT_EQ((A_qp - model->dynamics[t]).cwiseAbs().maxCoeff(), 0.0) << k << " " << i;
      EXPECT_LT((model->points[t] - r.z.col(i)).cwiseAbs().maxCoeff(), s.scp_eps) << k << " " << i;
    }
    for (int i = 0; i <= r.horizon; ++i) {
      const double t = ref.t0 + (k + i) * s.dt;
      const Eigen::MatrixXd G_qp(qp.G.block(i, i < s.horizon ? i * 3 : s.horizon * 3, 1, 2));
      EXPECT_EQ((G_qp - model->rows[t]).cwiseAbs().maxCoeff(), 0.0) << k << " " << i;
    }
    EXPECT_LT((r.z - rf.z).cwiseAbs().maxCoeff(), 10 * s.scp_eps) << k;
    EXPECT_LT((r.u - rf.u).cwiseAbs().maxCoeff(), 1e-2 * s.u_max(0)) << k;
    x = r.z.col(1) + Eigen::Vector2d(1e-5 * ((k % 3) - 1.0), 2e-5 * ((k % 2) - 0.5));
  }
  EXPECT_EQ(reused_steps, T);
  // Later SCP iterations hand the model the node's current data and the point they were taken about.
  EXPECT_GT(model->rediscretize_calls, 0);
  EXPECT_EQ(model->rediscretize_mismatches, 0);
  // After reset() or a skipped step the first iteration calls the model at every node again.
  for (const int k : {5, 7}) {
    if (k == 5) mpc.reset();
    const std::size_t before = model->call_times.size();
    const StepResult& r = mpc.step(k, x0, tube);
    ASSERT_GE(r.model_evaluations, s.horizon);
    for (int i = 0; i < s.horizon; ++i)
      EXPECT_EQ(model->call_times[before + i], ref.t0 + (k + i) * s.dt) << k;
  }
}

// ScpMode::RealTime runs one QP per step; the next step re-linearises about that QP's plan exactly the
// nodes it moved by scp_eps or more from their linearisation points (and the node it appends), hands
// the re-used nodes' data and points to rediscretize, and keeps the others' data; its commands stay
// close to those of a controller that iterates to convergence.
TEST(TubeMPC, RealTimeIterationRelinearizesTheNodesTheLastQpMoved) {
  auto model = std::make_shared<RecordingPendulum>();
  auto converged_model = std::make_shared<RecordingPendulum>();
  Settings s = pendulum_settings(12);
  const Settings s_converge = s;
  s.scp_mode = ScpMode::RealTime;
  TubeMPC mpc(model, s), reference_mpc(converged_model, s_converge);
  const Reference ref = swing_reference();
  const int T = static_cast<int>(ref.u.cols());
  const Eigen::VectorXd x0 = ref.z.col(0);
  setup_pendulum(mpc, ref);
  setup_pendulum(reference_mpc, ref);
  const Tube tube = small_tube(2, 1, 1e-8);
  Eigen::VectorXd x = x0;
  Eigen::MatrixXd last_plan;
  std::map<double, Eigen::VectorXd> last_points;
  int moved_total = 0;
  for (int k = 0; k < T; ++k) {
    const int calls_before = model->discretize_calls;
    const StepResult r = mpc.step(k, x, tube);
    const StepResult& rc = reference_mpc.step(k, x, tube);
    ASSERT_EQ(r.status, Status::Solved) << k;
    ASSERT_EQ(rc.status, Status::Solved) << k;
    EXPECT_EQ(r.scp_iterations, 1) << k;
    EXPECT_EQ(r.model_evaluations, model->discretize_calls - calls_before) << k;
    if (k > 0) {
      int expected = r.horizon == s.horizon ? 1 : 0;  // the appended node
      for (int i = 0; i < r.horizon; ++i) {
        const double t = ref.t0 + (k + i) * s.dt;
        if (r.horizon == s.horizon && i == r.horizon - 1) continue;  // the appended node
        const bool moved = (last_plan.col(i + 1) - last_points[t]).cwiseAbs().maxCoeff() >= s.scp_eps;
        expected += moved ? 1 : 0;
        moved_total += moved ? 1 : 0;
        const Eigen::VectorXd& now = model->points[t];
        EXPECT_EQ(
            (now - (moved ? Eigen::VectorXd(last_plan.col(i + 1)) : last_points[t])).cwiseAbs().maxCoeff(),
            0.0)
            << k << " " << i;
      }
      EXPECT_EQ(r.model_evaluations, expected) << k;
    }
    const QpData qp = mpc.qp_data();
    for (int i = 0; i < r.horizon; ++i) {
      const double t = ref.t0 + (k + i) * s.dt;
      const Eigen::MatrixXd A_qp = -Eigen::MatrixXd(qp.A.block((i + 1) * 2, i * 3, 2, 2));
      EXPECT_EQ((A_qp - model->dynamics[t]).cwiseAbs().maxCoeff(), 0.0) << k << " " << i;
    }
    EXPECT_LT((r.u - rc.u).cwiseAbs().maxCoeff(), 1e-2 * s.u_max(0)) << k;
    last_plan = r.z;
    last_points = model->points;
    x = r.z.col(1) + Eigen::Vector2d(1e-5 * ((k % 3) - 1.0), 2e-5 * ((k % 2) - 0.5));
  }
  EXPECT_GT(moved_total, 0);  // the test exercised the re-linearisation of moved nodes
  EXPECT_EQ(model->rediscretize_mismatches, 0);
  Settings bad = s;
  bad.linearization = Linearization::EveryIteration;
  EXPECT_THROW(bad.validate(2, 1), std::invalid_argument);
}

// A model that keeps its data within a tolerance (as the proximity model keeps its gravity's blocks) is
// always handed, as x_prev, a point it computed the node's data about whole: the reference's (setup's
// discretisation at that time) for a new node, else the node's last whole evaluation. So its tolerance bounds
// the distance to the data's own point: a node that moves by less than the tolerance from step to step is
// computed whole again once it is beyond it, not kept on from its last point.
TEST(TubeMPC, KeptDataAreAlwaysMeasuredFromThePointTheyWereComputedAbout) {
  auto model = std::make_shared<RecordingPendulum>();
  model->keep_tolerance = 2e-2;  // above scp_eps (1e-3), the distance that triggers a re-linearisation
  Settings s = pendulum_settings(12);
  s.scp_mode = ScpMode::RealTime;
  TubeMPC mpc(model, s);
  const Reference ref = swing_reference();
  setup_pendulum(mpc, ref);
  const int T = static_cast<int>(ref.u.cols());
  EXPECT_EQ(model->discretize_calls, T);  // setup: the reference's data at every node
  const Tube tube = small_tube(2, 1, 1e-8);
  int whole_in_steps = 0;
  for (int k = 0; k < T; ++k) {
    // the state walks away from the reference in steps smaller than the tolerance
    const Eigen::VectorXd x = ref.z.col(k) + Eigen::Vector2d(4e-4 * k, 0.0);
    const int before = model->discretize_calls;
    ASSERT_EQ(mpc.step(k, x, tube).status, Status::Solved) << k;
    whole_in_steps += model->discretize_calls - before;
  }
  EXPECT_EQ(model->whole_mismatches, 0);
  EXPECT_GT(model->kept_from_reference, 0);  // new nodes kept the reference's data
  EXPECT_GT(model->kept_calls, model->kept_from_reference);
  EXPECT_GT(whole_in_steps, 0);
}
