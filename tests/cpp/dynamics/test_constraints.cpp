// Glide-slope and line-of-sight constraints: the paper's boundary states, gradients, linearisation.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_fields.hpp"
#include "tubempc/dynamics/constraints.hpp"
#include "tubempc/dynamics/linearized_proximity.hpp"

namespace tubempc::dynamics {
namespace {

constexpr double kDeg = M_PI / 180.0;

StateVector table2_initial() {
  StateVector x;
  x << 959.2404, 162.4966, 752.7547, 7.7649e-4, 0.0844, -0.0192, 0.3142, 2.925, 0.3142, 1e-3, 0.0, 3e-3;
  return x;
}
StateVector table2_terminal() {
  StateVector x = StateVector::Zero();
  x(2) = 246.5;
  x(7) = 3.1416;
  return x;
}

TEST(Constraints, PaperBoundaryStatesSatisfyBothCones) {
  const Eigen::Vector3d b(0, 0, 1);
  for (const StateVector& x : {table2_initial(), table2_terminal()}) {
    EXPECT_LT(glide_slope_constraint(x, 70 * kDeg), 0.0);
    EXPECT_LT(line_of_sight_constraint(x, 80 * kDeg, b), 0.0);
  }
  // Terminal: the body z axis points along -z_L, at the asteroid: g_los = |r| cos 80 - |r|.
  EXPECT_NEAR(line_of_sight_constraint(table2_terminal(), 80 * kDeg, b), 246.5 * (std::cos(80 * kDeg) - 1.0),
              1e-6);
  // The literal reading (boresight +y_B and r_B along +C_BL r) is violated at the terminal state.
  const StateVector xf = table2_terminal();
  const Eigen::Vector3d r_B_literal =
      math::rotation_matrix(math::exp_map(xf.segment<3>(6))).transpose() * xf.head<3>();
  EXPECT_LT(r_B_literal.y(), 246.5 * std::cos(80 * kDeg));
}

TEST(Constraints, GradientsMatchFiniteDifferencesAndLinearisationIsTangent) {
  std::mt19937 rng(11u);
  std::normal_distribution<double> N(0.0, 1.0);
  const Eigen::Vector3d b = Eigen::Vector3d(0.2, -0.3, 1.0);
  for (int k = 0; k < 30; ++k) {
    StateVector x;
    for (int i = 0; i < 12; ++i) x(i) = N(rng);
    x.head<3>() *= 500.0;
    x.segment<3>(6) *= 1.2;
    for (int which = 0; which < 2; ++which) {
      auto g = [&](const StateVector& xx, StateVector* grad) {
        return which == 0 ? glide_slope_constraint(xx, 70 * kDeg, grad)
                          : line_of_sight_constraint(xx, 80 * kDeg, b, grad);
      };
      StateVector grad;
      const double g0 = g(x, &grad);
      for (int j = 0; j < 12; ++j) {
        const double h = j < 3 ? 1e-3 : 1e-5;
        StateVector xp = x, xm = x;
        xp(j) += h;
        xm(j) -= h;
        const double fd = (g(xp, nullptr) - g(xm, nullptr)) / (2 * h);
        EXPECT_NEAR(fd, grad(j), 1e-7 * std::max(1.0, grad.cwiseAbs().maxCoeff())) << which << " " << j;
      }
      const double bnd = linearized_bound(g0, grad, x);
      EXPECT_NEAR(grad.dot(x) - bnd, g0, 1e-9 * std::abs(bnd) + 1e-12);
      if (which == 0) EXPECT_NEAR(bnd, 0.0, 1e-10 * x.head<3>().norm());  // tangent plane through the apex
    }
  }
}

TEST(Constraints, GlideSlopeLinearisationIsAnOuterApproximation) {
  std::mt19937 rng(12u);
  std::normal_distribution<double> N(0.0, 1.0);
  StateVector ref = table2_initial();
  StateVector grad;
  const double g0 = glide_slope_constraint(ref, 70 * kDeg, &grad);
  const double bnd = linearized_bound(g0, grad, ref);
  int inside = 0;
  for (int k = 0; k < 2000; ++k) {
    StateVector x = StateVector::Zero();
    x.head<3>() = 800.0 * Eigen::Vector3d(N(rng), N(rng), N(rng));
    if (glide_slope_constraint(x, 70 * kDeg) <= 0.0) {
      ++inside;
      EXPECT_LE(grad.dot(x), bnd + 1e-9);
    }
  }
  EXPECT_GT(inside, 50);
}

TEST(Constraints, LinearizedModelRowsAndErrors) {
  const auto model = std::make_shared<const ProximityModel>(testing::bennu_point_mass());
  const LinearizedProximityModel lin(model);
  EXPECT_EQ(lin.nx(), 12);
  EXPECT_EQ(lin.nu(), 6);
  EXPECT_EQ(lin.n_constraints(), 2);
  Eigen::MatrixXd G(2, 12);
  Eigen::VectorXd h(2);
  const StateVector x = table2_initial();
  lin.constraints(0.0, x, G, h);
  StateVector grad;
  const double g_los = line_of_sight_constraint(x, 80 * kDeg, Eigen::Vector3d::UnitZ(), &grad);
  EXPECT_LE((G.row(1).transpose() - grad).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_NEAR(G.row(1).dot(x) - h(1), g_los, 1e-9);
  EXPECT_NEAR(G.row(0).dot(x) - h(0), glide_slope_constraint(x, 70 * kDeg), 1e-9);
  EXPECT_THROW(glide_slope_constraint(StateVector::Zero(), 70 * kDeg), std::domain_error);
  Eigen::MatrixXd G_bad(3, 12);
  EXPECT_THROW(lin.constraints(0.0, x, G_bad, h), std::invalid_argument);
  Eigen::MatrixXd A(12, 12), B(12, 6);
  Eigen::VectorXd c(12);
  StateVector x_nan = x;
  x_nan(0) = NAN;
  EXPECT_THROW(lin.discretize(0.0, 2.0, x_nan, InputVector::Zero(), A, B, c), std::domain_error);
}

// A cone fixed in the asteroid frame A (apex at a site off the spin axis, axis along its normal) turns
// with the body: at random times the model's constraint equals the definition evaluated in A, and
// the linearised row matches finite differences.
TEST(Constraints, BodyFixedConeFollowsTheRotationAtRandomTimes) {
  ModelParams p;
  p.glide_slope_apex_A = Eigen::Vector3d(180.0, -120.0, 90.0);
  p.glide_slope_axis_A = Eigen::Vector3d(0.8, -0.5, 0.3);
  const auto model = std::make_shared<const ProximityModel>(testing::bennu_point_mass(), p);
  const LinearizedProximityModel lin(model);
  const Eigen::Vector3d a_A = p.glide_slope_axis_A.normalized();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> time(0.0, 20000.0), pos(-600.0, 600.0);
  Eigen::MatrixXd G(2, 12);
  Eigen::VectorXd h(2);
  for (int trial = 0; trial < 50; ++trial) {
    const double t = time(rng);
    StateVector x = table2_initial();
    x.head<3>() = Eigen::Vector3d(pos(rng), pos(rng), pos(rng));
    // Independent evaluation in A: r_A = Rz(-theta) r_L with theta = (spin_rate - n) t.
    const double th = p.spin_angle0 + (p.spin_rate - model->mean_motion()) * t;
    const Eigen::Matrix3d C_AL = Eigen::AngleAxisd(-th, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d d_A = C_AL * x.head<3>() - p.glide_slope_apex_A;
    const double g_def = d_A.norm() * std::cos(p.glide_slope_angle) - d_A.dot(a_A);
    Eigen::Vector3d apex_L, axis_L;
    model->glide_slope_cone_L(t, apex_L, axis_L);
    StateVector grad;
    const double g = glide_slope_constraint(x, p.glide_slope_angle, apex_L, axis_L, &grad);
    EXPECT_NEAR(g, g_def, 1e-9 * (1.0 + std::abs(g_def)));
    lin.constraints(t, x, G, h);
    EXPECT_NEAR(G.row(0).dot(x) - h(0), g, 1e-9 * (1.0 + std::abs(g)));
    for (int i = 0; i < 3; ++i) {  // central differences of g in r_L
      StateVector xp = x, xm = x;
      xp(i) += 1e-4;
      xm(i) -= 1e-4;
      const double fd = (glide_slope_constraint(xp, p.glide_slope_angle, apex_L, axis_L) -
                         glide_slope_constraint(xm, p.glide_slope_angle, apex_L, axis_L)) /
                        2e-4;
      EXPECT_NEAR(G(0, i), fd, 1e-6);
    }
  }
  EXPECT_THROW(glide_slope_constraint(table2_initial(), p.glide_slope_angle, table2_initial().head<3>(), a_A),
               std::domain_error);
}

// The default cone (apex at the centre, axis z_A = z_L) is the paper's cone at every time, bit for bit.
TEST(Constraints, DefaultBodyFixedConeIsThePapersConeExactly) {
  const auto model = std::make_shared<const ProximityModel>(testing::bennu_point_mass());
  for (double t : {0.0, 137.0, 5000.5, 15466.0}) {
    Eigen::Vector3d apex_L, axis_L;
    model->glide_slope_cone_L(t, apex_L, axis_L);
    StateVector g1, g2;
    const StateVector x = table2_initial();
    EXPECT_EQ(glide_slope_constraint(x, 1.2, apex_L, axis_L, &g1), x.head<3>().norm() * std::cos(1.2) - x(2));
    glide_slope_constraint(x, 1.2, &g2);
    EXPECT_EQ((g1 - g2).cwiseAbs().maxCoeff(), 0.0);
  }
}

TEST(Constraints, ConeAxisMustBeNonzero) {
  ModelParams p;
  p.glide_slope_axis_A.setZero();
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p.glide_slope_axis_A = Eigen::Vector3d(0, 0, 1);
  p.glide_slope_apex_A(1) = NAN;
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

}  // namespace
}  // namespace tubempc::dynamics
