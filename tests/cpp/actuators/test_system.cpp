// The per-period actuation call: delivered impulse against its analytic value, frames, accounting,
// faults and the failed-everything case.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "actuator_fixtures.hpp"
#include "tubempc/actuators/achievable_set.hpp"
#include "tubempc/actuators/system.hpp"

using namespace tubempc::actuators;

namespace {

// Six thrusters at the centre of mass along +-x, +-y, +-z: pure forces, so a force command along +x is
// allocated to thruster 0 alone by the closed-form least squares f = w / (1 + thrust_weight^2).
std::vector<ThrusterSpec> axis_specs(double f_max, double t_min) {
  std::vector<ThrusterSpec> specs;
  for (int k = 0; k < 3; ++k)
    for (double s : {1.0, -1.0}) {
      ThrusterSpec t;
      t.direction_B = s * Eigen::Vector3d::Unit(k);
      t.max_thrust = f_max;
      t.min_on_time = t_min;
      t.isp = 200.0;
      specs.push_back(t);
    }
  return specs;
}

ActuationSettings settings(double dt, double mass, double q) {
  ActuationSettings s;
  s.mass = mass;
  s.modulation.period = dt;
  s.modulation.on_time_resolution = q;
  s.allocation.period = dt;
  return s;
}

}  // namespace

TEST(ActuationSystem, DeliveredImpulseMatchesTheAnalyticPulseTrain) {
  const double F = 2.0, dt = 1.0, q = 1e-3, t_min = 0.02, mass = 10.0, scale = 0.03;
  std::vector<ThrusterSpec> specs = axis_specs(F, t_min);
  specs[0].scale_error_bound = 0.05;
  specs[0].scale_error = scale;
  ActuationSystem sys(ThrusterCluster(specs), ReactionWheels({}), settings(dt, mass, q));
  // u_p along +y of L, with C_BL turning L's y into B's x (a rotation of -90 deg about z).
  Eigen::Matrix3d C_BL;
  C_BL << 0, 1, 0, -1, 0, 0, 0, 0, 1;
  const double a = 0.0377;  // m/s^2: F_x = 0.377 N, below F; the on-time is not a multiple of q
  Vector6 u = Vector6::Zero();
  u(1) = a;
  const double f = mass * a / (1.0 + std::pow(sys.settings().allocation.thrust_weight, 2));
  double r = 0.0, impulse = 0.0;
  for (int k = 0; k < 25; ++k) {
    const ActuationStep& st = sys.step(k * dt, u, C_BL);
    // M34 by hand: the on-time asked plus the remainder, floored to q, fired if >= the minimum on-time.
    const double total = f * dt / F + r;
    double tau = std::floor(total / q + 1e-9) * q;
    if (tau < t_min) tau = 0.0;
    r = total - tau;
    EXPECT_NEAR(st.on_time(0), tau, 1e-12) << k;
    EXPECT_NEAR(st.impulse(0), (1.0 + scale) * F * tau, 1e-12) << k;
    EXPECT_NEAR(st.u_delivered(1), (1.0 + scale) * F * tau / dt / mass, 1e-12) << k;  // back in L
    EXPECT_NEAR(st.u_delivered(0), 0.0, 1e-15);
    EXPECT_NEAR(st.propellant, (1.0 + scale) * F * tau / (200.0 * kStandardGravity), 1e-15);
    EXPECT_EQ(st.status, AllocationStatus::Ok);
    impulse += (1.0 + scale) * F * tau;
  }
  EXPECT_NEAR(sys.totals().impulse, impulse, 1e-11);
  EXPECT_NEAR(sys.totals().delta_v, impulse / mass, 1e-12);
  // Over the mission the nominal impulse delivered is the commanded one minus F times the last remainder.
  EXPECT_NEAR(impulse / (1.0 + scale), 25 * f * dt - F * sys.modulator().remainder()(0), 1e-10);
  EXPECT_LT(sys.modulator().remainder()(0), t_min);
}

TEST(ActuationSystem, ErrorIsAllocatedMinusDeliveredAndWheelsCarryTheTorque) {
  ThrusterCluster cluster = actuator_test::cube_cluster();
  ReactionWheels wheels = actuator_test::pyramid_wheels();
  ActuationSystem sys(cluster, wheels, settings(2.0, 1500.0, 1e-3));
  Vector6 u;
  u << 1e-3, -2e-3, 5e-4, 0.05, -0.02, 0.1;  // m/s^2, N m: the torque within the wheels' 0.2 N m
  const ActuationStep& st = sys.step(0.0, u, Eigen::Matrix3d::Identity());
  EXPECT_EQ(st.status, AllocationStatus::Ok);
  EXPECT_TRUE(st.error_B.isApprox(st.allocated_B - st.delivered_B));
  EXPECT_LT((st.commanded_B - st.allocated_B).cwiseAbs().maxCoeff(), 1e-4);
  // The wheels' torque is G u_w and their momentum moved by -u_w dt.
  EXPECT_TRUE(st.wheel_momentum.isApprox(-2.0 * st.wheel_torque));
  EXPECT_GT(st.wheel_torque.norm(), 0.0);
  EXPECT_EQ(st.pulses, (st.on_time.array() > 0.0).count());
}

TEST(ActuationSystem, FailedThrusterIsReported) {
  ThrusterCluster cluster = actuator_test::cube_cluster();
  cluster.set_fault(0, FaultKind::FailedOff, 4.0);
  ActuationSystem sys(cluster, actuator_test::pyramid_wheels(), settings(2.0, 100.0, 1e-3));
  Vector6 u = Vector6::Zero();
  u(0) = 0.002;  // 0.2 N along +x: thrusters 0 and 1 (one alone: its 0.1 N m torque goes to the wheels)
  EXPECT_EQ(sys.step(0.0, u, Eigen::Matrix3d::Identity()).status, AllocationStatus::Ok);
  const ActuationStep& st = sys.step(4.0, u, Eigen::Matrix3d::Identity());
  EXPECT_EQ(st.status, AllocationStatus::ThrusterFailed);
  EXPECT_EQ(st.failed_thrusters, 1);
  EXPECT_EQ(st.on_time(0), 0.0);
  EXPECT_EQ(to_string(st.status), "thruster_failed");
}

TEST(ActuationSystem, EverythingFailedGivesStatusesAndNoNaN) {
  ThrusterCluster cluster = actuator_test::cube_cluster();
  for (int j = 0; j < cluster.size(); ++j) cluster.set_fault(j, FaultKind::FailedOff, 0.0);
  ActuationSystem sys(cluster, actuator_test::pyramid_wheels(0.2, 1.0), settings(1.0, 100.0, 1e-3));
  Vector6 u;
  u << 0.5, -0.3, 0.2, 1.0, -1.0, 2.0;
  for (int k = 0; k < 20; ++k) {
    const ActuationStep& st = sys.step(k, u, Eigen::Matrix3d::Identity());
    EXPECT_TRUE(st.u_delivered.allFinite());
    EXPECT_TRUE(st.error_B.allFinite());
    EXPECT_TRUE(st.delivered_B.head<3>().isZero()) << k;
    EXPECT_TRUE(st.status == AllocationStatus::Infeasible || st.status == AllocationStatus::Saturated) << k;
    EXPECT_LE(st.wheel_momentum.cwiseAbs().maxCoeff(), 1.0 + 1e-12);
  }
  EXPECT_EQ(sys.totals().not_delivered, 20);
  EXPECT_EQ(sys.totals().impulse, 0.0);
  // Non-finite command and attitude: InvalidCommand, finite output.
  Vector6 bad = u;
  bad(2) = std::nan("");
  EXPECT_EQ(sys.step(21.0, bad, Eigen::Matrix3d::Identity()).status, AllocationStatus::InvalidCommand);
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
  C(0, 0) = std::nan("");
  const ActuationStep& st = sys.step(22.0, u, C);
  EXPECT_EQ(st.status, AllocationStatus::InvalidCommand);
  EXPECT_TRUE(st.u_delivered.allFinite());
}

TEST(ActuationSystem, SettingsNameTheField) {
  ActuationSettings s = settings(2.0, 0.0, 1e-3);
  EXPECT_THROW(s.validate(), std::invalid_argument);
  s.mass = 1.0;
  s.allocation.period = 1.0;
  try {
    s.validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("allocation.period"), std::string::npos);
  }
}

TEST(DisturbanceWithActuationError, ContainsTheSumAndIsNoLargerThanTheTraceChoice) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  for (int trial = 0; trial < 20; ++trial) {
    Matrix6 L;
    for (int i = 0; i < 36; ++i) L(i) = n(rng) * (i % 6 < 3 ? 1.0 : 0.01);
    const Matrix6 P_W = L * L.transpose() + 1e-8 * Matrix6::Identity();
    Eigen::Matrix<double, 6, 3> B;
    for (int i = 0; i < 18; ++i) B(i) = n(rng);
    Eigen::Matrix3d M;
    for (int i = 0; i < 9; ++i) M(i) = 1e-2 * n(rng);
    const Eigen::Matrix3d E = M * M.transpose();
    const Matrix6 P = disturbance_with_actuation_error(P_W, B, E);
    // w + B e on the boundaries of both sets lies in the result.
    const Eigen::LLT<Matrix6> W_factor(P_W);
    const Eigen::LLT<Eigen::Matrix3d> E_factor(E);
    for (int s = 0; s < 200; ++s) {
      Eigen::Matrix<double, 6, 1> a;
      Eigen::Vector3d b;
      for (int i = 0; i < 6; ++i) a(i) = n(rng);
      for (int i = 0; i < 3; ++i) b(i) = n(rng);
      const Eigen::Matrix<double, 6, 1> w = W_factor.matrixL() * a.normalized();
      const Eigen::Vector3d e = E_factor.matrixL() * b.normalized();
      const Eigen::Matrix<double, 6, 1> sum = w + B * e;
      EXPECT_LE(sum.dot(P.llt().solve(sum)), 1.0 + 1e-9);
    }
    // No larger in volume than the trace-minimal member in diag(P_W) units (the search's start).
    const Matrix6 P_E = B * E * B.transpose();
    double b2 = 0.0;
    for (int i = 0; i < 6; ++i) b2 += P_E(i, i) / P_W(i, i);
    const double beta = std::sqrt(b2) / (std::sqrt(6.0) + std::sqrt(b2));
    const Matrix6 P0 = P_W / (1.0 - beta) + P_E / beta;
    EXPECT_LE(std::log(P.determinant()), std::log(P0.determinant()) + 1e-9);
  }
  EXPECT_EQ(disturbance_with_actuation_error(Eigen::Matrix<double, 6, 6>::Identity(),
                                             Eigen::Matrix<double, 6, 3>::Ones(), Eigen::Matrix3d::Zero()),
            (Eigen::Matrix<double, 6, 6>::Identity()));
}

// No exception escapes the actuation step (noexcept) on bad numbers: every component of the command and of
// the attitude NaN, +-inf or huge gives a status and a finite delivered input.
TEST(ActuationSystem, NoExceptionEscapesAStepOnBadNumbers) {
  // the call itself, its arguments already bound (their conversions are not the step's)
  static_assert(noexcept(std::declval<ActuationSystem&>().step(0.0, std::declval<const Vector6&>(),
                                                               std::declval<const Eigen::Matrix3d&>())));
  ActuationSystem sys(actuator_test::cube_cluster(), actuator_test::pyramid_wheels(0.2, 1.0),
                      settings(1.0, 100.0, 1e-3));
  const double bad[] = {std::nan(""), HUGE_VAL, -HUGE_VAL, 1e300};
  double t = 0.0;
  for (const double v : bad) {
    for (int i = 0; i < 6; ++i) {
      Vector6 u = Vector6::Constant(0.1);
      u(i) = v;
      const ActuationStep& st = sys.step(t++, u, Eigen::Matrix3d::Identity());
      EXPECT_TRUE(st.u_delivered.allFinite()) << i << " " << v;
      if (!std::isfinite(v)) EXPECT_EQ(st.status, AllocationStatus::InvalidCommand) << i;
    }
    for (int i = 0; i < 9; ++i) {
      Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
      C(i / 3, i % 3) = v;
      const ActuationStep& st = sys.step(t++, Vector6::Constant(0.1), C);
      EXPECT_TRUE(st.u_delivered.allFinite()) << i << " " << v;
      EXPECT_TRUE(st.wheel_momentum.allFinite()) << i << " " << v;
    }
  }
  EXPECT_TRUE(sys.step(t, Vector6::Constant(0.1), Eigen::Matrix3d::Identity()).u_delivered.allFinite());
}

TEST(ActuationSystem, AFailedWheelIsReportedAndTheOthersCarryTheTorque) {
  ReactionWheels wheels = actuator_test::pyramid_wheels();
  wheels.set_failure(2, 4.0);
  ActuationSystem sys(actuator_test::cube_cluster(), wheels, settings(2.0, 1500.0, 1e-3));
  Vector6 u = Vector6::Zero();
  u.tail<3>() << 0.05, -0.02, 0.1;  // N m: within the three remaining wheels' reach
  EXPECT_EQ(sys.step(0.0, u, Eigen::Matrix3d::Identity()).failed_wheels, 0);
  const ActuationStep& st = sys.step(4.0, u, Eigen::Matrix3d::Identity());
  EXPECT_EQ(st.failed_wheels, 1);
  EXPECT_EQ(st.wheel_torque(2), 0.0);
  EXPECT_EQ(st.status, AllocationStatus::Ok);  // re-allocated around the failed wheel
  EXPECT_LT((st.commanded_B - st.allocated_B).cwiseAbs().maxCoeff(), 1e-4);
}
