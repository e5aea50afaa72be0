// The sensors against independent computations: the altimeter over a box, the camera's pixels from a
// quaternion sandwich product, visibility (field of view, facing, Sun, occlusion), the IMU and the star
// tracker without and with noise, dropouts and the settings' checks.
#include <gtest/gtest.h>

#include <cmath>

#include "../gravity/gravity_test_meshes.hpp"
#include "nav_fixtures.hpp"

using namespace tubempc;

namespace {

std::shared_ptr<const nav::RayCaster> box_caster() {
  const gravity_test::Mesh m = gravity_test::box(-10.0, 10.0, -10.0, 10.0, -10.0, 10.0);
  return std::make_shared<nav::RayCaster>(gravity::Shape(m.v, m.f));
}

// Rotate v by q with the quaternion sandwich q (x) [v; 0] (x) q^*.
Eigen::Vector3d rotate(const math::Quaternion& q, const Eigen::Vector3d& v) {
  math::Quaternion p;
  p << v, 0.0;
  return math::quat_mul(math::quat_mul(q, p), math::quat_conj(q)).head<3>();
}

nav::SensorTruth above_box(double height, const math::Quaternion& q_BL) {
  nav::SensorTruth t;
  t.r_L = Eigen::Vector3d(1.0, 5.0, 10.0 + height);
  t.q_BL = q_BL;
  return t;
}

}  // namespace

TEST(Altimeter, RangeToAFlatFaceAndItsLimits) {
  nav::AltimeterSettings s;
  s.sigma = 0.0;
  s.bias = 0.25;
  s.max_range = 100.0;
  s.boresight_B = Eigen::Vector3d(0.0, 0.0, 1.0);
  nav::Altimeter alt(box_caster(), s, 1);
  // +z_B pointing down (-z_L) after a half turn about x, tilted by 0.3 rad about x: range h / cos(0.3).
  const math::Quaternion q = math::exp_map(Eigen::Vector3d(3.14159265358979323846 - 0.3, 0.0, 0.0));
  nav::AltimeterMeasurement m;
  ASSERT_EQ(alt.measure(above_box(40.0, q), m), nav::SensorStatus::Ok);
  EXPECT_NEAR(m.range, 40.0 / std::cos(0.3) + 0.25, 1e-10);
  // Beyond max_range, pointing away, non-finite state.
  EXPECT_EQ(alt.measure(above_box(120.0, q), m), nav::SensorStatus::OutOfRange);
  EXPECT_EQ(alt.measure(above_box(40.0, math::quat_identity()), m), nav::SensorStatus::OutOfRange);
  nav::SensorTruth bad = above_box(40.0, q);
  bad.r_L.x() = NAN;
  EXPECT_EQ(alt.measure(bad, m), nav::SensorStatus::InvalidInput);
  s.min_range = 50.0;
  nav::Altimeter near_limit(box_caster(), s, 1);
  EXPECT_EQ(near_limit.measure(above_box(40.0, q), m), nav::SensorStatus::OutOfRange);
  // Noise statistics and dropouts.
  s.min_range = 1.0;
  s.sigma = 0.1;
  s.dropout_probability = 0.3;
  nav::Altimeter noisy(box_caster(), s, 9);
  int ok = 0, dropped = 0;
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const nav::SensorStatus st = noisy.measure(above_box(40.0, q), m);
    if (st == nav::SensorStatus::Dropout) ++dropped;
    if (st != nav::SensorStatus::Ok) continue;
    ++ok;
    const double e = m.range - 0.25 - 40.0 / std::cos(0.3);
    sum += e;
    sum2 += e * e;
  }
  EXPECT_EQ(ok + dropped, 20000);
  EXPECT_NEAR(dropped / 20000.0, 0.3, 5.0 * std::sqrt(0.21 / 20000));
  EXPECT_NEAR(sum / ok, 0.0, 5.0 * 0.1 / std::sqrt(ok));
  EXPECT_NEAR(std::sqrt(sum2 / ok), 0.1, 5.0 * 0.1 / std::sqrt(2.0 * ok));
}

TEST(Camera, PixelsMatchAnIndependentProjection) {
  auto caster = box_caster();
  // Landmarks on the top face (normal +z_A); the Sun (-x_L) lights them at 60 deg incidence when A
  // is tilted; here A = L and the Sun is along -x: tilt the landmarks' normals instead.
  std::vector<nav::Landmark> lms;
  for (int i = 0; i < 5; ++i) {
    nav::Landmark lm;
    lm.p_A = Eigen::Vector3d(-6.0 + 3.0 * i, 2.0 - i, 10.0);
    lm.normal_A = Eigen::Vector3d(-1.0, 0.0, 1.0).normalized();
    lms.push_back(lm);
  }
  nav::CameraSettings s;
  s.pixel_sigma = 0.0;
  s.pixel_bias = Eigen::Vector2d(0.5, -0.25);
  s.max_incidence_angle = 1.0;  // 57 deg: the normals are 45 deg from the Sun
  s.max_emission_angle = 1.5;
  s.C_BC = math::rotation_matrix(math::exp_map(Eigen::Vector3d(0.0, 0.0, 0.4)));
  nav::NavCamera cam(caster, lms, s, 3);
  const math::Quaternion q = math::exp_map(Eigen::Vector3d(3.1, 0.05, -0.02));  // looking down
  const nav::SensorTruth truth = above_box(60.0, q);
  nav::CameraFrame frame;
  ASSERT_EQ(cam.measure(truth, frame), nav::SensorStatus::Ok);
  ASSERT_EQ(frame.count, 5);
  const math::Quaternion q_BC = math::quat_from_rotation_matrix(s.C_BC);
  for (int i = 0; i < frame.count; ++i) {
    const nav::LandmarkObservation& o = frame.observations[static_cast<std::size_t>(i)];
    // s_C = q_BC^* (x) q_BL^* (x) (p - r) (x) q_BL (x) q_BC.
    const Eigen::Vector3d s_C =
        rotate(math::quat_conj(q_BC),
               rotate(math::quat_conj(q), lms[static_cast<std::size_t>(o.landmark)].p_A - truth.r_L));
    const double u = 512.0 + 1500.0 * s_C.x() / s_C.z() + 0.5, v = 512.0 + 1500.0 * s_C.y() / s_C.z() - 0.25;
    EXPECT_NEAR(o.pixel.x(), u, 1e-9);
    EXPECT_NEAR(o.pixel.y(), v, 1e-9);
  }
  // No light: the Sun along -x_L lights nothing whose normal points along +x.
  for (auto& lm : lms) lm.normal_A = Eigen::Vector3d(1.0, 0.0, 1.0).normalized();
  nav::NavCamera dark(caster, lms, s, 3);
  EXPECT_EQ(dark.measure(truth, frame), nav::SensorStatus::NoLandmarkVisible);
  EXPECT_EQ(frame.count, 0);
  // Looking away: nothing in the field of view.
  EXPECT_EQ(cam.measure(above_box(60.0, math::quat_identity()), frame), nav::SensorStatus::NoLandmarkVisible);
}

TEST(Camera, OccludedAndBackFacingLandmarksAreNotSeen) {
  auto caster = box_caster();
  // A landmark on the bottom face with a normal made to face the camera: only occlusion hides it.
  nav::Landmark hidden;
  hidden.p_A = Eigen::Vector3d(0.0, 0.0, -10.0);
  hidden.normal_A = Eigen::Vector3d(-1.0, 0.0, 1.0).normalized();
  nav::Landmark top = hidden;
  top.p_A.z() = 10.0;
  nav::CameraSettings s;
  s.max_incidence_angle = 1.0;
  nav::NavCamera cam(caster, {hidden, top}, s, 1);
  const nav::SensorTruth truth =
      above_box(60.0, math::exp_map(Eigen::Vector3d(3.14159265358979323846, 0.0, 0.0)));
  Eigen::Vector2d pixel;
  EXPECT_FALSE(cam.visible(0, truth, pixel));
  EXPECT_TRUE(cam.visible(1, truth, pixel));
  // Back-facing: the emission angle test.
  nav::Landmark side = top;
  side.normal_A = Eigen::Vector3d(-1.0, 0.0, -1.0).normalized();
  nav::NavCamera cam2(caster, {side}, s, 1);
  EXPECT_FALSE(cam2.visible(0, truth, pixel));
  // Range limits.
  s.max_range = 30.0;
  nav::NavCamera cam3(caster, {top}, s, 1);
  EXPECT_FALSE(cam3.visible(0, truth, pixel));
}

TEST(Camera, CatalogueIsOnTheSurfaceAndTheFovHelperInvertsThePinhole) {
  const nav_test::World w = nav_test::make_world();
  ASSERT_GT(w.landmarks.size(), 300u);
  for (const nav::Landmark& lm : w.landmarks) {
    // On its face: a ray from just outside along -normal hits it at once.
    const nav::RayHit h = w.caster->cast(lm.p_A + 1e-3 * lm.normal_A, -lm.normal_A);
    ASSERT_TRUE(h.hit);
    EXPECT_NEAR(h.distance, 1e-3, 1e-6);
    EXPECT_NEAR(lm.normal_A.norm(), 1.0, 1e-12);
  }
  const double f = nav::CameraSettings::focal_length_from_fov(0.6, 1024);
  EXPECT_NEAR(2.0 * std::atan(512.0 / f), 0.6, 1e-12);
  EXPECT_THROW(nav::CameraSettings::focal_length_from_fov(3.2, 1024), std::invalid_argument);
  EXPECT_EQ(nav::generate_landmarks(*w.caster, 400).size(), w.landmarks.size());  // deterministic
}

TEST(Imu, MeasuresSpecificForceAndInertialRate) {
  nav::ImuSettings s;
  s.gyro_noise_density = 0.0;
  s.accel_noise_density = 0.0;
  s.gyro_bias_random_walk = 0.0;
  s.accel_bias_random_walk = 0.0;
  nav::Imu imu(s, 5);
  nav::SensorTruth t;
  t.q_BL = math::exp_map(Eigen::Vector3d(0.3, -1.0, 2.0));
  t.omega_BL_B = Eigen::Vector3d(1e-3, 2e-3, -3e-3);
  t.omega_LI_L = Eigen::Vector3d(0.0, 0.0, 2e-7);
  t.accel_nongrav_L = Eigen::Vector3d(1e-3, -2e-4, 5e-5);
  nav::ImuSample m;
  ASSERT_EQ(imu.measure(t, m), nav::SensorStatus::Ok);
  EXPECT_GT(imu.gyro_bias().norm(), 0.0);
  EXPECT_TRUE(m.specific_force_B.isApprox(
      rotate(math::quat_conj(t.q_BL), t.accel_nongrav_L) + imu.accel_bias(), 1e-12));
  EXPECT_TRUE(m.omega_BI_B.isApprox(
      t.omega_BL_B + rotate(math::quat_conj(t.q_BL), t.omega_LI_L) + imu.gyro_bias(), 1e-12));
  // Noise: standard deviation density / sqrt(period).
  s.gyro_noise_density = 1e-4;
  s.period = 0.25;
  nav::Imu noisy(s, 6);
  double sum2 = 0.0;
  const int n = 10000;
  for (int i = 0; i < n; ++i) {
    noisy.measure(t, m);
    sum2 += (m.omega_BI_B - t.omega_BL_B - rotate(math::quat_conj(t.q_BL), t.omega_LI_L) - noisy.gyro_bias())
                .squaredNorm();
  }
  EXPECT_NEAR(std::sqrt(sum2 / (3 * n)), 2e-4, 5.0 * 2e-4 / std::sqrt(6.0 * n));
}

TEST(StarTracker, MeasuresAttitudeWithNoiseAndMisalignment) {
  nav::StarTrackerSettings s;
  s.sigma_B.setZero();
  s.misalignment_B = Eigen::Vector3d(1e-3, 0.0, -2e-3);
  nav::StarTracker st(s, 2);
  nav::SensorTruth t;
  t.q_BL = math::exp_map(Eigen::Vector3d(0.5, 2.0, -1.0));
  nav::StarTrackerMeasurement m;
  ASSERT_EQ(st.measure(t, m), nav::SensorStatus::Ok);
  EXPECT_TRUE(
      math::log_map(math::quat_mul(math::quat_conj(t.q_BL), m.q_BL)).isApprox(s.misalignment_B, 1e-9));
  s.misalignment_B.setZero();
  s.sigma_B = Eigen::Vector3d(1e-4, 2e-4, 1e-3);
  nav::StarTracker noisy(s, 3);
  Eigen::Vector3d sum2 = Eigen::Vector3d::Zero();
  const int n = 10000;
  for (int i = 0; i < n; ++i) {
    noisy.measure(t, m);
    sum2 += math::log_map(math::quat_mul(math::quat_conj(t.q_BL), m.q_BL)).cwiseAbs2();
  }
  for (int j = 0; j < 3; ++j)
    EXPECT_NEAR(std::sqrt(sum2(j) / n), s.sigma_B(j), 5.0 * s.sigma_B(j) / std::sqrt(2.0 * n));
  s.dropout_probability = 1.0;
  nav::StarTracker lost(s, 3);
  EXPECT_EQ(lost.measure(t, m), nav::SensorStatus::Dropout);
}

TEST(Sensors, SettingsNameTheBadField) {
  auto message = [](auto f) {
    try {
      f();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  nav::AltimeterSettings a;
  a.max_range = 0.5;
  EXPECT_NE(message([&] { a.validate(); }).find("altimeter.max_range"), std::string::npos);
  nav::CameraSettings c;
  c.max_landmarks = nav::kMaxLandmarksPerFrame + 1;
  EXPECT_NE(message([&] { c.validate(); }).find("camera.max_landmarks"), std::string::npos);
  c = nav::CameraSettings{};
  c.C_BC(0, 0) = 2.0;
  EXPECT_NE(message([&] { c.validate(); }).find("camera.C_BC"), std::string::npos);
  nav::ImuSettings i;
  i.period = 0.0;
  EXPECT_NE(message([&] { i.validate(); }).find("imu.period"), std::string::npos);
  nav::StarTrackerSettings s;
  s.dropout_probability = 1.5;
  EXPECT_NE(message([&] { s.validate(); }).find("star_tracker.dropout_probability"), std::string::npos);
  nav::FilterSettings fs;
  fs.max_substeps = 0;
  EXPECT_NE(message([&] { fs.validate(); }).find("filter.max_substeps"), std::string::npos);
  EXPECT_STREQ(nav::to_string(nav::SensorStatus::NoLandmarkVisible), "no_landmark_visible");
  EXPECT_STREQ(nav::to_string(nav::FilterStatus::TimeMismatch), "time_mismatch");
}
