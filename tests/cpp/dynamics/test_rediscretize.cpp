// ProximityModel::discretize_rotation and LinearizedProximityModel::rediscretize against the full
// discretisation: the attitude half equals discretize's blocks; the translational blocks are exact
// for any change of v_L, the attitude or the input, and kept within the position tolerance.
#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>

#include "test_fields.hpp"
#include "tubempc/dynamics/linearized_proximity.hpp"

namespace tubempc::dynamics {
namespace {

using testing::cluster;
using testing::fast_frames;

Eigen::VectorXd state() {
  Eigen::VectorXd x(12);
  x << 310.0, -120.0, 240.0, 0.05, -0.02, 0.01, 0.4, -1.1, 0.7, 2e-3, -1e-3, 4e-3;
  return x;
}

Eigen::VectorXd input() {
  Eigen::VectorXd u(6);
  u << 1e-4, -2e-4, 5e-5, 0.02, -0.01, 0.03;
  return u;
}

struct Node {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(12, 12), B = Eigen::MatrixXd::Zero(12, 6);
  Eigen::VectorXd c = Eigen::VectorXd::Zero(12);
};

Node full(const LinearizedProximityModel& lin, double t, const Eigen::VectorXd& x, const Eigen::VectorXd& u) {
  Node n;
  lin.discretize(t, 2.0, x, u, n.A, n.B, n.c);
  return n;
}

double max_abs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

class Rediscretize : public ::testing::TestWithParam<Kinematics> {};

TEST_P(Rediscretize, RotationHalfEqualsDiscretizeBlocks) {
  const ProximityModel model(cluster(), fast_frames(GetParam()));
  const Eigen::VectorXd x = state(), u = input();
  StateMatrix Ad;
  InputMatrix Bd;
  StateVector cd;
  ASSERT_EQ(model.discretize(7.0, 2.0, x, u, Ad, Bd, cd), DiscretizationStatus::Ok);
  Eigen::Matrix<double, 6, 6> Ad_r;
  Eigen::Matrix<double, 6, 3> Bd_r;
  Eigen::Matrix<double, 6, 1> cd_r;
  ASSERT_EQ(model.discretize_rotation(2.0, x.segment<3>(6), x.segment<3>(9), u.tail<3>(), Ad_r, Bd_r, cd_r),
            DiscretizationStatus::Ok);
  EXPECT_LT(max_abs(Ad_r - Ad.bottomRightCorner<6, 6>()), 1e-14);
  EXPECT_LT(max_abs(Bd_r - Bd.bottomRightCorner<6, 3>()), 1e-14 * max_abs(Bd_r));
  EXPECT_LT(max_abs(cd_r - cd.tail<6>()), 1e-14 * max_abs(cd_r));
  // Statuses as discretize.
  const Eigen::Vector3d nan_w(std::nan(""), 0.0, 0.0);
  EXPECT_EQ(model.discretize_rotation(2.0, x.segment<3>(6), nan_w, u.tail<3>(), Ad_r, Bd_r, cd_r),
            DiscretizationStatus::NonFiniteInput);
}

// Same r_L, every other coordinate and the input changed: the translational blocks do not depend on
// them, so the result is the full discretisation at the new point (to rounding).
TEST_P(Rediscretize, ExactWhenPositionIsUnchanged) {
  const auto model = std::make_shared<const ProximityModel>(cluster(), fast_frames(GetParam()));
  const LinearizedProximityModel lin(model, 0.0);
  const Eigen::VectorXd x0 = state(), u0 = input();
  Eigen::VectorXd x1 = x0, u1 = u0;
  x1.segment<3>(3) += Eigen::Vector3d(0.03, -0.01, 0.02);
  x1.segment<3>(6) += Eigen::Vector3d(0.2, -0.1, 0.15);
  x1.segment<3>(9) += Eigen::Vector3d(1e-3, 2e-3, -1e-3);
  u1 += Eigen::VectorXd::Constant(6, 1e-3);
  Node n = full(lin, 7.0, x0, u0);
  const Node before = n;
  EXPECT_TRUE(lin.rediscretize(7.0, 2.0, x0, u0, x1, u1, n.A, n.B, n.c));  // the translation kept
  const Node want = full(lin, 7.0, x1, u1);
  EXPECT_EQ(max_abs(n.A.topRows(6) - before.A.topRows(6)), 0.0);  // translation kept
  EXPECT_LT(max_abs(n.A - want.A), 1e-13);
  EXPECT_LT(max_abs(n.B - want.B), 1e-13 * max_abs(want.B));
  EXPECT_LT(max_abs(n.c - want.c), 1e-12 * max_abs(want.c));
  EXPECT_GT(max_abs(n.A.bottomRows(6) - before.A.bottomRows(6)), 1e-6);  // attitude recomputed
}

// r_L moved within the tolerance: the translational blocks stay those about the old point, within
// the gravity gradient's change over that distance of the exact ones; beyond it, discretize.
TEST_P(Rediscretize, PositionToleranceBoundsTheKeptBlocks) {
  const auto model = std::make_shared<const ProximityModel>(cluster(), fast_frames(GetParam()));
  const LinearizedProximityModel lin(model, 2e-3);
  const Eigen::VectorXd x0 = state(), u0 = input();
  Eigen::VectorXd x_in = x0, x_out = x0;
  x_in.head<3>() += Eigen::Vector3d(1e-3, -1e-3, 5e-4);
  x_out.head<3>() += Eigen::Vector3d(3e-3, 0.0, 0.0);

  Node n = full(lin, 3.0, x0, u0);
  const Node before = n;
  EXPECT_TRUE(lin.rediscretize(3.0, 2.0, x0, u0, x_in, u0, n.A, n.B, n.c));
  const Node want_in = full(lin, 3.0, x_in, u0);
  EXPECT_EQ(max_abs(n.A.topRows(6) - before.A.topRows(6)), 0.0);
  EXPECT_EQ(max_abs(n.c.head(6) - before.c.head(6)), 0.0);
  // Tangent models about points 1e-3 m apart: their slopes differ by ~|grad G| 1e-3 (nonzero, tiny),
  // and at x_in both predict the same state to second order.
  const double dA = max_abs(n.A.topRows(6) - want_in.A.topRows(6));
  EXPECT_GT(dA, 0.0);
  EXPECT_LT(dA, 1e-9);
  const Eigen::VectorXd pred = n.A * x_in + n.B * u0 + n.c,
                        pred_want = want_in.A * x_in + want_in.B * u0 + want_in.c;
  EXPECT_LT(max_abs(pred - pred_want), 1e-13 * max_abs(x_in));  // rounding of ~300 m terms

  n = full(lin, 3.0, x0, u0);
  EXPECT_FALSE(lin.rediscretize(3.0, 2.0, x0, u0, x_out, u0, n.A, n.B, n.c));
  const Node want_out = full(lin, 3.0, x_out, u0);
  EXPECT_EQ(max_abs(n.A - want_out.A), 0.0);
  EXPECT_EQ(max_abs(n.B - want_out.B), 0.0);
  EXPECT_EQ(max_abs(n.c - want_out.c), 0.0);
}

INSTANTIATE_TEST_SUITE_P(BothKinematics, Rediscretize,
                         ::testing::Values(Kinematics::FirstOrder, Kinematics::Exact));

// An extra acceleration may depend on v_L: the translation is then always re-discretised.
class LinearDrag final : public ExtraAcceleration {
 public:
  Eigen::Vector3d acceleration(double, const Eigen::Vector3d&, const Eigen::Vector3d& v_L) const override {
    return -1e-3 * v_L.cwiseAbs().cwiseProduct(v_L);
  }
  void jacobian(double, const Eigen::Vector3d&, const Eigen::Vector3d& v_L, Eigen::Matrix3d& da_dr,
                Eigen::Matrix3d& da_dv) const override {
    da_dr.setZero();
    da_dv = (-2e-3 * v_L.cwiseAbs()).asDiagonal();
  }
};

TEST(Rediscretize, ExtraAccelerationAndCoupledDataUseDiscretize) {
  const auto model = std::make_shared<const ProximityModel>(cluster(), fast_frames(Kinematics::Exact),
                                                            std::make_shared<LinearDrag>());
  const LinearizedProximityModel lin(model);
  const Eigen::VectorXd x0 = state(), u0 = input();
  Eigen::VectorXd x1 = x0;
  x1.segment<3>(3) *= 3.0;
  Node n = full(lin, 1.0, x0, u0);
  EXPECT_FALSE(lin.rediscretize(1.0, 2.0, x0, u0, x1, u0, n.A, n.B, n.c));
  const Node want = full(lin, 1.0, x1, u0);
  EXPECT_EQ(max_abs(n.A - want.A), 0.0);
  EXPECT_EQ(max_abs(n.c - want.c), 0.0);

  // Incoming data with a coupling entry are not the decoupled model's: recomputed in full.
  const LinearizedProximityModel plain(
      std::make_shared<const ProximityModel>(cluster(), fast_frames(Kinematics::Exact)));
  Node m = full(plain, 1.0, x0, u0);
  m.A(0, 9) = 1.0;
  EXPECT_FALSE(plain.rediscretize(1.0, 2.0, x0, u0, x0, u0, m.A, m.B, m.c));
  EXPECT_EQ(max_abs(m.A - full(plain, 1.0, x0, u0).A), 0.0);
}

TEST(Rediscretize, RejectsBadToleranceSizesAndTime) {
  const auto model = std::make_shared<const ProximityModel>(cluster(), fast_frames(Kinematics::FirstOrder));
  for (const double tol : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    try {
      LinearizedProximityModel bad(model, tol);
      ADD_FAILURE() << tol;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("position_tolerance"), std::string::npos);
    }
  }
  const LinearizedProximityModel lin(model);
  Node n = full(lin, 0.0, state(), input());
  const Eigen::VectorXd short_x = Eigen::VectorXd::Zero(11);
  EXPECT_THROW(lin.rediscretize(0.0, 2.0, short_x, input(), state(), input(), n.A, n.B, n.c),
               std::invalid_argument);
  EXPECT_THROW(lin.rediscretize(std::nan(""), 2.0, state(), input(), state(), input(), n.A, n.B, n.c),
               std::domain_error);
}

}  // namespace
}  // namespace tubempc::dynamics
