// Truth propagation: RK4 order, DOPRI5 accuracy, invariants (Jacobi integral, angular momentum),
// unit quaternion, disturbance channels, statuses.
#include <gtest/gtest.h>

#include <cmath>

#include "test_fields.hpp"
#include "tubempc/dynamics/propagator.hpp"

namespace tubempc::dynamics {
namespace {

TruthState initial_state() {
  TruthState s;
  s << 300.0, -150.0, 200.0, 0.02, 0.08, -0.05, 0, 0, 0, 1, 0.05, -0.03, 0.04;
  s.segment<4>(6) = math::exp_map(Eigen::Vector3d(0.4, 2.5, -0.3));
  return s;
}

PropagationResult run(const ProximityModel& m, const TruthState& s, double dt, PropagatorSettings set,
                      const InputVector& u = InputVector::Zero(), const Disturbance& d = {}) {
  return propagate(m, 0.0, s, u, dt, d, set);
}

double state_error(const TruthState& a, const TruthState& b) {
  TruthState d = a - b;
  if ((a.segment<4>(6) + b.segment<4>(6)).norm() < d.segment<4>(6).norm())
    d.segment<4>(6) = a.segment<4>(6) + b.segment<4>(6);
  // position in m, velocity scaled by 100 s, quaternion and rate by 1 and 100 s
  d.segment<3>(3) *= 100.0;
  d.segment<3>(10) *= 100.0;
  return d.norm();
}

TEST(Propagator, Rk4IsFourthOrder) {
  const ProximityModel model(testing::cluster(), testing::fast_frames(Kinematics::FirstOrder));
  const TruthState s0 = initial_state();
  InputVector u;
  u << 1e-4, -2e-4, 5e-5, 0.3, -0.2, 0.1;
  PropagatorSettings ref;
  ref.method = Integrator::DOPRI5;
  ref.rtol = 1e-13;
  ref.atol = 1e-15;
  const TruthState exact = run(model, s0, 40.0, ref, u).state;
  double prev = 0.0;
  for (int sub : {8, 16, 32}) {
    PropagatorSettings set;
    set.substeps = sub;
    const PropagationResult r = run(model, s0, 40.0, set, u);
    ASSERT_EQ(r.status, PropagationStatus::Success);
    EXPECT_EQ(r.steps, sub);
    EXPECT_EQ(r.evaluations, 4 * sub);
    const double err = state_error(r.state, exact);
    if (prev > 0.0) {
      EXPECT_GT(prev / err, 14.0) << sub;
      EXPECT_LT(prev / err, 18.0) << sub;
    }
    prev = err;
  }
}

TEST(Propagator, Dopri5MeetsItsToleranceAgainstFineRk4) {
  const ProximityModel model(testing::cluster(), testing::fast_frames(Kinematics::FirstOrder));
  const TruthState s0 = initial_state();
  PropagatorSettings fine;
  fine.substeps = 4000;
  const TruthState exact = run(model, s0, 40.0, fine).state;
  for (double tol : {1e-6, 1e-8, 1e-10}) {
    PropagatorSettings set;
    set.method = Integrator::DOPRI5;
    set.rtol = tol;
    set.atol = tol;
    const PropagationResult r = run(model, s0, 40.0, set);
    ASSERT_EQ(r.status, PropagationStatus::Success);
    EXPECT_DOUBLE_EQ(r.t, 40.0);
    const TruthState diff = r.state - exact;
    for (int i = 0; i < kNtruth; ++i) {
      EXPECT_LE(std::abs(diff(i)), 10.0 * (tol + tol * std::abs(exact(i)))) << "tol " << tol << " i " << i;
    }
    EXPECT_NEAR(r.state.segment<4>(6).norm(), 1.0, 1e-15);
  }
}

// C = 1/2 |v|^2 - n^2/2 (3 x^2 - z^2) - GM/|r| is conserved in L for a point mass without SRP or
// control: dC/dt = v.(-2n z x v) = 0 (the asteroid's rotation does not change a spherical field).
double jacobi(const TruthState& s, double n, double gm) {
  const Eigen::Vector3d r = s.head<3>();
  return 0.5 * s.segment<3>(3).squaredNorm() - 0.5 * n * n * (3 * r.x() * r.x() - r.z() * r.z()) -
         gm / r.norm();
}

TEST(Propagator, JacobiIntegralConservedOver600s) {
  ModelParams p;
  p.srp_enabled = false;
  p.orbit_radius = 2e9;  // n ~ 1.3e-4 rad/s: Hill terms comparable to gravity at ~300 m
  const double gm = 5.236;
  const ProximityModel model(std::make_shared<gravity::PointMassGravity>(gm), p);
  const double n = model.mean_motion();
  TruthState s0 = initial_state();
  s0.segment<3>(3) << 0.05, 0.09, -0.04;
  for (Integrator method : {Integrator::RK4, Integrator::DOPRI5}) {
    PropagatorSettings set;
    set.method = method;
    set.substeps = 20;
    set.rtol = 1e-13;
    set.atol = 1e-14;
    TruthState s = s0;
    const double c0 = jacobi(s0, n, gm);
    for (int k = 0; k < 300; ++k) {
      const PropagationResult r = propagate(model, 2.0 * k, s, InputVector::Zero(), 2.0, {}, set);
      ASSERT_EQ(r.status, PropagationStatus::Success);
      s = r.state;
    }
    EXPECT_GT((s.head<3>() - s0.head<3>()).norm(), 30.0);  // the orbit did move
    EXPECT_LE(std::abs(jacobi(s, n, gm) - c0), 1e-10 * std::abs(c0)) << to_string(method);
    EXPECT_NEAR(s.segment<4>(6).norm(), 1.0, 1e-15);
  }
}

TEST(Propagator, TorqueFreeMotionConservesInertialAngularMomentum) {
  // H_I = C_IL C_LB J (w + w_LI), C_IL = Rz(n t): constant for zero torque, with L inertial
  // (mu_sun = 0) and with L rotating fast (n ~ 0.03 rad/s).
  for (double mu_sun : {0.0, 1.32712440018e20}) {
    ModelParams p;
    p.mu_sun = mu_sun;
    p.orbit_radius = 5e7;
    p.inertia_B = Eigen::Vector3d(2000.0, 2750.0, 3500.0).asDiagonal();
    const ProximityModel model(testing::bennu_point_mass(), p);
    const double n = model.mean_motion();
    auto H_I = [&](const TruthState& s, double t) {
      const Eigen::Matrix3d C_LB = math::rotation_matrix(s.segment<4>(6));
      const Eigen::Vector3d w_BI = s.segment<3>(10) + n * C_LB.transpose().col(2);
      const Eigen::Matrix3d C_IL = math::rotation_matrix(math::exp_map(Eigen::Vector3d(0, 0, n * t)));
      return (C_IL * C_LB * p.inertia_B * w_BI).eval();
    };
    TruthState s = initial_state();
    s.segment<3>(10) << 0.05, 0.1, -0.03;
    const Eigen::Vector3d H0 = H_I(s, 0.0);
    PropagatorSettings set;
    set.method = Integrator::DOPRI5;
    set.rtol = 1e-13;
    set.atol = 1e-15;
    for (int k = 0; k < 300; ++k) s = propagate(model, 2.0 * k, s, InputVector::Zero(), 2.0, {}, set).state;
    EXPECT_LE((H_I(s, 600.0) - H0).norm(), 1e-10 * H0.norm()) << "n = " << n;
    EXPECT_NEAR(s.segment<4>(6).norm(), 1.0, 1e-15);
  }
}

TEST(Propagator, DisturbanceChannelsActLikeInputs) {
  const ProximityModel model(testing::cluster(), testing::fast_frames(Kinematics::FirstOrder));
  const TruthState s0 = initial_state();
  const Eigen::Vector3d a(1e-4, -3e-4, 2e-4);
  const Eigen::Vector3d alpha(1e-4, 2e-4, -1e-4);
  InputVector u;
  u.head<3>() = a;
  u.tail<3>() = model.params().inertia_B * alpha;  // torque giving angular acceleration alpha
  Disturbance d;
  d.constant.head<3>() = a;
  d.constant.tail<3>() = alpha;
  for (Integrator m : {Integrator::RK4, Integrator::DOPRI5}) {
    PropagatorSettings set;
    set.method = m;
    const TruthState by_input = run(model, s0, 10.0, set, u).state;
    const TruthState by_dist = run(model, s0, 10.0, set, InputVector::Zero(), d).state;
    Disturbance fn;
    fn.function = [&](double, const TruthState&) { return d.constant; };
    const TruthState by_fn = run(model, s0, 10.0, set, InputVector::Zero(), fn).state;
    EXPECT_LE((by_input - by_dist).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LE((by_fn - by_dist).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_GT((by_dist - run(model, s0, 10.0, set).state).cwiseAbs().maxCoeff(), 1e-3);
  }
}

TEST(Propagator, StatusesAndErrors) {
  const ProximityModel model(testing::cluster(), testing::fast_frames(Kinematics::FirstOrder));
  const TruthState s0 = initial_state();
  PropagatorSettings set;
  set.method = Integrator::DOPRI5;
  set.max_steps = 3;
  set.rtol = 1e-12;
  set.atol = 1e-12;
  const PropagationResult r = run(model, s0, 100.0, set);
  EXPECT_EQ(r.status, PropagationStatus::MaxStepsReached);
  EXPECT_LT(r.t, 100.0);
  EXPECT_TRUE(r.state.allFinite());

  TruthState bad = s0;
  bad(2) = NAN;
  EXPECT_EQ(run(model, bad, 2.0, PropagatorSettings{}).status, PropagationStatus::NonFinite);
  Disturbance nan_fn;
  nan_fn.function = [](double t, const TruthState&) { return Disturbance6::Constant(t > 1.0 ? NAN : 0.0); };
  for (Integrator m : {Integrator::RK4, Integrator::DOPRI5}) {
    PropagatorSettings s2;
    s2.method = m;
    const PropagationResult rn = run(model, s0, 2.0, s2, InputVector::Zero(), nan_fn);
    EXPECT_EQ(rn.status, PropagationStatus::NonFinite) << to_string(m);
    EXPECT_TRUE(rn.state.allFinite());
  }

  PropagatorSettings s3;
  s3.substeps = 0;
  EXPECT_THROW(run(model, s0, 2.0, s3), std::invalid_argument);
  s3 = PropagatorSettings{};
  s3.rtol = -1.0;
  EXPECT_THROW(run(model, s0, 2.0, s3), std::invalid_argument);
  TruthState q_bad = s0;
  q_bad.segment<4>(6) *= 2.0;
  EXPECT_THROW(run(model, q_bad, 2.0, PropagatorSettings{}), std::invalid_argument);
  EXPECT_THROW(run(model, s0, -1.0, PropagatorSettings{}), std::invalid_argument);
  PropagatorSettings s4;
  s4.gravity_expansion_tolerance = -1e-9;
  EXPECT_THROW(run(model, s0, 2.0, s4), std::invalid_argument);
  s4.gravity_expansion_tolerance = 1e-9;
  gravity::ExpansionHold other(0.0, 1e-8);  // a hold of another tolerance
  EXPECT_THROW(propagate(model, 0.0, s0, InputVector::Zero(), 2.0, {}, s4, &other), std::invalid_argument);
  // the held gravity at a point mass's singular point: a status (the hold cannot evaluate it), not an exception
  const ProximityModel point_mass(testing::bennu_point_mass(), ModelParams{});
  TruthState at_centre = s0;
  at_centre.head<3>().setZero();
  const PropagationResult r_centre = propagate(point_mass, 0.0, at_centre, InputVector::Zero(), 2.0, {}, s4);
  EXPECT_EQ(r_centre.status, PropagationStatus::NonFinite);
  EXPECT_TRUE(r_centre.state.allFinite());
}

TEST(Propagator, HeldGravityStaysNearTheExactFieldsTrajectoryWithFewerEvaluations) {
  // A 300 s descent at 5 cm/s in 2 s calls, the run's hold carried from call to call: the trajectory against the exact
  // field's, and the field's evaluations against the integrator's.
  const auto field = testing::cluster();
  const ProximityModel model(field, ModelParams{});
  TruthState s0;
  s0 << 260.0, -40.0, 90.0, -0.05, 0.01, -0.02, 0, 0, 0, 1, 1e-3, -2e-3, 5e-4;
  InputVector u;
  u << 2e-4, -1e-4, 3e-4, 0.01, -0.02, 0.005;
  PropagatorSettings exact;
  exact.substeps = 2;
  PropagatorSettings held = exact;
  held.gravity_expansion_tolerance = 1e-10;
  gravity::ExpansionHold hold(0.0, held.gravity_expansion_tolerance);
  TruthState a = s0, b = s0, c = s0;
  int evaluations = 0;
  for (int k = 0; k < 150; ++k) {
    a = propagate(model, 2.0 * k, a, u, 2.0, {}, exact).state;
    const PropagationResult r = propagate(model, 2.0 * k, b, u, 2.0, {}, held, &hold);
    ASSERT_EQ(r.status, PropagationStatus::Success);
    b = r.state;
    evaluations += r.evaluations;
    c = propagate(model, 2.0 * k, c, u, 2.0, {}, held).state;  // a hold of each call alone
  }
  // |a| <= tol over T = 300 s moves the position by at most tol T^2 / 2 = 4.5e-6 m
  EXPECT_LT((a.head<3>() - b.head<3>()).norm(), 4.5e-6);
  EXPECT_LT((a.segment<3>(3) - b.segment<3>(3)).norm(), 1e-10 * 300.0);
  EXPECT_LT((a.head<3>() - c.head<3>()).norm(), 4.5e-6);
  EXPECT_GT((a.head<3>() - b.head<3>()).norm(), 0.0);  // the hold was used
  EXPECT_EQ(evaluations, 150 * 8);
  EXPECT_LT(hold.evaluations(), evaluations / 4);
  EXPECT_LT(hold.largest_error(), 2.0 * held.gravity_expansion_tolerance);
}

}  // namespace
}  // namespace tubempc::dynamics
