// ActiveSetQp against PIQP (an independent solver) on random QPs, the KKT conditions of its pair
// checked independently, warm starts, bad data; and the tube MPC with either backend.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <piqp/piqp.hpp>
#include <random>
#include <stdexcept>

#include "tubempc/mpc/active_set_qp.hpp"
#include "tubempc/mpc/lti_model.hpp"
#include "tubempc/mpc/tube_mpc.hpp"

using namespace tubempc::mpc;
using SpMat = ActiveSetQp::SpMat;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A random feasible QP: strictly convex cost, equality rows, two-sided G rows and bounds on the first
// n_bounded variables, all around a feasible point, with a linear cost that makes some rows active.
struct RandomQp {
  SpMat P, A, G;
  Eigen::VectorXd q, b, h_l, h_u, x_l, x_u;
  Eigen::Array<bool, Eigen::Dynamic, 1> boundable;

  RandomQp(unsigned seed, int n = 30, int m = 8, int p = 12, int n_bounded = 10) {
    std::mt19937 gen(seed);
    std::normal_distribution<double> N01;
    std::uniform_real_distribution<double> U(0.05, 1.0);
    const auto randn = [&](int r, int c) {
      return Eigen::MatrixXd(Eigen::MatrixXd::NullaryExpr(r, c, [&] { return N01(gen); }));
    };
    const Eigen::MatrixXd M = randn(n, n);
    const Eigen::MatrixXd H = M * M.transpose() / n + 0.1 * Eigen::MatrixXd::Identity(n, n);
    P = H.triangularView<Eigen::Upper>().toDenseMatrix().sparseView();
    const Eigen::VectorXd w0 = randn(n, 1);
    const Eigen::MatrixXd Ad = randn(m, n), Gd = randn(p, n);
    A = Ad.sparseView();
    G = Gd.sparseView();
    P.makeCompressed();
    A.makeCompressed();
    G.makeCompressed();
    b = Ad * w0;
    q = 5.0 * randn(n, 1);
    h_l = Gd * w0;
    h_u = h_l;
    for (int i = 0; i < p; ++i) {
      h_l(i) -= U(gen);
      h_u(i) += U(gen);
    }
    h_l(0) = -kInf;  // one one-sided row
    x_l = Eigen::VectorXd::Constant(n, -kInf);
    x_u = Eigen::VectorXd::Constant(n, kInf);
    boundable = Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(n, false);
    for (int j = 0; j < n_bounded; ++j) {
      x_l(j) = w0(j) - U(gen);
      x_u(j) = w0(j) + U(gen);
      boundable(j) = true;
    }
    boundable(n_bounded) = true;  // may carry bounds but has none here
  }

  double objective(const Eigen::VectorXd& w) const {
    const SpMat Pf = P.selfadjointView<Eigen::Upper>();
    return 0.5 * w.dot(Pf * w) + q.dot(w);
  }
};

// Sets `as` up for qp (60 factorisations: cold starts on random data) and returns an empty working set.
Eigen::VectorXi set_up_cold(ActiveSetQp& as, const RandomQp& qp) {
  ActiveSetQp::Settings s;
  s.max_iterations = 60;
  as.setup(qp.P, qp.A, qp.G, qp.boundable, s);
  return Eigen::VectorXi::Zero(qp.G.rows() + qp.P.rows());
}

ActiveSetQp::Status solve(ActiveSetQp& as, const RandomQp& d, Eigen::VectorXi& active) {
  return as.solve(d.P, d.q, d.A, d.b, d.G, d.h_l, d.h_u, d.x_l, d.x_u, active);
}

}  // namespace

TEST(ActiveSetQp, MatchesPiqpOnRandomQps) {
  int with_active_rows = 0;
  for (unsigned seed = 0; seed < 20; ++seed) {
    RandomQp qp(seed);
    ActiveSetQp as;
    Eigen::VectorXi active = set_up_cold(as, qp);
    ASSERT_EQ(solve(as, qp, active), ActiveSetQp::Status::Solved)
        << "seed " << seed << ": " << to_string(as.info().status);
    with_active_rows += as.info().n_active > 0;

    piqp::SparseSolver<double> piqp;
    piqp.settings().eps_abs = 1e-10;
    piqp.settings().eps_rel = 1e-11;
    piqp.setup(qp.P, qp.q, qp.A, qp.b, qp.G, qp.h_l, qp.h_u, qp.x_l, qp.x_u);
    ASSERT_EQ(piqp.solve(), piqp::Status::PIQP_SOLVED) << "seed " << seed;
    const double f_piqp = qp.objective(piqp.result().x);
    EXPECT_NEAR(as.objective(), f_piqp, 1e-7 * std::max(1.0, std::abs(f_piqp))) << "seed " << seed;
    EXPECT_NEAR(as.objective(), qp.objective(as.w()), 1e-9 * std::max(1.0, std::abs(f_piqp)));
    EXPECT_LT((as.w() - piqp.result().x).lpNorm<Eigen::Infinity>(), 1e-6) << "seed " << seed;
  }
  EXPECT_GE(with_active_rows, 15);  // the test exercises constraints
}

TEST(ActiveSetQp, ReturnedPairSatisfiesTheKktConditions) {
  for (unsigned seed = 100; seed < 110; ++seed) {
    RandomQp qp(seed);
    ActiveSetQp as;
    Eigen::VectorXi active = set_up_cold(as, qp);
    ASSERT_EQ(solve(as, qp, active), ActiveSetQp::Status::Solved);
    const Eigen::VectorXd& w = as.w();
    const SpMat Pf = qp.P.selfadjointView<Eigen::Upper>();
    const Eigen::VectorXd stat = Pf * w + qp.q + qp.A.transpose() * as.y() +
                                 qp.G.transpose() * (as.z_u() - as.z_l()) + as.z_bu() - as.z_bl();
    EXPECT_LT(stat.lpNorm<Eigen::Infinity>(), 1e-8);
    EXPECT_LT((qp.A * w - qp.b).lpNorm<Eigen::Infinity>(), 1e-9);
    const Eigen::VectorXd g = qp.G * w;
    for (Eigen::Index i = 0; i < g.size(); ++i) {
      EXPECT_LE(g(i), qp.h_u(i) + 1e-9);
      EXPECT_GE(g(i), qp.h_l(i) - 1e-9);
      EXPECT_GE(as.z_u()(i), 0.0);
      EXPECT_GE(as.z_l()(i), 0.0);
      if (as.z_u()(i) > 0.0) EXPECT_NEAR(g(i), qp.h_u(i), 1e-9);  // complementarity
      if (as.z_l()(i) > 0.0) EXPECT_NEAR(g(i), qp.h_l(i), 1e-9);
    }
    for (Eigen::Index j = 0; j < w.size(); ++j) {
      EXPECT_LE(w(j), qp.x_u(j) + 1e-9);
      EXPECT_GE(w(j), qp.x_l(j) - 1e-9);
      if (as.z_bu()(j) > 0.0) EXPECT_NEAR(w(j), qp.x_u(j), 1e-9);
      if (as.z_bl()(j) > 0.0) EXPECT_NEAR(w(j), qp.x_l(j), 1e-9);
    }
  }
}

TEST(ActiveSetQp, WarmStartFromTheOptimalSetTakesOneFactorisation) {
  RandomQp qp(7);
  ActiveSetQp as;
  Eigen::VectorXi active = set_up_cold(as, qp);
  ASSERT_EQ(solve(as, qp, active), ActiveSetQp::Status::Solved);
  const int cold = as.info().iterations;
  const Eigen::VectorXd w = as.w();
  ASSERT_GT(as.info().n_active, 0);
  ASSERT_EQ(solve(as, qp, active), ActiveSetQp::Status::Solved);
  EXPECT_EQ(as.info().iterations, 1);
  EXPECT_GT(cold, 1);
  EXPECT_LT((as.w() - w).lpNorm<Eigen::Infinity>(), 1e-10);
}

// min 1/2 |w|^2 - 0.8 w_0 with the row w_0 <= 0.5 and the bound w_0 <= 1: a guess with both active holds
// w_0 at two values (dependent rows), which the regularised KKT matrix answers with multipliers of
// ~0.5 / dual_reg. The primal-dual phase stops there at once (or, without the ratio test, within its
// iterations) and the dual phase, which drops the wrong-sign row, returns the optimum.
TEST(ActiveSetQp, DependentActiveRowsGoToTheDualPhase) {
  SpMat P(2, 2), A(0, 2), G(1, 2);
  P.insert(0, 0) = 1.0;
  P.insert(1, 1) = 1.0;
  G.insert(0, 0) = 1.0;
  P.makeCompressed();
  A.makeCompressed();
  G.makeCompressed();
  const Eigen::VectorXd q = Eigen::Vector2d(-0.8, 0.0), b(0), h_l = Eigen::VectorXd::Constant(1, -kInf),
                        h_u = Eigen::VectorXd::Constant(1, 0.5), x_l = Eigen::Vector2d(-1.0, -kInf),
                        x_u = Eigen::Vector2d(1.0, kInf);
  const Eigen::Array<bool, Eigen::Dynamic, 1> boundable = Eigen::Array<bool, 2, 1>(true, false);
  for (const double ratio : {1e6, kInf}) {
    ActiveSetQp as;
    ActiveSetQp::Settings s;
    s.max_multiplier_ratio = ratio;
    as.setup(P, A, G, boundable, s);
    Eigen::VectorXi dependent(3);
    dependent << 1, 1, 0;  // the row's upper side and w_0's upper bound
    ASSERT_EQ(as.solve(P, q, A, b, G, h_l, h_u, x_l, x_u, dependent), ActiveSetQp::Status::Solved);
    if (std::isfinite(ratio)) EXPECT_LE(as.info().iterations, 3);  // 1 primal-dual, then the dual phase
    EXPECT_NEAR(as.w()(0), 0.5, 1e-12);
    EXPECT_NEAR(as.z_u()(0), 0.3, 1e-9);
    EXPECT_EQ(as.z_bu()(0), 0.0);
    EXPECT_EQ(dependent(0), 1);
    EXPECT_EQ(dependent(1), 0);
  }
}

// The dual phase alone (after one primal-dual factorisation), from cold starts and from random guesses
// (wrong-sign and dependent rows among them), reaches PIQP's optimum on every random QP.
TEST(ActiveSetQp, DualPhaseMatchesPiqpFromAnyGuess) {
  std::mt19937 gen(11);
  std::uniform_int_distribution<int> side(-1, 1);
  int dual_factorisations = 0;
  for (unsigned seed = 200; seed < 215; ++seed) {
    RandomQp qp(seed);
    piqp::SparseSolver<double> piqp;
    piqp.settings().eps_abs = 1e-10;
    piqp.settings().eps_rel = 1e-11;
    piqp.setup(qp.P, qp.q, qp.A, qp.b, qp.G, qp.h_l, qp.h_u, qp.x_l, qp.x_u);
    ASSERT_EQ(piqp.solve(), piqp::Status::PIQP_SOLVED) << "seed " << seed;
    const double f_piqp = qp.objective(piqp.result().x);
    ActiveSetQp as;
    ActiveSetQp::Settings s;
    s.max_iterations = 60;
    s.primal_dual_iterations = 1;
    as.setup(qp.P, qp.A, qp.G, qp.boundable, s);
    for (int guess = 0; guess < 3; ++guess) {
      Eigen::VectorXi active = Eigen::VectorXi::Zero(qp.G.rows() + qp.P.rows());
      if (guess > 0)
        for (Eigen::Index i = 0; i < active.size(); ++i) active(i) = side(gen);
      ASSERT_EQ(solve(as, qp, active), ActiveSetQp::Status::Solved)
          << "seed " << seed << " guess " << guess << ": " << to_string(as.info().status);
      dual_factorisations += as.info().iterations - 1;
      EXPECT_NEAR(as.objective(), f_piqp, 1e-7 * std::max(1.0, std::abs(f_piqp))) << "seed " << seed;
      EXPECT_LT((as.w() - piqp.result().x).lpNorm<Eigen::Infinity>(), 1e-6) << "seed " << seed;
    }
  }
  EXPECT_GT(dual_factorisations, 45);  // the dual phase did the work
  ActiveSetQp::Settings bad;
  bad.primal_dual_iterations = 0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

// An exact L1 penalty, as the tube MPC's soft terminal constraint: min 1/2 |w|^2 + t + 1/2 t^2 with
// |w_0 + w_1| <= t (the pair rows w_0 + w_1 - t <= 0 and w_0 + w_1 + t >= 0) and w_0 <= 3; optimum w = 0,
// t = 0 with both pair rows active (multipliers 1/2 each) and the bound inactive. The guess "bound and
// both pair rows active" holds w = (3, -3): the bound's multiplier is -6 and the lower pair row's -1,
// both wrong. Dropping both (the primal-dual step) leaves t = -2 and costs a third factorisation;
// with the pair marked (set_penalty_rows) only the bound leaves and the second factorisation is the optimum.
TEST(ActiveSetQp, PenaltyRowsStayWhileAnotherRowIsWrong) {
  SpMat P(3, 3), A(0, 3), G(2, 3);
  P.insert(0, 0) = 1.0;
  P.insert(1, 1) = 1.0;
  P.insert(2, 2) = 1.0;
  G.insert(0, 0) = 1.0;
  G.insert(0, 1) = 1.0;
  G.insert(0, 2) = -1.0;
  G.insert(1, 0) = 1.0;
  G.insert(1, 1) = 1.0;
  G.insert(1, 2) = 1.0;
  P.makeCompressed();
  A.makeCompressed();
  G.makeCompressed();
  const Eigen::VectorXd q = Eigen::Vector3d(0.0, 0.0, 1.0), b(0), h_l = Eigen::Vector2d(-kInf, 0.0),
                        h_u = Eigen::Vector2d(0.0, kInf), x_l = Eigen::Vector3d::Constant(-kInf),
                        x_u = Eigen::Vector3d(3.0, kInf, kInf);
  const Eigen::Array<bool, Eigen::Dynamic, 1> boundable = Eigen::Array<bool, 3, 1>(true, false, false);
  for (const bool marked : {true, false}) {
    ActiveSetQp as;
    as.setup(P, A, G, boundable, ActiveSetQp::Settings{});
    if (marked) as.set_penalty_rows(Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(2, true));
    Eigen::VectorXi guess(5);
    guess << 1, -1, 1, 0, 0;  // both pair rows and w_0's upper bound
    ASSERT_EQ(as.solve(P, q, A, b, G, h_l, h_u, x_l, x_u, guess), ActiveSetQp::Status::Solved) << marked;
    EXPECT_EQ(as.info().iterations, marked ? 2 : 3);
    EXPECT_LT(as.w().lpNorm<Eigen::Infinity>(), 1e-12) << marked;
    EXPECT_NEAR(as.z_u()(0), 0.5, 1e-9);
    EXPECT_NEAR(as.z_l()(1), 0.5, 1e-9);
    EXPECT_EQ(guess(2), 0);
  }
  ActiveSetQp as;
  as.setup(P, A, G, boundable, ActiveSetQp::Settings{});
  EXPECT_THROW(as.set_penalty_rows(Eigen::Array<bool, Eigen::Dynamic, 1>::Constant(3, true)),
               std::invalid_argument);
}

TEST(ActiveSetQp, ReportsBadDataAndUnsolvedProblemsAsStatuses) {
  RandomQp qp(3);
  ActiveSetQp as;
  Eigen::VectorXi active = set_up_cold(as, qp);
  const auto solve_cold = [&](const RandomQp& d) {
    active.setZero();
    return solve(as, d, active);
  };
  RandomQp bad = qp;
  bad.q(2) = std::nan("");
  EXPECT_EQ(solve_cold(bad), ActiveSetQp::Status::InvalidData);
  bad = qp;
  bad.x_u(25) = 1.0;  // variable 25 was not declared boundable
  EXPECT_EQ(solve_cold(bad), ActiveSetQp::Status::InvalidData);
  bad = qp;
  bad.h_l(3) = bad.h_u(3) + 1.0;
  EXPECT_EQ(solve_cold(bad), ActiveSetQp::Status::InvalidData);
  // Infeasible: w_10 >= 1 (its bound) but G row 1 = e_10 with G w <= 0.
  bad = qp;
  for (Eigen::Index k = 0; k < bad.G.nonZeros(); ++k) bad.G.valuePtr()[k] = 0.0;
  bad.G.coeffRef(1, 10) = 1.0;
  bad.h_l(1) = -kInf;
  bad.h_u(1) = 0.0;
  bad.x_l(10) = 1.0;
  bad.x_u(10) = 2.0;
  const ActiveSetQp::Status st = solve_cold(bad);
  EXPECT_NE(st, ActiveSetQp::Status::Solved) << to_string(st);
  EXPECT_EQ(solve_cold(qp), ActiveSetQp::Status::Solved);  // and the solver is still usable

  ActiveSetQp::Settings s;
  s.max_iterations = 0;
  try {
    s.validate();
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_iterations"), std::string::npos);
  }
  s = ActiveSetQp::Settings{};
  s.dual_reg = 0.0;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  EXPECT_THROW(as.setup(qp.P, qp.A, qp.G, qp.boundable.head(3), ActiveSetQp::Settings{}),
               std::invalid_argument);
}

// The tube MPC with either backend on the same states: the same QPs (a linear plant, no trust
// region), hence the same optima, on a 12-state, 6-input plant whose input limits and state bound
// are active, most QPs by the active set and none by it with PiqpSparse.
TEST(TubeMPC, ActiveSetBackendMatchesPiqp) {
  const double dt = 2.0;
  Eigen::MatrixXd A_c = Eigen::MatrixXd::Zero(12, 12), B_c = Eigen::MatrixXd::Zero(12, 6);
  A_c.block(0, 3, 3, 3).setIdentity();
  A_c.block(6, 9, 3, 3).setIdentity();
  B_c.block(3, 0, 3, 3).setIdentity();
  B_c.block(9, 3, 3, 3) = 1e-3 * Eigen::MatrixXd::Identity(3, 3);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(2, 12);
  G(0, 0) = 1.0;   // x <= 52
  G(1, 3) = -1.0;  // -v_x <= 1.2
  Eigen::VectorXd h(2);
  h << 52.0, 1.2;
  auto model = std::make_shared<LtiModel>(A_c, B_c, Eigen::VectorXd::Zero(12), dt, G, h);
  const int T = 40;
  Reference ref;
  ref.z = Eigen::MatrixXd::Zero(12, T + 1);
  ref.u = Eigen::MatrixXd::Zero(6, T);
  for (int j = 0; j <= T; ++j) ref.z(0, j) = 50.0 * (1.0 - static_cast<double>(j) / T);
  ref.z.block(3, 0, 1, T + 1).setConstant(-50.0 / (T * dt));
  Tube tube;
  tube.K = Eigen::MatrixXd::Zero(6, 12);
  tube.Pe = 1e-4 * Eigen::MatrixXd::Identity(12, 12);
  std::unique_ptr<TubeMPC> mpc[2];
  for (int b = 0; b < 2; ++b) {
    Settings s;
    s.horizon = 15;
    s.dt = dt;
    s.u_max = Eigen::VectorXd::Constant(6, 0.05);
    s.time_limit = kInf;
    s.qp_solver = b == 0 ? QpSolver::ActiveSet : QpSolver::Piqp;
    mpc[b] = std::make_unique<TubeMPC>(model, s);
    mpc[b]->setup(ref);
  }
  Eigen::VectorXd x = ref.z.col(0);
  x(3) = 0.35;  // moving away: braking at the input limit ends near the position bound
  Eigen::MatrixXd Ad(12, 12), Bd(12, 6);
  Eigen::VectorXd c(12);
  int as_solves[2] = {0, 0}, qps = 0;
  double max_input = 0.0;
  for (int k = 0; k < T; ++k) {
    const StepResult& r = mpc[0]->step(k, x, tube);
    const StepResult& p = mpc[1]->step(k, x, tube);
    ASSERT_EQ(r.status, Status::Solved) << "k " << k;
    ASSERT_EQ(p.status, Status::Solved) << "k " << k;
    // Both optima to the solvers' tolerances; a 1e-10 error in a soft-terminal slack costs 1e-4 of
    // objective through its 1e6 L1 penalty.
    EXPECT_NEAR(r.objective, p.objective, 1e-4) << "k " << k;
    EXPECT_LT((r.z - p.z).lpNorm<Eigen::Infinity>(), 1e-5) << "k " << k;
    as_solves[0] += r.active_set_solves;
    as_solves[1] += p.active_set_solves;
    qps += r.scp_iterations;
    max_input = std::max(max_input, r.v.cwiseAbs().maxCoeff());
    model->discretize(0.0, dt, x, r.u, Ad, Bd, c);
    x = Ad * x + Bd * r.u + c;
  }
  EXPECT_GE(max_input, 0.05 - 1e-9);  // input bounds active
  EXPECT_GE(as_solves[0], qps * 9 / 10);
  EXPECT_EQ(as_solves[1], 0);
}
