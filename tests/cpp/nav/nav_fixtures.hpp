// A small asteroid, its sensors and a navigation run (truth, sensors, filter) shared by the navigation
// tests and the allocation test.
#pragma once

#include <cmath>
#include <memory>
#include <vector>

#include "../gravity/gravity_test_meshes.hpp"
#include "tubempc/dynamics/propagator.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc/nav/filter.hpp"
#include "tubempc/nav/sensors.hpp"

namespace nav_test {

using namespace tubempc;

// A lumpy body of mean radius ~200 m (528 faces), its gravity, the model, the caster and 400 landmarks.
struct World {
  std::shared_ptr<const gravity::PolyhedronGravity> gravity;
  std::shared_ptr<const dynamics::ProximityModel> model;
  std::shared_ptr<const nav::RayCaster> caster;
  std::vector<nav::Landmark> landmarks;
};

inline World make_world() {
  const gravity_test::Mesh m = gravity_test::lumpy_body(12, 24, 200.0);
  gravity::Shape shape(m.v, m.f);
  World w;
  w.caster = std::make_shared<nav::RayCaster>(shape);
  w.gravity = std::make_shared<gravity::PolyhedronGravity>(shape, 1260.0);
  w.model = std::make_shared<dynamics::ProximityModel>(w.gravity);
  w.landmarks = nav::generate_landmarks(*w.caster, 400);
  return w;
}

// q_B/L of an attitude whose +z_B points from r_L to the asteroid's centre.
inline math::Quaternion nadir_attitude(const Eigen::Vector3d& r_L) {
  const Eigen::Vector3d z = -r_L.normalized();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitZ().cross(z).normalized();
  Eigen::Matrix3d C_LB;
  C_LB << x, z.cross(x), z;
  return math::quat_from_rotation_matrix(C_LB);
}

// The sensors' view of a truth state.
inline nav::SensorTruth sensor_truth(const dynamics::ProximityModel& model, double t,
                                     const dynamics::TruthState& s) {
  nav::SensorTruth st;
  st.t = t;
  st.r_L = s.segment<3>(0);
  st.q_BL = s.segment<4>(6);
  st.omega_BL_B = s.segment<3>(10);
  st.omega_LI_L = Eigen::Vector3d(0.0, 0.0, model.mean_motion());
  const auto& p = model.params();
  st.accel_nongrav_L =
      Eigen::Vector3d::UnitX() * (p.srp_enabled ? p.beta_srp / (p.orbit_radius * p.orbit_radius) : 0.0);
  st.C_AL = model.C_AL(t);
  return st;
}

// Settings of one run: the truth's sensors and the filter's model of them.
struct RunSettings {
  nav::AltimeterSettings altimeter{};
  nav::CameraSettings camera{};
  nav::StarTrackerSettings star_tracker{};
  nav::ImuSettings imu{};
  nav::FilterSettings filter{};  // its sensor settings are overwritten by the above unless keep_filter
  bool keep_filter_sensors{false};
  double duration{60.0};  // s
  Eigen::Vector3d r0_L{-420.0, 40.0, 60.0};
  Eigen::Vector3d v0_L{0.02, -0.03, 0.01};
  Eigen::Vector3d omega0_BL_B{1e-4, -2e-4, 5e-5};
  Eigen::Matrix<double, 15, 1> sigma0 = (Eigen::Matrix<double, 15, 1>() << 2.0, 2.0, 2.0, 0.01, 0.01, 0.01,
                                         1e-3, 1e-3, 1e-3, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5)
                                            .finished();
};

struct RunResult {
  double nees_final{0.0};
  double nis_camera{0.0};
  int dof_camera{0};
  double nis_star{0.0};
  int dof_star{0};
  double nis_altimeter{0.0};
  int dof_altimeter{0};
  int camera_frames{0}, camera_empty{0}, altimeter_ok{0}, altimeter_out{0};
  int filter_failures{0};
  bool finite{true};
  double trace_P0{0.0}, trace_P_final{0.0};
  nav::NavCovariance P_final{nav::NavCovariance::Zero()};
  long gravity_evaluations{0};
  double gravity_expansion_error{0.0};  // m/s^2
  nav::NavState estimate, truth;
};

inline RunResult run(const World& w, const RunSettings& rs, std::uint64_t seed) {
  nav::ImuSettings imu_s = rs.imu;
  nav::FilterSettings fs = rs.filter;
  if (!rs.keep_filter_sensors) {
    fs.altimeter = rs.altimeter;
    fs.camera = rs.camera;
    fs.star_tracker = rs.star_tracker;
    fs.imu = rs.imu;
  }
  nav::Altimeter altimeter(w.caster, rs.altimeter, seed * 4 + 1);
  nav::NavCamera camera(w.caster, w.landmarks, rs.camera, seed * 4 + 2);
  nav::Imu imu(imu_s, seed * 4 + 3);
  nav::StarTracker star(rs.star_tracker, seed * 4 + 4);
  nav::NavigationFilter filter(w.model, w.caster, w.landmarks, fs);
  nav::Random rng(seed * 4 + 5);

  dynamics::TruthState s;
  s << rs.r0_L, rs.v0_L, nadir_attitude(rs.r0_L), rs.omega0_BL_B;
  Eigen::Matrix<double, 15, 1> e;
  for (int i = 0; i < 15; ++i) e(i) = rs.sigma0(i) * rng.normal();
  nav::NavState x0;
  x0.r_L = rs.r0_L - e.segment<3>(0);
  x0.v_L = rs.v0_L - e.segment<3>(3);
  x0.q_BL = math::quat_mul(s.segment<4>(6), math::exp_map(-e.segment<3>(6)));
  x0.gyro_bias_B.setZero();
  x0.accel_bias_B.setZero();
  nav::NavCovariance P0 = nav::NavCovariance::Zero();
  P0.diagonal() = rs.sigma0.cwiseAbs2();
  P0.block<3, 3>(9, 9).diagonal().setConstant(imu_s.gyro_bias_sigma * imu_s.gyro_bias_sigma + 1e-30);
  P0.block<3, 3>(12, 12).diagonal().setConstant(imu_s.accel_bias_sigma * imu_s.accel_bias_sigma + 1e-30);
  // The estimate's biases are 0; the truth's come from the IMU's draw (standard deviation as in P0).
  filter.initialize(x0, P0);

  RunResult out;
  out.trace_P0 = P0.trace();
  const double T = imu_s.period;
  const int steps = static_cast<int>(std::lround(rs.duration / T));
  const int every_cam = static_cast<int>(std::lround(rs.camera.period / T));
  const int every_alt = static_cast<int>(std::lround(rs.altimeter.period / T));
  const int every_st = static_cast<int>(std::lround(rs.star_tracker.period / T));
  dynamics::PropagatorSettings ps;
  ps.substeps = 1;
  const dynamics::InputVector u = dynamics::InputVector::Zero();
  nav::ImuSample sample;
  nav::AltimeterMeasurement alt;
  nav::CameraFrame frame;
  nav::StarTrackerMeasurement st;
  for (int k = 0; k <= steps; ++k) {
    const double t = k * T;
    const nav::SensorTruth truth = sensor_truth(*w.model, t, s);
    if (k > 0) {
      if (k % every_st == 0) {
        star.measure(truth, st);
        const nav::UpdateResult r = filter.update_star_tracker(st);
        out.nis_star += r.nis;
        out.dof_star += r.dof;
      }
      if (k % every_alt == 0) {
        const nav::SensorStatus a = altimeter.measure(truth, alt);
        out.altimeter_ok += a == nav::SensorStatus::Ok;
        out.altimeter_out += a == nav::SensorStatus::OutOfRange;
        const nav::UpdateResult r = filter.update_altimeter(alt);
        out.nis_altimeter += r.nis;
        out.dof_altimeter += r.dof;
      }
      if (k % every_cam == 0) {
        const nav::SensorStatus c = camera.measure(truth, frame);
        out.camera_frames += 1;
        out.camera_empty += c == nav::SensorStatus::NoLandmarkVisible;
        const nav::UpdateResult r = filter.update_camera(frame);
        out.nis_camera += r.nis;
        out.dof_camera += r.dof;
      }
    }
    if (k == steps) break;
    imu.measure(truth, sample);
    const nav::FilterStatus fst = filter.propagate(t + T, sample);
    out.filter_failures += fst != nav::FilterStatus::Ok;
    s = dynamics::propagate(*w.model, t, s, u, T, {}, ps).state;
    out.finite = out.finite && filter.state().r_L.allFinite();  // P is read at the end: reading it
  }                                                             // would propagate it at every sample
  out.finite = out.finite && filter.covariance().allFinite();
  out.estimate = filter.state();
  out.truth.t = steps * T;
  out.truth.r_L = s.segment<3>(0);
  out.truth.v_L = s.segment<3>(3);
  out.truth.q_BL = s.segment<4>(6);
  out.truth.gyro_bias_B = imu.gyro_bias();
  out.truth.accel_bias_B = imu.accel_bias();
  out.nees_final = nav::nees(out.estimate, filter.covariance(), out.truth);
  out.trace_P_final = filter.covariance().trace();
  out.P_final = filter.covariance();
  out.gravity_evaluations = filter.gravity_evaluations();
  out.gravity_expansion_error = filter.gravity_expansion_error();
  return out;
}

// Wilson-Hilferty approximation of the p-quantile of a chi-square with k degrees of freedom (relative
// error < 1e-3 for k >= 30); z the standard normal quantile of p.
inline double chi2_quantile(double k, double z) {
  const double a = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - a + z * std::sqrt(a), 3);
}

}  // namespace nav_test
