// The navigation filter: measurement Jacobians against finite differences, the noise-free prediction
// against the truth propagator, NEES and NIS inside their 95 % chi-square bounds over a Monte Carlo set
// (and outside them for a filter told the wrong pixel noise), broken sensors and bad calls.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "nav_fixtures.hpp"

using namespace tubempc;

namespace {

nav::NavState perturbed(const nav::NavState& x, const nav::NavErrorVector& dx) {
  nav::NavState y = x;
  y.r_L += dx.segment<3>(0);
  y.v_L += dx.segment<3>(3);
  y.q_BL = math::quat_mul(x.q_BL, math::exp_map(dx.segment<3>(6)));
  y.gyro_bias_B += dx.segment<3>(9);
  y.accel_bias_B += dx.segment<3>(12);
  return y;
}

nav::NavState start_state() {
  nav::NavState x;
  x.t = 12.0;
  x.r_L = Eigen::Vector3d(-420.0, 40.0, 60.0);
  x.v_L = Eigen::Vector3d(0.02, -0.03, 0.01);
  x.q_BL = nav_test::nadir_attitude(x.r_L);
  return x;
}

// A frame's landmarks linearised at the filter's estimate (predict_pixel), folded in by two independent
// references with dense matrices over all the frame's rows: the stacked Kalman update (S = H P H^T + R,
// 2n x 2n, Joseph form) and the sequential one (2-D updates of that linear model one landmark at a
// time, each residual taken at the updated error). Both end with the filter's injection and reset.
struct Folded {
  nav::NavState x;
  nav::NavCovariance P;
  double nis{0.0};
};

nav::NavState injected(nav::NavState x, const nav::NavErrorVector& dx) {
  x.r_L += dx.segment<3>(0);
  x.v_L += dx.segment<3>(3);
  x.q_BL = math::quat_normalize(math::quat_mul(x.q_BL, math::exp_map(dx.segment<3>(6))));
  x.gyro_bias_B += dx.segment<3>(9);
  x.accel_bias_B += dx.segment<3>(12);
  return x;
}

nav::NavCovariance attitude_reset(const Eigen::MatrixXd& P, const nav::NavErrorVector& dx) {
  Eigen::MatrixXd G = Eigen::MatrixXd::Identity(15, 15);
  G.block<3, 3>(6, 6) -= 0.5 * math::skew(dx.segment<3>(6));
  return G * P * G.transpose();
}

void linearised_frame(const nav::NavigationFilter& f, const nav::CameraFrame& frame,
                      const std::vector<int>& use, Eigen::MatrixXd& H, Eigen::VectorXd& y) {
  const int m = 2 * static_cast<int>(use.size());
  H.resize(m, 15);
  y.resize(m);
  for (int k = 0; k < static_cast<int>(use.size()); ++k) {
    const nav::LandmarkObservation& o = frame.observations[static_cast<std::size_t>(use[k])];
    Eigen::Vector2d p;
    Eigen::Matrix<double, 2, 15> Hk;
    EXPECT_TRUE(f.predict_pixel(o.landmark, p, &Hk));
    H.middleRows(2 * k, 2) = Hk;
    y.segment(2 * k, 2) = o.pixel - f.settings().camera.pixel_bias - p;
  }
}

Folded stacked_update(const nav::NavigationFilter& f, const nav::CameraFrame& frame,
                      const std::vector<int>& use) {
  Eigen::MatrixXd H;
  Eigen::VectorXd y;
  linearised_frame(f, frame, use, H, y);
  const double var = std::pow(f.settings().camera.pixel_sigma, 2);
  const Eigen::MatrixXd R = var * Eigen::MatrixXd::Identity(H.rows(), H.rows());
  const Eigen::MatrixXd P = f.covariance();
  const Eigen::MatrixXd S = H * P * H.transpose() + R;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
  const Eigen::MatrixXd K = ldlt.solve(H * P).transpose();
  const Eigen::MatrixXd A = Eigen::MatrixXd::Identity(15, 15) - K * H;
  const nav::NavErrorVector dx = K * y;
  Folded out;
  out.nis = y.dot(ldlt.solve(y));
  out.x = injected(f.state(), dx);
  out.P = attitude_reset(A * P * A.transpose() + K * R * K.transpose(), dx);
  return out;
}

Folded sequential_update(const nav::NavigationFilter& f, const nav::CameraFrame& frame,
                         const std::vector<int>& use) {
  Eigen::MatrixXd H;
  Eigen::VectorXd y;
  linearised_frame(f, frame, use, H, y);
  const Eigen::Matrix2d R = std::pow(f.settings().camera.pixel_sigma, 2) * Eigen::Matrix2d::Identity();
  Eigen::MatrixXd P = f.covariance();
  Eigen::VectorXd dx = Eigen::VectorXd::Zero(15);
  Folded out;
  for (int k = 0; k < static_cast<int>(use.size()); ++k) {
    const Eigen::MatrixXd Hk = H.middleRows(2 * k, 2);
    const Eigen::Vector2d yk = y.segment(2 * k, 2) - Hk * dx;
    const Eigen::Matrix2d S = Hk * P * Hk.transpose() + R;
    const Eigen::MatrixXd K = P * Hk.transpose() * S.inverse();
    const Eigen::MatrixXd A = Eigen::MatrixXd::Identity(15, 15) - K * Hk;
    out.nis += yk.dot(S.inverse() * yk);
    dx += K * yk;
    P = A * P * A.transpose() + K * R * K.transpose();
  }
  out.x = injected(f.state(), dx);
  out.P = attitude_reset(P, dx);
  return out;
}

// Largest difference of two covariances relative to the first's sigmas (sigma_i sigma_j).
double covariance_difference(const nav::NavCovariance& P, const nav::NavCovariance& Q) {
  const nav::NavErrorVector s = P.diagonal().cwiseSqrt();
  return (P - Q).cwiseQuotient(s * s.transpose()).cwiseAbs().maxCoeff();
}

// Largest difference of two estimates relative to the sigmas of P.
double state_difference(const nav::NavState& a, const nav::NavState& b, const nav::NavCovariance& P) {
  return nav::nav_error(a, b).cwiseQuotient(P.diagonal().cwiseSqrt()).cwiseAbs().maxCoeff();
}

}  // namespace

TEST(NavigationFilter, MeasurementJacobiansMatchFiniteDifferences) {
  const nav_test::World w = nav_test::make_world();
  nav::FilterSettings fs;
  nav::NavigationFilter f(w.model, w.caster, w.landmarks, fs), g(w.model, w.caster, w.landmarks, fs);
  const nav::NavState x = start_state();
  ASSERT_EQ(f.initialize(x, nav::NavCovariance::Identity()), nav::FilterStatus::Ok);
  double range = 0.0;
  Eigen::Matrix<double, 1, 15> Hr;
  ASSERT_TRUE(f.predict_range(range, &Hr));
  int checked = 0;
  for (int i = 0; i < static_cast<int>(w.landmarks.size()) && checked < 5; ++i) {
    Eigen::Vector2d p;
    Eigen::Matrix<double, 2, 15> H;
    if (!f.predict_pixel(i, p, &H) || (p.array() < 0.0).any() || (p.array() > 1024.0).any()) continue;
    ++checked;
    for (int j = 0; j < 15; ++j) {
      const double h = j < 3 ? 1e-3 : 1e-6;
      nav::NavErrorVector dx = nav::NavErrorVector::Zero();
      dx(j) = h;
      Eigen::Vector2d pp, pm;
      g.initialize(perturbed(x, dx), nav::NavCovariance::Identity());
      ASSERT_TRUE(g.predict_pixel(i, pp));
      g.initialize(perturbed(x, -dx), nav::NavCovariance::Identity());
      ASSERT_TRUE(g.predict_pixel(i, pm));
      const Eigen::Vector2d fd = (pp - pm) / (2.0 * h);
      EXPECT_NEAR(H(0, j), fd(0), 1e-5 * (1.0 + std::abs(fd(0)))) << "landmark " << i << " column " << j;
      EXPECT_NEAR(H(1, j), fd(1), 1e-5 * (1.0 + std::abs(fd(1)))) << "landmark " << i << " column " << j;
    }
  }
  EXPECT_EQ(checked, 5);
  for (int j = 0; j < 15; ++j) {
    const double h = j < 3 ? 1e-4 : 1e-7;  // small: the beam stays on one face
    nav::NavErrorVector dx = nav::NavErrorVector::Zero();
    dx(j) = h;
    double rp = 0.0, rm = 0.0;
    g.initialize(perturbed(x, dx), nav::NavCovariance::Identity());
    ASSERT_TRUE(g.predict_range(rp));
    g.initialize(perturbed(x, -dx), nav::NavCovariance::Identity());
    ASSERT_TRUE(g.predict_range(rm));
    EXPECT_NEAR(Hr(0, j), (rp - rm) / (2.0 * h), 1e-5 * (1.0 + std::abs(Hr(0, j)))) << "column " << j;
  }
}

TEST(NavigationFilter, CameraFrameIsTheStackedKalmanUpdate) {
  // A frame of landmarks (18 here) seen from a truth 3 m and 1 mrad away from the estimate: the filter's
  // one update per frame (from the landmarks' information on [dr, dtheta]) against the stacked Kalman
  // update over all the frame's rows and the sequential one, for the measurements linearised at the
  // estimate (for a linear model the three are the same); then a gated landmark.
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.camera.max_landmarks = nav::kMaxLandmarksPerFrame;
  rs.camera.max_range = 2000.0;
  nav::FilterSettings fs;
  fs.camera = rs.camera;
  const nav::NavState x = start_state();
  nav::NavCovariance P0 = nav::NavCovariance::Zero();
  P0.diagonal() = rs.sigma0.cwiseAbs2();
  P0(0, 7) = P0(7, 0) = 0.5 * rs.sigma0(0) * rs.sigma0(7);  // a position-attitude correlation
  nav::NavErrorVector dx_true = nav::NavErrorVector::Zero();
  dx_true << 3.0, -2.0, 1.0, 0.01, 0.0, 0.0, 1e-3, -5e-4, 2e-4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  dynamics::TruthState s;
  const nav::NavState truth = perturbed(x, dx_true);
  s << truth.r_L, truth.v_L, truth.q_BL, Eigen::Vector3d::Zero();
  nav::NavCamera camera(w.caster, w.landmarks, rs.camera, 5);
  nav::CameraFrame frame;
  camera.measure(nav_test::sensor_truth(*w.model, x.t, s), frame);
  ASSERT_EQ(frame.status, nav::SensorStatus::Ok);
  ASSERT_GE(frame.count, 12);
  std::vector<int> all(static_cast<std::size_t>(frame.count));
  for (int i = 0; i < frame.count; ++i) all[static_cast<std::size_t>(i)] = i;

  nav::NavigationFilter f(w.model, w.caster, w.landmarks, fs);
  ASSERT_EQ(f.initialize(x, P0), nav::FilterStatus::Ok);
  const Folded stacked = stacked_update(f, frame, all);
  const Folded sequential = sequential_update(f, frame, all);
  const nav::UpdateResult r = f.update_camera(frame);
  ASSERT_EQ(r.status, nav::FilterStatus::Ok);
  EXPECT_EQ(r.accepted, frame.count);
  EXPECT_EQ(r.rejected, 0);
  EXPECT_EQ(r.dof, 2 * frame.count);
  std::printf(
      "%d landmarks: filter - stacked: estimate %.3g sigma, covariance %.3g; stacked - sequential: "
      "%.3g, %.3g; NIS %.6g %.6g %.6g\n",
      frame.count, state_difference(stacked.x, f.state(), stacked.P),
      covariance_difference(stacked.P, f.covariance()), state_difference(stacked.x, sequential.x, stacked.P),
      covariance_difference(stacked.P, sequential.P), r.nis, stacked.nis, sequential.nis);
  EXPECT_LT(state_difference(stacked.x, sequential.x, stacked.P), 1e-9);
  EXPECT_LT(covariance_difference(stacked.P, sequential.P), 1e-8);
  EXPECT_NEAR(stacked.nis, sequential.nis, 1e-8 * stacked.nis);
  EXPECT_LT(state_difference(stacked.x, f.state(), stacked.P), 1e-9);
  EXPECT_LT(covariance_difference(stacked.P, f.covariance()), 1e-8);
  EXPECT_NEAR(r.nis, stacked.nis, 1e-8 * stacked.nis);
  EXPECT_GT(state_difference(x, f.state(), stacked.P), 0.5);  // the frame did move the estimate

  // One landmark 150 pixels off: refused by a gate of 25 on its NIS against the frame's prior, and the
  // update is the stacked one of the others.
  nav::CameraFrame bad = frame;
  bad.observations[3].pixel.x() += 150.0;
  fs.innovation_gate = 25.0;
  nav::NavigationFilter g(w.model, w.caster, w.landmarks, fs);
  ASSERT_EQ(g.initialize(x, P0), nav::FilterStatus::Ok);
  std::vector<int> others;
  for (int i = 0; i < frame.count; ++i)
    if (i != 3) others.push_back(i);
  const Folded kept = stacked_update(g, bad, others);
  const nav::UpdateResult rg = g.update_camera(bad);
  ASSERT_EQ(rg.status, nav::FilterStatus::Ok);
  EXPECT_EQ(rg.rejected, 1);
  EXPECT_EQ(rg.accepted, frame.count - 1);
  EXPECT_LT(state_difference(kept.x, g.state(), kept.P), 1e-9);
  EXPECT_LT(covariance_difference(kept.P, g.covariance()), 1e-8);
  EXPECT_NEAR(rg.nis, kept.nis, 1e-8 * kept.nis);
}

TEST(NavigationFilter, NoiseFreePredictionFollowsTheTruth) {
  // Perfect IMU (no noise, no bias): 120 s of prediction against the truth propagator (RK4, DOPRI-grade
  // steps); the gravity is linearised over each 0.1 s sub-step.
  const nav_test::World w = nav_test::make_world();
  nav::ImuSettings imu_s;
  imu_s.gyro_noise_density = imu_s.accel_noise_density = 0.0;
  imu_s.gyro_bias_sigma = imu_s.accel_bias_sigma = 0.0;
  imu_s.gyro_bias_random_walk = imu_s.accel_bias_random_walk = 0.0;
  nav::FilterSettings fs;
  fs.imu = imu_s;
  nav::NavigationFilter f(w.model, w.caster, w.landmarks, fs);
  nav::Imu imu(imu_s, 1);
  nav::NavState x0 = start_state();
  x0.t = 0.0;
  ASSERT_EQ(f.initialize(x0, nav::NavCovariance::Identity() * 1e-6), nav::FilterStatus::Ok);
  dynamics::TruthState s;
  s << x0.r_L, x0.v_L, x0.q_BL, Eigen::Vector3d(0.0, 0.0, 0.0);
  dynamics::PropagatorSettings ps;
  ps.substeps = 4;
  nav::ImuSample sample;
  const double T = 0.1;
  for (int k = 0; k < 1200; ++k) {
    imu.measure(nav_test::sensor_truth(*w.model, k * T, s), sample);
    ASSERT_EQ(f.propagate((k + 1) * T, sample), nav::FilterStatus::Ok);
    s = dynamics::propagate(*w.model, k * T, s, dynamics::InputVector::Zero(), T, {}, ps).state;
  }
  // The truth moved ~40 m and fell under gravity; the prediction stays within millimetres.
  EXPECT_GT((s.segment<3>(0) - x0.r_L).norm(), 3.0);
  EXPECT_LT((f.state().r_L - s.segment<3>(0)).norm(), 1e-3);
  EXPECT_LT((f.state().v_L - s.segment<3>(3)).norm(), 1e-5);
  EXPECT_LT(math::log_map(math::quat_mul(math::quat_conj(f.state().q_BL), s.segment<4>(6))).norm(), 1e-9);
  EXPECT_NEAR(f.state().t, 120.0, 1e-9);
  // The controller's view: r, v, phi, omega.
  const dynamics::StateVector xm = f.model_state(Eigen::Vector3d::Zero());
  EXPECT_TRUE(xm.head<3>().isApprox(f.state().r_L));
  EXPECT_LT(xm.tail<3>().norm(), 1e-12);
  const dynamics::StateMatrix C = f.model_covariance(Eigen::Vector3d::Zero());
  EXPECT_TRUE(C.allFinite());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<dynamics::StateMatrix>(C).eigenvalues().minCoeff(), 0.0);
}

TEST(NavigationFilter, GyroRateIsInterpolatedBetweenSamplesThatBracketTheInterval) {
  // M30: a body turning about a fixed B axis at a constant angular acceleration (the rate a torque held
  // over half a period gives), a perfect gyro sampled every 0.1 s for 10 s. Sampled at each interval's
  // end (as nav::NavigationSystem samples it), the rate interpolated between the last sample and this one
  // integrates the turn exactly; sampled at the interval's start, the sample's rate is held and the
  // attitude lags by the rectangle rule's alpha h / 2 per second.
  const nav_test::World w = nav_test::make_world();
  nav::ImuSettings imu_s;
  imu_s.gyro_noise_density = imu_s.accel_noise_density = 0.0;
  imu_s.gyro_bias_sigma = imu_s.accel_bias_sigma = 0.0;
  imu_s.gyro_bias_random_walk = imu_s.accel_bias_random_walk = 0.0;
  nav::FilterSettings fs;
  fs.imu = imu_s;
  nav::NavState x0 = start_state();
  x0.t = 0.0;
  const Eigen::Vector3d axis_B = Eigen::Vector3d(1.0, 2.0, -2.0) / 3.0;
  const double omega0 = 2e-3, alpha = 1e-3, h = 0.1;  // rad/s, rad/s^2, s
  const auto truth_at = [&](double t) {
    dynamics::TruthState s;
    s << x0.r_L, x0.v_L, math::quat_mul(x0.q_BL, math::exp_map((omega0 * t + 0.5 * alpha * t * t) * axis_B)),
        (omega0 + alpha * t) * axis_B;
    return s;
  };
  for (const bool at_end : {true, false}) {
    nav::NavigationFilter f(w.model, w.caster, w.landmarks, fs);
    ASSERT_EQ(f.initialize(x0, nav::NavCovariance::Identity() * 1e-6), nav::FilterStatus::Ok);
    nav::Imu imu(imu_s, 1);
    nav::ImuSample sample;
    imu.measure(nav_test::sensor_truth(*w.model, 0.0, truth_at(0.0)), sample);
    ASSERT_EQ(f.propagate(0.0, sample), nav::FilterStatus::Ok);  // the rate at the start
    for (int k = 0; k < 100; ++k) {
      const double t_sample = (at_end ? k + 1 : k) * h;
      imu.measure(nav_test::sensor_truth(*w.model, t_sample, truth_at(t_sample)), sample);
      ASSERT_EQ(f.propagate((k + 1) * h, sample), nav::FilterStatus::Ok);
    }
    const dynamics::TruthState s = truth_at(10.0);
    const double error =
        math::log_map(math::quat_mul(math::quat_conj(f.state().q_BL), s.segment<4>(6))).norm();
    if (at_end)
      EXPECT_LT(error, 1e-9) << "the turn interpolated between bracketing samples";
    else
      EXPECT_NEAR(error, alpha * h / 2.0 * 10.0, 1e-3 * alpha * h / 2.0 * 10.0) << "the start's rate held";
  }
}

TEST(NavigationFilter, HeldGravityExpansionMatchesAnEvaluationPerSubStep) {
  // M42: the expansion about the last evaluation point, re-evaluated after 1 m, against an evaluation at
  // every 0.1 s sub-step (gravity_relinearization_distance = 0), over the same 60 s of sensors and
  // updates. The expansion's error (half the third derivative of U times 1 m^2, ~1e-10 m/s^2 here)
  // moves the estimate by far less than its sigma; the evaluations follow the distance flown.
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.v0_L = Eigen::Vector3d(0.2, -0.3, 0.1);  // 22 m in 60 s
  rs.filter.gravity_relinearization_distance = 0.0;
  rs.filter.gravity_expansion_tolerance = 0.0;
  const nav_test::RunResult every = nav_test::run(w, rs, 11);
  rs.filter.gravity_relinearization_distance = 1.0;
  const nav_test::RunResult held = nav_test::run(w, rs, 11);
  EXPECT_EQ(every.gravity_evaluations, 600);
  const double path = 60.0 * rs.v0_L.norm();
  EXPECT_GE(held.gravity_evaluations,
            static_cast<long>(path / 1.0 / 2.0));  // the estimate's path, +- its jumps
  EXPECT_LE(held.gravity_evaluations, static_cast<long>(path / 1.0 * 2.0));
  const nav::NavErrorVector sigma = every.P_final.diagonal().cwiseSqrt();
  const nav::NavErrorVector d = nav::nav_error(every.estimate, held.estimate);
  std::printf("evaluations %ld against %ld; largest |difference| / sigma %.3g; expansion error %.3g m/s^2\n",
              held.gravity_evaluations, every.gravity_evaluations,
              d.cwiseQuotient(sigma).cwiseAbs().maxCoeff(), held.gravity_expansion_error);
  EXPECT_LT(d.cwiseQuotient(sigma).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT((held.P_final - every.P_final).cwiseAbs().maxCoeff(), 1e-6 * every.P_final.diagonal().maxCoeff());
  EXPECT_GT(held.gravity_expansion_error, 0.0);

  // The hold from a tolerance above the 1 m expansion's error: the evaluations fall, the expansion's
  // error found at each re-evaluation stays near the tolerance.
  for (const double tol : {1e-9, 1e-8}) {
    rs.filter.gravity_expansion_tolerance = tol;
    const nav_test::RunResult adaptive = nav_test::run(w, rs, 11);
    const nav::NavErrorVector da = nav::nav_error(every.estimate, adaptive.estimate);
    std::printf(
        "tolerance %.3g m/s^2: evaluations %ld, largest expansion error %.3g m/s^2, |difference| / sigma "
        "%.3g\n",
        tol, adaptive.gravity_evaluations, adaptive.gravity_expansion_error,
        da.cwiseQuotient(sigma).cwiseAbs().maxCoeff());
    EXPECT_LT(adaptive.gravity_evaluations, held.gravity_evaluations);
    EXPECT_LT(adaptive.gravity_expansion_error, 2.0 * tol);
    EXPECT_GT(adaptive.gravity_expansion_error, 0.25 * tol);  // not needlessly short
    EXPECT_LT(da.cwiseQuotient(sigma).cwiseAbs().maxCoeff(), 1e-3);
  }
}

TEST(NavigationFilter, CovarianceOverASpanMatchesOnePerSample) {
  // M30 over spans of covariance_step = 1 s with the span's mean F, against a propagation at every
  // 0.1 s IMU sample (covariance_step = 0), over 60 s of sensors and updates with a turning spacecraft.
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.omega0_BL_B = Eigen::Vector3d(2e-3, -1e-3, 3e-3);
  rs.filter.covariance_step = 0.0;
  const nav_test::RunResult every = nav_test::run(w, rs, 12);
  rs.filter.covariance_step = 1.0;
  const nav_test::RunResult span = nav_test::run(w, rs, 12);
  const nav::NavErrorVector sigma_every = every.P_final.diagonal().cwiseSqrt();
  const nav::NavErrorVector sigma_span = span.P_final.diagonal().cwiseSqrt();
  const double sigma_rel = (sigma_span - sigma_every).cwiseQuotient(sigma_every).cwiseAbs().maxCoeff();
  const nav::NavErrorVector d = nav::nav_error(every.estimate, span.estimate);
  const double est_rel = d.cwiseQuotient(sigma_every).cwiseAbs().maxCoeff();
  std::printf("largest relative sigma difference %.3g; estimate difference / sigma %.3g\n", sigma_rel,
              est_rel);
  EXPECT_LT(sigma_rel, 1e-3);
  EXPECT_LT(est_rel, 1e-2);
  // A longer span without measurements: 2 s of prediction alone, read once, against 20 sub-steps, from
  // the run's initial sigmas. The mean F drops the turn of C_LB within the span (a Magnus commutator
  // term of order omega h): the correlations move by about 1e-8 here.
  nav::FilterSettings fs;
  fs.covariance_step = 0.0;
  nav::NavigationFilter a(w.model, w.caster, w.landmarks, fs);
  fs.covariance_step = 5.0;
  nav::NavigationFilter b(w.model, w.caster, w.landmarks, fs);
  nav::NavState x0 = start_state();
  nav::NavCovariance P0 = nav::NavCovariance::Zero();
  P0.diagonal() = rs.sigma0.cwiseAbs2();
  ASSERT_EQ(a.initialize(x0, P0), nav::FilterStatus::Ok);
  ASSERT_EQ(b.initialize(x0, P0), nav::FilterStatus::Ok);
  nav::ImuSample imu;
  imu.t = x0.t;
  imu.specific_force_B = Eigen::Vector3d(1e-3, -2e-3, 5e-3);
  imu.omega_BI_B = Eigen::Vector3d(2e-3, -1e-3, 3e-3);
  for (int k = 1; k <= 20; ++k) {
    ASSERT_EQ(a.propagate(x0.t + 0.1 * k, imu), nav::FilterStatus::Ok);
    ASSERT_EQ(b.propagate(x0.t + 0.1 * k, imu), nav::FilterStatus::Ok);
  }
  const nav::NavCovariance Pa = a.covariance(), Pb = b.covariance();
  const nav::NavErrorVector sa = Pa.diagonal().cwiseSqrt();
  const nav::NavCovariance corr = (Pa - Pb).cwiseQuotient(sa * sa.transpose());
  std::printf("2 s span: largest correlation difference %.3g\n", corr.cwiseAbs().maxCoeff());
  EXPECT_LT(corr.cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT((Pa - P0).cwiseQuotient(sa * sa.transpose()).cwiseAbs().maxCoeff(), 1e-2);  // it did move
}

TEST(NavigationFilter, NeesAndNisInsideChiSquareBounds) {
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.duration = 40.0;
  // The test body is smooth at the scale of the position error: the filter's noise model is exact
  // without the terrain term (tests/py/test_nav.py flies the Bennu-like body with it).
  rs.filter.altimeter_terrain_sigma = 0.0;
  const int runs = 40;
  double nees = 0.0, nis_cam = 0.0, nis_star = 0.0, nis_alt = 0.0;
  int dof_cam = 0, dof_star = 0, dof_alt = 0, frames = 0, empty = 0;
  for (int r = 0; r < runs; ++r) {
    const nav_test::RunResult out = nav_test::run(w, rs, 100 + r);
    ASSERT_TRUE(out.finite);
    EXPECT_EQ(out.filter_failures, 0);
    nees += out.nees_final;
    nis_cam += out.nis_camera;
    dof_cam += out.dof_camera;
    nis_star += out.nis_star;
    dof_star += out.dof_star;
    nis_alt += out.nis_altimeter;
    dof_alt += out.dof_altimeter;
    frames += out.camera_frames;
    empty += out.camera_empty;
  }
  const double k_nees = 15.0 * runs;
  std::printf("NEES/15 %.3f  NIS/dof: camera %.3f (%d), star tracker %.3f (%d), altimeter %.3f (%d)\n",
              nees / k_nees, nis_cam / dof_cam, dof_cam, nis_star / dof_star, dof_star, nis_alt / dof_alt,
              dof_alt);
  EXPECT_EQ(empty, 0);
  EXPECT_GT(dof_cam, 2 * 8 * frames);  // at least 8 landmarks per frame on average
  const double z = 1.959963984540054;
  EXPECT_GT(nees, nav_test::chi2_quantile(k_nees, -z)) << "average NEES " << nees / runs;
  EXPECT_LT(nees, nav_test::chi2_quantile(k_nees, z)) << "average NEES " << nees / runs;
  EXPECT_GT(nis_cam, nav_test::chi2_quantile(dof_cam, -z)) << "camera NIS per dof " << nis_cam / dof_cam;
  EXPECT_LT(nis_cam, nav_test::chi2_quantile(dof_cam, z)) << "camera NIS per dof " << nis_cam / dof_cam;
  EXPECT_GT(nis_star, nav_test::chi2_quantile(dof_star, -z))
      << "star tracker NIS per dof " << nis_star / dof_star;
  EXPECT_LT(nis_star, nav_test::chi2_quantile(dof_star, z))
      << "star tracker NIS per dof " << nis_star / dof_star;
  EXPECT_GT(nis_alt, nav_test::chi2_quantile(dof_alt, -z)) << "altimeter NIS per dof " << nis_alt / dof_alt;
  EXPECT_LT(nis_alt, nav_test::chi2_quantile(dof_alt, z)) << "altimeter NIS per dof " << nis_alt / dof_alt;
}

TEST(NavigationFilter, WrongPixelNoiseFailsTheConsistencyCheck) {
  // The same check catches a filter that trusts its camera 10 times too much.
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.duration = 20.0;
  rs.keep_filter_sensors = true;
  rs.filter.altimeter = rs.altimeter;
  rs.filter.star_tracker = rs.star_tracker;
  rs.filter.imu = rs.imu;
  rs.filter.camera = rs.camera;
  rs.filter.camera.pixel_sigma = 0.1 * rs.camera.pixel_sigma;
  double nis = 0.0;
  int dof = 0;
  for (int r = 0; r < 4; ++r) {
    const nav_test::RunResult out = nav_test::run(w, rs, 200 + r);
    nis += out.nis_camera;
    dof += out.dof_camera;
  }
  ASSERT_GT(dof, 0);
  EXPECT_GT(nis, nav_test::chi2_quantile(dof, 1.959963984540054));
}

TEST(NavigationFilter, SplitFiltersAreInconsistentWithACoarseStarTracker) {
  // With a star tracker 10 times coarser than the default, the attitude error common to a frame's
  // landmarks matters: the joint filter stays consistent, two separate filters (FilterSettings::split)
  // count the frames as independent information and their NEES leaves the bound.
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.duration = 40.0;
  rs.filter.altimeter_terrain_sigma = 0.0;
  rs.star_tracker.sigma_B *= 10.0;
  const int runs = 20;
  const double hi = nav_test::chi2_quantile(15.0 * runs, 1.959963984540054);
  double nees_joint = 0.0, nees_split = 0.0, err_joint = 0.0, err_split = 0.0;
  for (int r = 0; r < runs; ++r) {
    rs.filter.split = false;
    const nav_test::RunResult joint = nav_test::run(w, rs, 300 + r);
    rs.filter.split = true;
    const nav_test::RunResult split = nav_test::run(w, rs, 300 + r);
    nees_joint += joint.nees_final;
    nees_split += split.nees_final;
    err_joint += (joint.estimate.r_L - joint.truth.r_L).squaredNorm();
    err_split += (split.estimate.r_L - split.truth.r_L).squaredNorm();
  }
  std::printf("NEES/15 joint %.3f split %.3f; RMS position error joint %.4f m split %.4f m\n",
              nees_joint / (15.0 * runs), nees_split / (15.0 * runs), std::sqrt(err_joint / runs),
              std::sqrt(err_split / runs));
  EXPECT_LT(nees_joint, hi);
  EXPECT_GT(nees_split, hi);
  EXPECT_LT(err_joint, err_split);
}

TEST(NavigationFilter, BrokenSensorsLeaveThePredictionRunning) {
  // The night side: every landmark is dark; the altimeter looks away from the body (beam +x_B, out of
  // range). The filter reports the statuses and keeps predicting: finite, covariance growing.
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.duration = 20.0;
  rs.r0_L = Eigen::Vector3d(420.0, 40.0, 60.0);
  rs.altimeter.boresight_B = Eigen::Vector3d::UnitX();
  rs.star_tracker.dropout_probability = 1.0;
  const nav_test::RunResult out = nav_test::run(w, rs, 7);
  EXPECT_TRUE(out.finite);
  EXPECT_EQ(out.filter_failures, 0);
  EXPECT_EQ(out.camera_empty, out.camera_frames);
  EXPECT_EQ(out.altimeter_ok, 0);
  EXPECT_EQ(out.altimeter_out, 20);
  EXPECT_EQ(out.dof_camera + out.dof_star + out.dof_altimeter, 0);
  EXPECT_GT(out.trace_P_final, out.trace_P0);
  EXPECT_TRUE(std::isfinite(out.nees_final));

  // The update calls' statuses for those samples.
  nav::NavigationFilter f(w.model, w.caster, w.landmarks, nav::FilterSettings{});
  nav::CameraFrame frame;
  frame.status = nav::SensorStatus::NoLandmarkVisible;
  nav::AltimeterMeasurement alt;
  alt.status = nav::SensorStatus::OutOfRange;
  EXPECT_EQ(f.update_camera(frame).status, nav::FilterStatus::InvalidInput);  // not initialised
  ASSERT_EQ(f.initialize(start_state(), nav::NavCovariance::Identity()), nav::FilterStatus::Ok);
  frame.t = alt.t = start_state().t;
  EXPECT_EQ(f.update_camera(frame).status, nav::FilterStatus::NoMeasurement);
  EXPECT_EQ(f.update_altimeter(alt).status, nav::FilterStatus::NoMeasurement);
}

TEST(NavigationFilter, BadCallsGiveStatusesAndChangeNothing) {
  const nav_test::World w = nav_test::make_world();
  nav::FilterSettings fs;
  nav::NavigationFilter f(w.model, w.caster, w.landmarks, fs);
  nav::NavCovariance P0 = nav::NavCovariance::Identity();
  P0(0, 0) = -1.0;
  EXPECT_EQ(f.initialize(start_state(), P0), nav::FilterStatus::InvalidInput);
  EXPECT_FALSE(f.initialized());
  ASSERT_EQ(f.initialize(start_state(), nav::NavCovariance::Identity() * 1e-4), nav::FilterStatus::Ok);
  const nav::NavState x = f.state();
  nav::ImuSample imu;
  imu.t = x.t;
  EXPECT_EQ(f.propagate(x.t - 1.0, imu), nav::FilterStatus::InvalidInput);
  EXPECT_EQ(f.propagate(x.t + 1000.0, imu), nav::FilterStatus::StepTooLong);
  EXPECT_EQ(f.propagate(NAN, imu), nav::FilterStatus::InvalidInput);
  EXPECT_EQ(f.state().t, x.t);
  imu.status = nav::SensorStatus::Dropout;
  imu.omega_BI_B.setConstant(NAN);
  EXPECT_EQ(f.propagate(x.t + 0.1, imu), nav::FilterStatus::ImuHeld);
  EXPECT_TRUE(f.state().r_L.allFinite());
  nav::StarTrackerMeasurement st;
  st.t = x.t;  // the filter is now at x.t + 0.1
  EXPECT_EQ(f.update_star_tracker(st).status, nav::FilterStatus::TimeMismatch);
  st.t = f.state().t;
  st.q_BL = math::quat_mul(f.state().q_BL, math::exp_map(Eigen::Vector3d(0.5, 0.0, 0.0)));
  nav::FilterSettings gated = fs;
  gated.innovation_gate = 9.0;
  nav::NavigationFilter g(w.model, w.caster, w.landmarks, gated);
  g.initialize(f.state(), nav::NavCovariance::Identity() * 1e-8);
  const nav::UpdateResult r = g.update_star_tracker(st);
  EXPECT_EQ(r.status, nav::FilterStatus::Rejected);
  EXPECT_EQ(r.rejected, 1);
  EXPECT_TRUE(g.state().q_BL.isApprox(f.state().q_BL));
  // An accepted update: the NIS and the covariance's shrinkage.
  st.q_BL = math::quat_mul(f.state().q_BL, math::exp_map(Eigen::Vector3d(1e-5, 0.0, 0.0)));
  const double before = f.covariance().block(6, 6, 3, 3).trace();
  const nav::UpdateResult ok = f.update_star_tracker(st);
  EXPECT_EQ(ok.status, nav::FilterStatus::Ok);
  EXPECT_EQ(ok.dof, 3);
  EXPECT_LT(f.covariance().block(6, 6, 3, 3).trace(), 1e-3 * before);
  // A non-finite pixel: the update is refused for numerics and undone.
  nav::CameraFrame frame;
  frame.t = f.state().t;
  frame.count = 1;
  frame.observations[0].landmark = 0;
  frame.observations[0].pixel = Eigen::Vector2d(INFINITY, 1.0);
  const nav::NavState before_frame = f.state();
  Eigen::Vector2d pixel;
  for (int i = 0; i < static_cast<int>(w.landmarks.size()); ++i) {
    if (f.predict_pixel(i, pixel)) {
      frame.observations[0].landmark = i;
      break;
    }
  }
  const nav::UpdateResult bad = f.update_camera(frame);
  EXPECT_EQ(bad.status, nav::FilterStatus::NumericalFailure);
  EXPECT_EQ(bad.failed, 1);
  EXPECT_TRUE(f.state().r_L == before_frame.r_L);
  EXPECT_THROW(nav::NavigationFilter(nullptr, w.caster, w.landmarks, fs), std::invalid_argument);
  nav::FilterSettings exact = fs;  // a frame is folded in as information: R^-1 must exist
  exact.camera.pixel_sigma = 0.0;
  try {
    nav::NavigationFilter(w.model, w.caster, w.landmarks, exact);
    ADD_FAILURE() << "pixel_sigma = 0 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("filter.camera.pixel_sigma"), std::string::npos) << e.what();
  }
}
