// Sensor faults injected in nav::NavigationSystem and their detection (nav/faults.hpp, docs/model.md M49-M50):
// the chi-square quantiles against tabulated values, each detection on its fault within a stated
// latency, an outlier landmark rejected alone, and no detection on clean data over many seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "nav_fixtures.hpp"
#include "tubempc/nav/faults.hpp"
#include "tubempc/nav/system.hpp"

using namespace tubempc;

namespace {

using Rows13 = Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNtruth, Eigen::RowMajor>;
using Rows3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
constexpr double kInf = std::numeric_limits<double>::infinity();

nav::NavigationSettings fault_settings() {
  nav::NavigationSettings s;
  s.imu.period = 0.1;
  s.altimeter.period = 1.0;
  s.camera.period = 2.0;
  s.star_tracker.period = 1.0;
  s.filter.altimeter = s.altimeter;
  s.filter.camera = s.camera;
  s.filter.imu = s.imu;
  s.filter.star_tracker = s.star_tracker;
  s.initial_sigma << 1.0, 1.0, 1.0, 0.01, 0.01, 0.01, 1e-3, 1e-3, 1e-3;
  return s;
}

struct FaultRun {
  nav::NavigationStep last;
  std::vector<nav::NavigationStep> steps;  // per period
  double max_position_error{0.0};          // |r_hat - r| over the run (m)
};

// `periods` periods of 2 s (IMU at 0.1 s) of the fixture's free drift, with `faults` injected.
FaultRun fault_run(const nav_test::World& w, const nav::NavigationSettings& ns,
                   const std::vector<nav::SensorFault>& faults, const nav::FaultDetectionSettings& det,
                   int periods, std::uint64_t seed) {
  nav::NavigationSystem sys(w.model, w.caster, w.caster, w.landmarks, ns, seed);
  sys.set_faults(faults, det);
  nav_test::RunSettings rs;
  dynamics::TruthState s;
  s << rs.r0_L, rs.v0_L, nav_test::nadir_attitude(rs.r0_L), rs.omega0_BL_B;
  const Eigen::Vector3d srp_L = nav_test::sensor_truth(*w.model, 0.0, s).accel_nongrav_L;
  const Eigen::Vector3d phi_ref = Eigen::Vector3d::Zero();
  sys.initialize(0.0, s, srp_L, phi_ref);
  const int n = 20;
  const double h = 0.1;
  dynamics::PropagatorSettings ps;
  ps.substeps = 1;
  Eigen::VectorXd t(n);
  Rows13 x(n, dynamics::kNtruth);
  Rows3 a(n, 3);
  FaultRun out;
  for (int k = 0; k < periods; ++k) {
    for (int j = 0; j < n; ++j) {
      s = dynamics::propagate(*w.model, 2.0 * k + j * h, s, dynamics::InputVector::Zero(), h, {}, ps).state;
      t(j) = 2.0 * k + (j + 1) * h;
      x.row(j) = s.transpose();
      a.row(j) = srp_L.transpose();
    }
    out.steps.push_back(sys.step(t, x, a, phi_ref));
    out.max_position_error =
        std::max(out.max_position_error, (out.steps.back().estimate.r_L - s.segment<3>(0)).norm());
  }
  out.last = out.steps.back();
  return out;
}

nav::SensorFault fault(nav::SensorFaultKind kind, double t_start, double magnitude = 0.0,
                       double duration = kInf) {
  nav::SensorFault f;
  f.kind = kind;
  f.t_start = t_start;
  f.magnitude = magnitude;
  f.duration = duration;
  return f;
}

double at(const nav::NavigationStep& s, nav::NavFault f) { return s.detected_at[static_cast<int>(f)]; }

}  // namespace

TEST(ChiSquare, QuantilesMatchTabulatedValues) {
  // scipy.stats.chi2.isf(q, dof)
  EXPECT_NEAR(nav::chi_square_upper_quantile(1e-3, 1), 10.827566170662733, 1e-9);
  EXPECT_NEAR(nav::chi_square_upper_quantile(1e-3, 2), 13.815510557964274, 1e-9);
  EXPECT_NEAR(nav::chi_square_upper_quantile(1e-3, 3), 16.266236196238129, 1e-9);
  EXPECT_NEAR(nav::chi_square_upper_quantile(0.05, 10), 18.307038053275146, 1e-9);
  EXPECT_NEAR(nav::chi_square_upper_quantile(1e-6, 32), 85.23155071709897, 1e-8);
  EXPECT_NEAR(nav::chi_square_upper_quantile(0.5, 128), 127.33395414332766, 1e-8);
  // Q(2, x) = exp(-x/2) exactly for two degrees of freedom.
  for (double x : {0.1, 1.0, 7.5, 40.0})
    EXPECT_NEAR(nav::chi_square_upper_tail(x, 2), std::exp(-x / 2), 1e-14);
  EXPECT_THROW(nav::chi_square_upper_quantile(0.0, 3), std::invalid_argument);
  EXPECT_THROW(nav::chi_square_upper_quantile(0.1, 0), std::invalid_argument);
}

TEST(NavigationFaults, SettingsNameTheBadField) {
  const auto message = [](auto&& call) {
    try {
      call();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  nav::SensorFault f;
  f.duration = 0.0;
  EXPECT_NE(message([&] { f.validate(); }).find("faults.duration"), std::string::npos);
  f = nav::SensorFault{};
  f.axis_B.setZero();
  EXPECT_NE(message([&] { f.validate(); }).find("faults.axis_B"), std::string::npos);
  nav::FaultDetectionSettings d;
  d.false_alarm_probability = 1.0;
  EXPECT_NE(message([&] { d.validate(); }).find("faults.false_alarm_probability"), std::string::npos);
  d = nav::FaultDetectionSettings{};
  d.persistence = 0;
  EXPECT_NE(message([&] { d.validate(); }).find("faults.persistence"), std::string::npos);
  const nav_test::World w = nav_test::make_world();
  nav::NavigationSystem sys(w.model, w.caster, w.caster, w.landmarks, fault_settings(), 1);
  EXPECT_THROW(sys.set_faults(std::vector<nav::SensorFault>(nav::kMaxSensorFaults + 1), {}),
               std::invalid_argument);
  EXPECT_STREQ(to_string(nav::NavFault::CameraOutage), "camera_outage");
  EXPECT_STREQ(to_string(nav::SensorFaultKind::GyroBiasStep), "gyro_bias_step");
  EXPECT_STREQ(to_string(nav::SensorStatus::Failed), "failed");
}

TEST(NavigationFaults, CameraOutageIsDetectedAfterTheOutageTime) {
  const nav_test::World w = nav_test::make_world();
  nav::FaultDetectionSettings det;
  det.outage_time = 10.0;
  const double onset = 20.0;
  const FaultRun r =
      fault_run(w, fault_settings(), {fault(nav::SensorFaultKind::CameraOutage, onset)}, det, 25, 3);
  const int cam = static_cast<int>(nav::Sensor::Camera);
  EXPECT_TRUE(r.last.fault_detected);
  EXPECT_EQ(r.last.fault_cause, nav::NavFault::CameraOutage);
  // The last good frame is at onset - 2 s: declared at the first period's end past 10 s after it.
  const double t = at(r.last, nav::NavFault::CameraOutage);
  EXPECT_GT(t, onset - 2.0 + det.outage_time);
  EXPECT_LE(t, onset - 2.0 + det.outage_time + 2.0);
  EXPECT_EQ(r.last.sensor_status[cam], nav::SensorStatus::Failed);
  for (const nav::NavigationStep& s : r.steps) {
    if (s.t < t) EXPECT_FALSE(s.fault_detected) << s.t;
    if (s.t > onset) EXPECT_EQ(s.accepted[cam], 0);
  }
}

TEST(NavigationFaults, GyroBiasStepIsDetectedWithinThreeStarTrackerSamples) {
  const nav_test::World w = nav_test::make_world();
  const double onset = 20.05;  // between samples: the first sample that sees it is at 21 s
  nav::SensorFault f = fault(nav::SensorFaultKind::GyroBiasStep, onset, 5e-4);
  f.axis_B = Eigen::Vector3d(1.0, 1.0, 0.0);
  const nav::FaultDetectionSettings det;
  const FaultRun r = fault_run(w, fault_settings(), {f}, det, 20, 5);
  ASSERT_TRUE(r.last.fault_detected);
  // The star tracker sees it first; the camera's frames fail with it: the common cause, the IMU.
  const double t =
      std::fmin(at(r.last, nav::NavFault::StarTrackerFault), at(r.last, nav::NavFault::ImuFault));
  EXPECT_TRUE(r.last.fault_cause == nav::NavFault::StarTrackerFault ||
              r.last.fault_cause == nav::NavFault::ImuFault);
  EXPECT_GE(t, 21.0);
  EXPECT_LE(t, 21.0 + (det.persistence - 1) * 1.0 + 1e-9);  // persistence star-tracker samples
  EXPECT_TRUE(std::isnan(at(r.last, nav::NavFault::AltimeterFault)));
}

TEST(NavigationFaults, AltimeterSpikeExcludesTheAltimeter) {
  const nav_test::World w = nav_test::make_world();
  const FaultRun r =
      fault_run(w, fault_settings(), {fault(nav::SensorFaultKind::AltimeterSpike, 10.0, 30.0)}, {}, 15, 7);
  const int alt = static_cast<int>(nav::Sensor::Altimeter);
  EXPECT_EQ(r.last.fault_cause, nav::NavFault::AltimeterFault);
  EXPECT_NEAR(at(r.last, nav::NavFault::AltimeterFault), 12.0, 1e-9);  // samples at 10, 11, 12 s
  EXPECT_TRUE(r.last.excluded[alt]);
  EXPECT_EQ(r.last.accepted[alt], 0);
  EXPECT_LT(r.max_position_error, 5.0);  // the camera keeps the estimate
}

TEST(NavigationFaults, AnOutlierLandmarkIsRejectedAloneAndNoFaultIsDeclared) {
  const nav_test::World w = nav_test::make_world();
  nav::NavigationSettings ns = fault_settings();
  ns.filter.innovation_gate = nav::chi_square_upper_quantile(1e-6, 2);
  const int cam = static_cast<int>(nav::Sensor::Camera);
  const FaultRun clean = fault_run(w, ns, {}, {}, 15, 9);
  const FaultRun bad =
      fault_run(w, ns, {fault(nav::SensorFaultKind::LandmarkOutlier, 0.0, 200.0)}, {}, 15, 9);
  EXPECT_FALSE(bad.last.fault_detected);
  int frames = 0;
  for (std::size_t k = 0; k < bad.steps.size(); ++k) {
    if (bad.steps[k].samples[cam] == 0 || bad.steps[k].landmarks_visible < 2) continue;
    ++frames;
    EXPECT_EQ(bad.steps[k].rejected[cam], clean.steps[k].rejected[cam] + 1) << k;
    EXPECT_EQ(bad.steps[k].accepted[cam], clean.steps[k].accepted[cam] - 1) << k;
  }
  EXPECT_GE(frames, 5);
  EXPECT_LT(bad.max_position_error, 2.0 * clean.max_position_error + 0.5);
}

TEST(NavigationFaults, CleanRunsRaiseNoDetectionAndFailAtTheStatedRate) {
  // 24 fault-free runs of 60 s: no detection at the default settings (per-sample false alarm 1e-3,
  // persistence 3), and at a per-sample false-alarm probability of 0.05 the star tracker's and the
  // altimeter's samples fail at about that rate (the NIS test is a chi-square quantile).
  const nav_test::World w = nav_test::make_world();
  nav::FaultDetectionSettings loose;
  loose.false_alarm_probability = 0.05;
  loose.persistence = 1000;
  int detections = 0;
  long failed_star = 0, tested_star = 0, failed_alt = 0, tested_alt = 0;
  const int st = static_cast<int>(nav::Sensor::StarTracker), alt = static_cast<int>(nav::Sensor::Altimeter);
  for (std::uint64_t seed = 1; seed <= 24; ++seed) {
    detections += fault_run(w, fault_settings(), {}, {}, 30, seed).last.fault_detected;
    const FaultRun r = fault_run(w, fault_settings(), {}, loose, 30, seed);
    for (const nav::NavigationStep& s : r.steps) {
      failed_star += s.failed[st];
      tested_star += s.accepted[st] + s.rejected[st];
      failed_alt += s.failed[alt];
      tested_alt += s.accepted[alt] + s.rejected[alt];
    }
  }
  EXPECT_EQ(detections, 0);
  const double rate_star = static_cast<double>(failed_star) / tested_star;
  const double rate_alt = static_cast<double>(failed_alt) / tested_alt;
  std::printf("per-sample failure rate at 0.05: star tracker %.4f (%ld), altimeter %.4f (%ld)\n", rate_star,
              tested_star, rate_alt, tested_alt);
  EXPECT_GT(tested_star, 1000);
  EXPECT_GT(rate_star, 0.02);
  EXPECT_LT(rate_star, 0.09);
  EXPECT_LT(rate_alt, 0.09);
}
