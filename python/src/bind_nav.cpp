#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "tubempc/nav/faults.hpp"
#include "tubempc/nav/filter.hpp"
#include "tubempc/nav/random.hpp"
#include "tubempc/nav/ray_caster.hpp"
#include "tubempc/nav/sensors.hpp"
#include "tubempc/nav/system.hpp"

namespace py = pybind11;

namespace tubempc::python {

namespace {

using namespace tubempc::nav;
using Rows3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Rows13 = Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNtruth, Eigen::RowMajor>;

// Ray casts of many rays with the GIL released: distances (inf for a miss) and faces (-1).
py::tuple cast_batch(const RayCaster& caster, const Eigen::Ref<const Rows3>& origins_A,
                     const Eigen::Ref<const Rows3>& directions_A, double max_distance, bool brute_force) {
  if (origins_A.rows() != directions_A.rows())
    throw std::invalid_argument("cast_batch: origins_A and directions_A must have the same number of rows");
  const Eigen::Index n = origins_A.rows();
  Eigen::VectorXd distance(n);
  Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1> face(n);
  {
    py::gil_scoped_release release;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Eigen::Vector3d o = origins_A.row(i).transpose(), d = directions_A.row(i).transpose();
      const RayHit h =
          brute_force ? caster.cast_all_faces(o, d, max_distance) : caster.cast(o, d, max_distance);
      distance(i) = h.hit ? h.distance : std::numeric_limits<double>::infinity();
      face(i) = h.face;
    }
  }
  return py::make_tuple(distance, face);
}

}  // namespace

void bind_nav(py::module_& m) {
  auto s = m.def_submodule(
      "nav",
      "Navigation: ray casting on the shape model, landmark catalogue, altimeter, camera, IMU, "
      "star tracker and the joint error-state EKF (docs/model.md 'Navigation'); SI units");

  py::class_<Random>(s, "Random",
                     "The project's seeded stream: xoshiro256** (SplitMix64 seeding), Box-Muller normals")
      .def(py::init<std::uint64_t>(), py::arg("seed") = 0)
      .def("reseed", &Random::reseed, py::arg("seed"))
      .def("next_u64", &Random::next_u64)
      .def("uniform", &Random::uniform, "Uniform in [0, 1) (53 bits)")
      .def("normal", &Random::normal, "Standard normal (Box-Muller)");

  py::class_<RayHit>(s, "RayHit", "The nearest intersection of a ray with the mesh (frame A, m)")
      .def_readonly("hit", &RayHit::hit)
      .def_readonly("distance", &RayHit::distance)
      .def_readonly("face", &RayHit::face)
      .def_readonly("point_A", &RayHit::point_A)
      .def_readonly("normal_A", &RayHit::normal_A);

  py::class_<RayCaster, std::shared_ptr<RayCaster>>(
      s, "RayCaster", "Ray caster over a Shape (bounding-volume hierarchy, frame A)")
      .def(py::init<const gravity::Shape&>(), py::arg("shape"))
      .def("cast", &RayCaster::cast, py::arg("origin_A"), py::arg("direction_A"),
           py::arg("max_distance") = std::numeric_limits<double>::infinity(), "First face met (m)")
      .def("cast_all_faces", &RayCaster::cast_all_faces, py::arg("origin_A"), py::arg("direction_A"),
           py::arg("max_distance") = std::numeric_limits<double>::infinity(),
           "The same over every face (O(m))")
      .def("cast_batch", &cast_batch, py::arg("origins_A"), py::arg("directions_A"),
           py::arg("max_distance") = std::numeric_limits<double>::infinity(), py::arg("brute_force") = false,
           "Rows of rays (n, 3): (distances (n,) m, inf for a miss; faces (n,), -1 for a miss); GIL released")
      .def("blocked", &RayCaster::blocked, py::arg("from_A"), py::arg("to_A"), py::arg("end_margin"))
      .def_property_readonly("n_faces", &RayCaster::n_faces)
      .def_property_readonly("n_nodes", &RayCaster::n_nodes)
      .def_property_readonly("depth", &RayCaster::depth)
      .def_property_readonly("size", &RayCaster::size)
      .def_property_readonly("box_center_A", &RayCaster::box_center_A);

  py::class_<Landmark>(s, "Landmark", "A surface landmark in A")
      .def(py::init<>())
      .def_readwrite("p_A", &Landmark::p_A)
      .def_readwrite("normal_A", &Landmark::normal_A)
      .def_readwrite("face", &Landmark::face);
  s.def("generate_landmarks", &generate_landmarks, py::arg("caster"), py::arg("count"),
        "Landmarks seen from count Fibonacci-lattice directions (deterministic)");

  bind_named_enum<SensorStatus>(s, "SensorStatus", "Outcome of one measurement");
  bind_named_enum<FilterStatus>(s, "FilterStatus", "Outcome of a filter call");

  py::class_<SensorTruth>(s, "SensorTruth", "The true state the sensors observe")
      .def(py::init<>())
      .def_readwrite("t", &SensorTruth::t)
      .def_readwrite("r_L", &SensorTruth::r_L)
      .def_readwrite("q_BL", &SensorTruth::q_BL)
      .def_readwrite("omega_BL_B", &SensorTruth::omega_BL_B)
      .def_readwrite("omega_LI_L", &SensorTruth::omega_LI_L)
      .def_readwrite("accel_nongrav_L", &SensorTruth::accel_nongrav_L)
      .def_readwrite("C_AL", &SensorTruth::C_AL);

  py::class_<AltimeterSettings> altimeter(s, "AltimeterSettings", "Laser altimeter settings");
  altimeter.def(py::init<>()).def("validate", &AltimeterSettings::validate);
  bind_fields(altimeter);
  py::class_<CameraSettings> camera(s, "CameraSettings", "Navigation camera settings (pinhole model)");
  camera.def(py::init<>())
      .def("validate", &CameraSettings::validate)
      .def_static("focal_length_from_fov", &CameraSettings::focal_length_from_fov, py::arg("fov_rad"),
                  py::arg("width_px"));
  bind_fields(camera);
  py::class_<ImuSettings> imu(s, "ImuSettings", "IMU settings (noise densities, biases, period)");
  imu.def(py::init<>()).def("validate", &ImuSettings::validate);
  bind_fields(imu);
  py::class_<StarTrackerSettings> star_tracker(s, "StarTrackerSettings", "Star tracker settings");
  star_tracker.def(py::init<>()).def("validate", &StarTrackerSettings::validate);
  bind_fields(star_tracker);
  py::class_<FilterSettings> filter(s, "FilterSettings",
                                    "The filter's settings, with its model of the sensors");
  filter.def(py::init<>()).def("validate", &FilterSettings::validate);
  bind_fields(filter);

  py::class_<AltimeterMeasurement>(s, "AltimeterMeasurement")
      .def(py::init<>())
      .def_readwrite("t", &AltimeterMeasurement::t)
      .def_readwrite("status", &AltimeterMeasurement::status)
      .def_readwrite("range", &AltimeterMeasurement::range);
  py::class_<CameraFrame>(s, "CameraFrame")
      .def(py::init<>())
      .def_readwrite("t", &CameraFrame::t)
      .def_readwrite("status", &CameraFrame::status)
      .def_readonly("count", &CameraFrame::count)
      .def_property_readonly("landmarks",
                             [](const CameraFrame& f) {
                               std::vector<int> out;
                               for (int i = 0; i < f.count; ++i) out.push_back(f.observations[i].landmark);
                               return out;
                             })
      .def_property_readonly("pixels", [](const CameraFrame& f) {
        Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor> p(f.count, 2);
        for (int i = 0; i < f.count; ++i) p.row(i) = f.observations[i].pixel.transpose();
        return p;
      });
  py::class_<ImuSample>(s, "ImuSample")
      .def(py::init<>())
      .def_readwrite("t", &ImuSample::t)
      .def_readwrite("status", &ImuSample::status)
      .def_readwrite("specific_force_B", &ImuSample::specific_force_B)
      .def_readwrite("omega_BI_B", &ImuSample::omega_BI_B);
  py::class_<StarTrackerMeasurement>(s, "StarTrackerMeasurement")
      .def(py::init<>())
      .def_readwrite("t", &StarTrackerMeasurement::t)
      .def_readwrite("status", &StarTrackerMeasurement::status)
      .def_readwrite("q_BL", &StarTrackerMeasurement::q_BL);

  py::class_<Altimeter>(s, "Altimeter", "Laser altimeter (range along a beam fixed in B)")
      .def(py::init<std::shared_ptr<const RayCaster>, const AltimeterSettings&, std::uint64_t>(),
           py::arg("caster"), py::arg("settings"), py::arg("seed"))
      .def(
          "measure",
          [](Altimeter& a, const SensorTruth& t) {
            AltimeterMeasurement m;
            a.measure(t, m);
            return m;
          },
          py::arg("truth"))
      .def_property_readonly("settings", &Altimeter::settings);
  py::class_<NavCamera>(s, "NavCamera", "Pinhole navigation camera observing the landmark catalogue")
      .def(py::init<std::shared_ptr<const RayCaster>, std::vector<Landmark>, const CameraSettings&,
                    std::uint64_t>(),
           py::arg("caster"), py::arg("landmarks"), py::arg("settings"), py::arg("seed"))
      .def(
          "project",
          [](const NavCamera& c, const Eigen::Vector3d& s_C) {
            Eigen::Vector2d p;
            const bool in = c.project(s_C, p);
            return py::make_tuple(in, p);
          },
          py::arg("s_C"), "(inside the image, pixel (u, v)) of a point in C (m)")
      .def(
          "visible",
          [](const NavCamera& c, int i, const SensorTruth& t) {
            if (i < 0 || i >= static_cast<int>(c.landmarks().size()))
              throw std::invalid_argument("visible: landmark index out of range");
            Eigen::Vector2d p = Eigen::Vector2d::Zero();
            const bool v = c.visible(i, t, p);
            return py::make_tuple(v, p);
          },
          py::arg("landmark"), py::arg("truth"))
      .def(
          "measure",
          [](NavCamera& c, const SensorTruth& t) {
            CameraFrame f;
            c.measure(t, f);
            return f;
          },
          py::arg("truth"))
      .def_property_readonly("settings", &NavCamera::settings)
      .def_property_readonly("landmarks", &NavCamera::landmarks);
  py::class_<Imu>(s, "Imu", "Accelerometer (non-gravitational acceleration in B) and gyro (omega_BI_B)")
      .def(py::init<const ImuSettings&, std::uint64_t>(), py::arg("settings"), py::arg("seed"))
      .def(
          "measure",
          [](Imu& imu, const SensorTruth& t) {
            ImuSample m;
            imu.measure(t, m);
            return m;
          },
          py::arg("truth"))
      .def_property_readonly("gyro_bias", &Imu::gyro_bias)
      .def_property_readonly("accel_bias", &Imu::accel_bias)
      .def_property_readonly("settings", &Imu::settings);
  py::class_<StarTracker>(s, "StarTracker", "Star tracker (q_B/L with noise)")
      .def(py::init<const StarTrackerSettings&, std::uint64_t>(), py::arg("settings"), py::arg("seed"))
      .def(
          "measure",
          [](StarTracker& st, const SensorTruth& t) {
            StarTrackerMeasurement m;
            st.measure(t, m);
            return m;
          },
          py::arg("truth"))
      .def_property_readonly("settings", &StarTracker::settings);

  py::class_<NavState>(s, "NavState", "Navigation state: t, r_L, v_L, q_BL, gyro_bias_B, accel_bias_B")
      .def(py::init<>())
      .def_readwrite("t", &NavState::t)
      .def_readwrite("r_L", &NavState::r_L)
      .def_readwrite("v_L", &NavState::v_L)
      .def_readwrite("q_BL", &NavState::q_BL)
      .def_readwrite("gyro_bias_B", &NavState::gyro_bias_B)
      .def_readwrite("accel_bias_B", &NavState::accel_bias_B);
  py::class_<UpdateResult>(s, "UpdateResult")
      .def_readonly("status", &UpdateResult::status)
      .def_readonly("accepted", &UpdateResult::accepted)
      .def_readonly("rejected", &UpdateResult::rejected)
      .def_readonly("failed", &UpdateResult::failed)
      .def_readonly("nis", &UpdateResult::nis)
      .def_readonly("dof", &UpdateResult::dof);
  s.def("nav_error", &nav_error, py::arg("estimate"), py::arg("truth"),
        "Error state dx (15) of truth against estimate");
  s.def("nees", &nees, py::arg("estimate"), py::arg("covariance"), py::arg("truth"));
  s.attr("N_STATES") = kNavStates;
  s.attr("MAX_LANDMARKS_PER_FRAME") = kMaxLandmarksPerFrame;

  py::class_<NavigationFilter>(s, "NavigationFilter",
                               "Joint error-state EKF (translation, attitude, IMU biases)")
      .def(py::init<std::shared_ptr<const dynamics::ProximityModel>, std::shared_ptr<const RayCaster>,
                    std::vector<Landmark>, const FilterSettings&>(),
           py::arg("model"), py::arg("caster"), py::arg("landmarks"), py::arg("settings"))
      .def("initialize", &NavigationFilter::initialize, py::arg("x0"), py::arg("P0"))
      .def("propagate", &NavigationFilter::propagate, py::arg("t_to"), py::arg("imu"))
      .def("add_process_noise", &NavigationFilter::add_process_noise, py::arg("Q"))
      .def("update_altimeter", &NavigationFilter::update_altimeter, py::arg("measurement"))
      .def("update_camera", &NavigationFilter::update_camera, py::arg("frame"))
      .def("update_star_tracker", &NavigationFilter::update_star_tracker, py::arg("measurement"))
      .def_property_readonly("state", &NavigationFilter::state)
      .def_property_readonly("covariance", &NavigationFilter::covariance)
      .def_property_readonly("omega_BL_B", &NavigationFilter::omega_BL_B)
      .def_property_readonly("initialized", &NavigationFilter::initialized)
      .def_property_readonly("gravity_evaluations", &NavigationFilter::gravity_evaluations)
      .def_property_readonly("gravity_expansion_error", &NavigationFilter::gravity_expansion_error)
      .def("model_state", &NavigationFilter::model_state, py::arg("phi_ref"))
      .def("model_covariance", &NavigationFilter::model_covariance, py::arg("phi_ref"))
      .def(
          "predict_pixel",
          [](const NavigationFilter& f, int landmark) {
            Eigen::Vector2d p = Eigen::Vector2d::Zero();
            Eigen::Matrix<double, 2, kNavStates> H = Eigen::Matrix<double, 2, kNavStates>::Zero();
            const bool ok = f.predict_pixel(landmark, p, &H);
            return py::make_tuple(ok, p, H);
          },
          py::arg("landmark"), "(ok, pixel (2,), H (2, 15))")
      .def(
          "predict_range",
          [](const NavigationFilter& f) {
            double r = 0.0;
            Eigen::Matrix<double, 1, kNavStates> H = Eigen::Matrix<double, 1, kNavStates>::Zero();
            const bool ok = f.predict_range(r, &H);
            return py::make_tuple(ok, r, H);
          },
          "(ok, range m, H (1, 15))")
      .def_property_readonly("settings", &NavigationFilter::settings);
  bind_named_enum<Sensor>(s, "Sensor", "The four sensors, in the order of NavigationStep's per-sensor lists");
  bind_named_enum<NavigationStatus>(s, "NavigationStatus", "Outcome of a navigation call");
  s.attr("N_SENSORS") = kSensors;
  bind_named_enum<SensorFaultKind>(s, "SensorFaultKind", "Kinds of injected sensor fault (nav/faults.hpp)");
  bind_named_enum<NavFault>(s, "NavFault", "A detection of the navigation step (nav/faults.hpp)");
  s.attr("N_NAV_FAULTS") = kNavFaults;
  s.attr("MAX_SENSOR_FAULTS") = kMaxSensorFaults;
  py::class_<SensorFault>(s, "SensorFault", "One injected sensor fault over [t_start, t_start + duration)")
      .def(py::init<>())
      .def_readwrite("kind", &SensorFault::kind)
      .def_readwrite("t_start", &SensorFault::t_start, "onset (s)")
      .def_readwrite("duration", &SensorFault::duration, "how long (s), > 0 (inf: to the end)")
      .def_readwrite("magnitude", &SensorFault::magnitude,
                     "size in the kind's unit: px, m, rad/s, m/s^2 or 1 (a scale step)")
      .def_readwrite("axis_B", &SensorFault::axis_B, "direction of a bias step in B")
      .def("active", &SensorFault::active, py::arg("t"))
      .def("validate", &SensorFault::validate);
  py::class_<FaultDetectionSettings>(s, "FaultDetectionSettings", "The navigation step's fault detection")
      .def(py::init<>())
      .def_readwrite("enabled", &FaultDetectionSettings::enabled)
      .def_readwrite("exclude", &FaultDetectionSettings::exclude)
      .def_readwrite("false_alarm_probability", &FaultDetectionSettings::false_alarm_probability)
      .def_readwrite("persistence", &FaultDetectionSettings::persistence)
      .def_readwrite("outage_time", &FaultDetectionSettings::outage_time, "(s)")
      .def_readwrite("max_position_sigma", &FaultDetectionSettings::max_position_sigma, "(m)")
      .def("validate", &FaultDetectionSettings::validate);
  s.def("chi_square_upper_quantile", &chi_square_upper_quantile, py::arg("q"), py::arg("dof"),
        "x with P(X > x) = q for a chi-square X with dof degrees of freedom");
  s.def("chi_square_upper_tail", &chi_square_upper_tail, py::arg("x"), py::arg("dof"),
        "P(X > x) for a chi-square X with dof degrees of freedom");
  py::class_<NavigationSettings> navigation(
      s, "NavigationSettings", "True sensors, the filter (its model of them), initial and per-period sigmas");
  navigation.def(py::init<>()).def("validate", &NavigationSettings::validate);
  bind_fields(navigation);
  py::class_<NavigationStep>(s, "NavigationStep", "Result of one navigation call (a copy)")
      .def_readonly("status", &NavigationStep::status)
      .def_readonly("t", &NavigationStep::t)
      .def_readonly("x_hat", &NavigationStep::x_hat)
      .def_readonly("P_x", &NavigationStep::P_x)
      .def_readonly("estimate", &NavigationStep::estimate)
      .def_readonly("covariance", &NavigationStep::covariance)
      .def_property_readonly("sensor_status",
                             [](const NavigationStep& r) {
                               return std::vector<SensorStatus>(r.sensor_status.begin(),
                                                                r.sensor_status.end());
                             })
      .def_readonly("samples", &NavigationStep::samples)
      .def_readonly("ok", &NavigationStep::ok)
      .def_readonly("accepted", &NavigationStep::accepted)
      .def_readonly("rejected", &NavigationStep::rejected)
      .def_readonly("landmarks_visible", &NavigationStep::landmarks_visible)
      .def_readonly("filter_status", &NavigationStep::filter_status)
      .def_readonly("nis", &NavigationStep::nis)
      .def_readonly("nis_dof", &NavigationStep::nis_dof)
      .def_readonly("time_sensors", &NavigationStep::time_sensors)
      .def_readonly("time_filter", &NavigationStep::time_filter)
      .def_readonly("gravity_evaluations", &NavigationStep::gravity_evaluations)
      .def_readonly("fault_detected", &NavigationStep::fault_detected)
      .def_property_readonly(
          "fault_cause", [](const NavigationStep& r) { return std::string(to_string(r.fault_cause)); },
          "the first detection's name (\"none\" while fault_detected is false)")
      .def_readonly("detected_at", &NavigationStep::detected_at)
      .def_readonly("excluded", &NavigationStep::excluded)
      .def_readonly("failed", &NavigationStep::failed);
  py::class_<NavigationSystem>(s, "NavigationSystem",
                               "The sensors and the filter of a run: one call per control period")
      .def(py::init<std::shared_ptr<const dynamics::ProximityModel>, std::shared_ptr<const RayCaster>,
                    std::shared_ptr<const RayCaster>, std::vector<Landmark>, const NavigationSettings&,
                    std::uint64_t>(),
           py::arg("model"), py::arg("sensor_caster"), py::arg("filter_caster"), py::arg("landmarks"),
           py::arg("settings"), py::arg("seed"))
      .def("initialize", &NavigationSystem::initialize, py::arg("t0"), py::arg("truth"),
           py::arg("accel_nongrav_L"), py::arg("phi_ref"), py::return_value_policy::copy)
      .def(
          "step",
          [](NavigationSystem& n, const Eigen::Ref<const Eigen::VectorXd>& t,
             const Eigen::Ref<const Rows13>& truth, const Eigen::Ref<const Rows3>& a,
             const Eigen::Vector3d& phi_ref) { return n.step(t, truth, a, phi_ref); },
          py::arg("t"), py::arg("truth"), py::arg("accel_nongrav_L"), py::arg("phi_ref"),
          "One control period from the truth samples (n,), (n, 13), (n, 3); returns a copy")
      .def_property_readonly("filter", &NavigationSystem::filter, py::return_value_policy::reference_internal)
      .def_property_readonly("imu", &NavigationSystem::imu, py::return_value_policy::reference_internal)
      .def_property_readonly("settings", &NavigationSystem::settings)
      .def_property_readonly("base_period", &NavigationSystem::base_period)
      .def("set_faults", &NavigationSystem::set_faults, py::arg("faults"), py::arg("detection"))
      .def_property_readonly("fault_detection", &NavigationSystem::fault_detection)
      .def(
          "nis_threshold",
          [](const NavigationSystem& n, int dof) {
            if (dof < 1 || dof > kMaxNisDof)
              throw std::invalid_argument("nis_threshold: dof must be in [1, " + std::to_string(kMaxNisDof) +
                                          "]");
            return n.nis_threshold(dof);
          },
          py::arg("dof"), "the NIS test's threshold for a sample of dof degrees of freedom");
}

}  // namespace tubempc::python
