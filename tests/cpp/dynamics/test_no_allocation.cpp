// The MPC calls the discretisation and the constraint linearisation inside its allocation-free
// step: count global operator new calls around them.
#include <gtest/gtest.h>

#include "test_fields.hpp"
#include "tubempc/dynamics/linearized_proximity.hpp"
#include "tubempc/dynamics/physical_environment.hpp"
#include "tubempc_testing/allocation_counter.hpp"

namespace {
// Allocations (counted from the start of the test binary; the tests compare before and after).
long allocations() { return tubempc_testing::AllocationCounter::count; }
struct CountFromStart {
  CountFromStart() { tubempc_testing::AllocationCounter::counting = true; }
} count_from_start;
}  // namespace

namespace tubempc::dynamics {
namespace {

TEST(NoAllocation, DiscretizeConstraintsAndHorizon) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "counting needs glibc, no sanitizer";
  ModelParams p;
  p.kinematics = Kinematics::Exact;
  const auto model = std::make_shared<const ProximityModel>(testing::cluster(), p);
  const LinearizedProximityModel lin(model);
  const int N = 30;
  DiscreteHorizon horizon(N);
  Eigen::Matrix<double, kNx, Eigen::Dynamic> X(kNx, N);
  Eigen::Matrix<double, kNu, Eigen::Dynamic> U(kNu, N);
  for (int k = 0; k < N; ++k) {
    X.col(k) << 959.0 - 30.0 * k, 162.0, 752.0, 0.0, 0.08, -0.02, 0.31, 2.9, 0.31, 1e-3, 0.0, 3e-3;
    U.col(k) << 1e-4, 0.0, -1e-4, 0.01, 0.0, 0.02;
  }
  Eigen::MatrixXd A(12, 12);
  Eigen::MatrixXd B(12, 6);
  Eigen::VectorXd c(12);
  Eigen::MatrixXd G(2, 12);
  Eigen::VectorXd h(2);
  const Eigen::VectorXd x = X.col(0);
  const Eigen::VectorXd u = U.col(0);

  Eigen::VectorXd x_attitude = x;
  x_attitude(6) += 0.01;
  Eigen::VectorXd x_moved = x;
  x_moved(0) += 1.0;

  const long before = allocations();
  lin.discretize(10.0, 2.0, x, u, A, B, c);
  lin.rediscretize(10.0, 2.0, x, u, x_attitude, u, A, B, c);        // attitude half only
  lin.rediscretize(10.0, 2.0, x_attitude, u, x_moved, u, A, B, c);  // full
  lin.discretize(10.0, 2.0, x, u, A, B, c);
  lin.constraints(10.0, x, G, h);
  const DiscretizationStatus st = lin.discretize_horizon(0.0, 2.0, X, U, horizon);
  const long after = allocations();
  EXPECT_EQ(after - before, 0);
  EXPECT_EQ(st, DiscretizationStatus::Ok);
  EXPECT_EQ(horizon.first_failed_node, -1);
  // The horizon's node 0 equals the single-node discretisation at t0.
  StateMatrix Ad;
  InputMatrix Bd;
  StateVector cd;
  ASSERT_EQ(model->discretize(0.0, 2.0, X.col(0), U.col(0), Ad, Bd, cd), DiscretizationStatus::Ok);
  EXPECT_EQ((Ad - horizon.A[0]).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((cd - horizon.c[0]).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(allocations(), 0);  // the counter does count (the horizon allocated)
}

TEST(NoAllocation, PhysicalEnvironmentAndItsPropagation) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "counting needs glibc, no sanitizer";
  PhysicalSettings s;
  for (int i = 0; i < 10; ++i) {
    FlatPlate p;
    p.area = 1.0 + i;
    p.normal_B = Eigen::Vector3d(std::cos(i), std::sin(i), 0.3 * i - 1.0);
    p.center_B = Eigen::Vector3d(0.1 * i, -0.2, 0.3);
    p.specular = 0.1;
    p.diffuse = 0.2;
    s.plates.push_back(p);
  }
  const Eigen::Matrix3d J = Eigen::Vector3d(2750.0, 2750.0, 2030.0).asDiagonal();
  const PhysicalEnvironment env(s, J, 5.0, 1.685e11);
  ModelParams p;
  p.srp_enabled = false;
  p.inertia_B = env.inertia_B();
  const ProximityModel truth(testing::cluster(), p);
  TruthState st;
  st << 300.0, -150.0, 200.0, 0.02, 0.08, -0.05, 0, 0, 0, 1, 0.05, -0.03, 0.04;
  st.segment<4>(6) = math::exp_map(Eigen::Vector3d(0.4, 2.5, -0.3));
  InputVector u;
  u << 1e-3, -2e-3, 5e-4, 0.3, -0.2, 0.1;
  PropagatorSettings set;
  set.substeps = 2;
  const long before = allocations();
  const InputVector delivered = env.deliver(u, st.segment<4>(6));
  const Disturbance6 d = env(0.0, st);
  const Eigen::Vector3d a = env.srp_acceleration_L(st);
  const PropagationResult res = propagate(truth, env, 0.0, st, delivered, 2.0, set);
  const long after = allocations();
  EXPECT_EQ(after - before, 0);
  EXPECT_EQ(res.status, PropagationStatus::Success);
  EXPECT_TRUE(d.allFinite() && a.allFinite() && res.state.allFinite());
}

}  // namespace
}  // namespace tubempc::dynamics
