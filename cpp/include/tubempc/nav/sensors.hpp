/// @file sensors.hpp
/// The spacecraft's navigation sensors (docs/model.md, "Navigation"): a laser altimeter, a navigation
/// camera observing surface landmarks, an IMU (accelerometer and gyro) and a star tracker. Each has
/// its `Settings` (noise, bias, sample period, limits, dropout probability; SI units, in-class
/// defaults, `validate()`), its own seeded `Random` stream and returns a `SensorStatus` per
/// measurement; `measure` never throws and never allocates. Frames: L (orbital), A (asteroid), B
/// (spacecraft), C (camera: z_C the boresight, x_C along the image's rows, y_C along its columns).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "tubempc/core/fields.hpp"
#include "tubempc/math/so3.hpp"
#include "tubempc/nav/random.hpp"
#include "tubempc/nav/ray_caster.hpp"

namespace tubempc::nav {

/// Outcome of one measurement.
enum class SensorStatus {
  Ok,                 ///< a measurement was produced
  Dropout,            ///< the sample was lost (random, with the sensor's dropout probability)
  OutOfRange,         ///< the altimeter's beam meets no surface within [min_range, max_range]
  NoLandmarkVisible,  ///< no landmark passes the camera's visibility tests
  InvalidInput,       ///< the true state given to the sensor is not finite
  Failed,             ///< an injected fault: the sensor gives no output (nav/faults.hpp)
};
/// Name of a sensor status.
/// @param s the status.
/// @return its name ("ok", "dropout", "out_of_range", "no_landmark_visible", "invalid_input", "failed").
const char* to_string(SensorStatus s);

/// The true state the sensors observe at one instant.
struct SensorTruth {
  double t{0.0};                                        ///< time (s)
  Eigen::Vector3d r_L{Eigen::Vector3d::Zero()};         ///< position in L (m)
  math::Quaternion q_BL{0.0, 0.0, 0.0, 1.0};            ///< attitude q_B/L (R(q_B/L) = C_LB), unit
  Eigen::Vector3d omega_BL_B{Eigen::Vector3d::Zero()};  ///< angular velocity of B relative to L, in B (rad/s)
  Eigen::Vector3d omega_LI_L{
      Eigen::Vector3d::Zero()};  ///< angular velocity of L relative to I, in L: n z_L (rad/s)
  Eigen::Vector3d accel_nongrav_L{
      Eigen::Vector3d::Zero()};  ///< non-gravitational acceleration (thrust, SRP) in L (m/s^2)
  Eigen::Matrix3d C_AL{Eigen::Matrix3d::Identity()};  ///< rotation from L to A at t (r_A = C_AL r_L)
};

/// Laser altimeter settings.
struct AltimeterSettings {
  Eigen::Vector3d boresight_B{0.0, 0.0, 1.0};  ///< beam direction in B (normalised on use), non-zero
  double sigma{0.05};                          ///< range noise standard deviation (m), >= 0
  double bias{0.0};                            ///< constant range bias (m), finite (not estimated)
  double min_range{1.0};                       ///< shortest range measured (m), >= 0
  double max_range{1000.0};                    ///< longest range measured (m), > min_range
  double period{1.0};                          ///< sample period (s), > 0
  double dropout_probability{0.0};             ///< probability that a sample is lost, in [0, 1]
  /// @throws std::invalid_argument naming the first bad field ("altimeter.<field>").
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// One altimeter sample.
struct AltimeterMeasurement {
  double t{0.0};                          ///< sample time (s)
  SensorStatus status{SensorStatus::Ok};  ///< outcome; `range` is valid only for Ok
  double range{0.0};                      ///< measured range along the boresight (m)
};

/// Laser altimeter: the range from the spacecraft's centre of mass along a beam fixed in B to the
/// first face of the shape model, rho = |hit - r| + bias + sigma N(0, 1).
class Altimeter {
 public:
  /// @param caster   ray caster on the shape model (frame A), non-null.
  /// @param settings validated here.
  /// @param seed     seed of the noise stream.
  /// @throws std::invalid_argument for a null caster or bad settings.
  Altimeter(std::shared_ptr<const RayCaster> caster, const AltimeterSettings& settings, std::uint64_t seed);
  /// The noise-free range and the face hit.
  /// @param r_A         position in A (m).
  /// @param boresight_A beam direction in A.
  /// @param max_range   longest range searched (m).
  /// @return the ray's first hit (no hit beyond max_range).
  RayHit true_range(const Eigen::Vector3d& r_A, const Eigen::Vector3d& boresight_A, double max_range) const;
  /// Takes one sample.
  /// @param truth the true state.
  /// @param out   receives the sample (time, status, range).
  /// @return out.status.
  SensorStatus measure(const SensorTruth& truth, AltimeterMeasurement& out) noexcept;
  /// @return the settings.
  const AltimeterSettings& settings() const { return settings_; }
  /// @return the ray caster.
  const RayCaster& caster() const { return *caster_; }

 private:
  std::shared_ptr<const RayCaster> caster_;
  AltimeterSettings settings_;
  Eigen::Vector3d boresight_B_;
  Random rng_;
};

/// A surface landmark, fixed on the asteroid.
struct Landmark {
  Eigen::Vector3d p_A{Eigen::Vector3d::Zero()};        ///< position in A (m)
  Eigen::Vector3d normal_A{Eigen::Vector3d::UnitZ()};  ///< unit outward normal of its face in A
  Eigen::Index face{-1};                               ///< the face it lies on (0-based)
};

/// The landmark catalogue: surface points seen from n directions spread evenly over the sphere (a
/// Fibonacci lattice u_i), each the first hit of a ray cast inwards from outside the body along -u_i;
/// points on a face already taken are dropped. Deterministic.
/// @param caster ray caster on the shape model.
/// @param count  number of directions, >= 1.
/// @return the landmarks (at most count), in lattice order.
/// @throws std::invalid_argument for count < 1.
std::vector<Landmark> generate_landmarks(const RayCaster& caster, int count);

/// Most landmarks one camera frame can hold (the fixed capacity of CameraFrame).
inline constexpr int kMaxLandmarksPerFrame = 64;

/// Navigation camera settings (pinhole model).
struct CameraSettings {
  double focal_length_px{1500.0};                       ///< focal length (pixels), > 0
  int width_px{1024};                                   ///< image width (pixels, along x_C), >= 1
  int height_px{1024};                                  ///< image height (pixels, along y_C), >= 1
  double pixel_sigma{0.5};                              ///< pixel noise standard deviation (pixels), >= 0
  Eigen::Vector2d pixel_bias{Eigen::Vector2d::Zero()};  ///< constant pixel bias (pixels; not estimated)
  Eigen::Matrix3d C_BC{Eigen::Matrix3d::Identity()};    ///< camera axes in B (v_B = C_BC v_C), a rotation
  double max_emission_angle{
      1.2217304763960306};  ///< largest angle between normal and view (rad, 70 deg), in (0, pi/2]
  /// Largest Sun incidence angle (rad, default 80 deg), in (0, pi]; pi: no illumination test (a
  /// sensor that needs no sunlight: a thermal-infrared camera or a flash lidar).
  double max_incidence_angle{1.3962634015954636};
  double min_range{1.0};            ///< nearest landmark observed (m), >= 0
  double max_range{5000.0};         ///< farthest landmark observed (m), > min_range
  int max_landmarks{16};            ///< most landmarks per frame, in [1, kMaxLandmarksPerFrame]
  double period{2.0};               ///< frame period (s), > 0
  double dropout_probability{0.0};  ///< probability that a frame is lost, in [0, 1]
  /// @throws std::invalid_argument naming the first bad field ("camera.<field>").
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
  /// Focal length that gives a horizontal field of view.
  /// @param fov_rad  full horizontal field of view (rad), in (0, pi).
  /// @param width_px image width (pixels).
  /// @return width_px / (2 tan(fov_rad / 2)) (pixels).
  static double focal_length_from_fov(double fov_rad, int width_px);
};

/// One landmark's pixel coordinates.
struct LandmarkObservation {
  int landmark{-1};                                ///< index into the catalogue
  Eigen::Vector2d pixel{Eigen::Vector2d::Zero()};  ///< measured pixel coordinates (u, v) (pixels)
};

/// One camera frame with a fixed capacity.
struct CameraFrame {
  double t{0.0};                                                        ///< frame time (s)
  SensorStatus status{SensorStatus::Ok};                                ///< outcome; count > 0 only for Ok
  int count{0};                                                         ///< observations held
  std::array<LandmarkObservation, kMaxLandmarksPerFrame> observations;  ///< the first `count` are valid
};

/// Navigation camera: a pinhole camera fixed in B observing the landmark catalogue. A landmark is
/// observed when it projects inside the image, lies within [min_range, max_range], faces the camera
/// (emission angle), is lit (Sun incidence angle; the Sun is along -x_L) and no face lies between it
/// and the camera (ray cast). Pixel (u, v) = (c_x + f x_C / z_C, c_y + f y_C / z_C) + bias + noise with
/// c = (width, height) / 2.
class NavCamera {
 public:
  /// @param caster    ray caster on the shape model, non-null.
  /// @param landmarks the catalogue (frame A), copied.
  /// @param settings  validated here.
  /// @param seed      seed of the noise stream.
  /// @throws std::invalid_argument for a null caster, an empty catalogue or bad settings.
  NavCamera(std::shared_ptr<const RayCaster> caster, std::vector<Landmark> landmarks,
            const CameraSettings& settings, std::uint64_t seed);
  /// Pinhole projection without noise or bias.
  /// @param s_C   landmark relative to the camera, in C (m).
  /// @param pixel receives (u, v) (pixels).
  /// @return whether s_C is in front of the camera (z_C > 0) and projects inside the image.
  bool project(const Eigen::Vector3d& s_C, Eigen::Vector2d& pixel) const;
  /// Whether landmark i passes every visibility test (geometry and light, without dropout).
  /// @param i     catalogue index.
  /// @param truth the true state.
  /// @param pixel receives its noise-free pixel coordinates when visible.
  /// @return true when visible (false for an index out of range or a non-finite state).
  bool visible(int i, const SensorTruth& truth, Eigen::Vector2d& pixel) const;
  /// Takes one frame: the first max_landmarks visible landmarks in catalogue order.
  /// @param truth the true state.
  /// @param out   receives the frame.
  /// @return out.status.
  SensorStatus measure(const SensorTruth& truth, CameraFrame& out) noexcept;
  /// @return the settings.
  const CameraSettings& settings() const { return settings_; }
  /// @return the landmark catalogue (frame A).
  const std::vector<Landmark>& landmarks() const { return landmarks_; }

 private:
  // Visibility of landmark i from r_A, with C_CA = C_CB C_BL C_LA and the Sun's direction in A.
  bool visible_from(int i, const Eigen::Vector3d& r_A, const Eigen::Matrix3d& C_CA,
                    const Eigen::Vector3d& sun_A, Eigen::Vector2d& pixel) const;

  std::shared_ptr<const RayCaster> caster_;
  std::vector<Landmark> landmarks_;
  CameraSettings settings_;
  double cos_emission_{0.0}, cos_incidence_{0.0};
  Random rng_;
};

/// IMU settings: white noise given as densities (continuous-time), biases as an initial random draw
/// plus a random walk. A sample's noise is the density over sqrt(period) (the mean over the period).
struct ImuSettings {
  double period{0.1};                  ///< sample period (s), > 0
  double gyro_noise_density{1e-6};     ///< gyro angle random walk (rad/s/sqrt(Hz)), >= 0
  double gyro_bias_sigma{1e-5};        ///< standard deviation of the initial gyro bias (rad/s), >= 0
  double gyro_bias_random_walk{1e-8};  ///< gyro bias random walk (rad/s^2/sqrt(Hz)), >= 0
  double accel_noise_density{1e-6};    ///< accelerometer velocity random walk (m/s^2/sqrt(Hz)), >= 0
  double accel_bias_sigma{1e-5};       ///< standard deviation of the initial accelerometer bias (m/s^2), >= 0
  double accel_bias_random_walk{1e-8};  ///< accelerometer bias random walk (m/s^3/sqrt(Hz)), >= 0
  double dropout_probability{0.0};      ///< probability that a sample is lost, in [0, 1]
  /// @throws std::invalid_argument naming the first bad field ("imu.<field>").
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// One IMU sample.
struct ImuSample {
  double t{0.0};                          ///< sample time (s)
  SensorStatus status{SensorStatus::Ok};  ///< outcome; the vectors are valid only for Ok
  Eigen::Vector3d specific_force_B{
      Eigen::Vector3d::Zero()};  ///< accelerometer: non-gravitational acceleration in B (m/s^2)
  Eigen::Vector3d omega_BI_B{
      Eigen::Vector3d::Zero()};  ///< gyro: angular velocity of B relative to I, in B (rad/s)
};

/// IMU: f_B = C_BL a_ng_L + b_a + noise (the accelerometer senses no gravity, the Sun's included) and
/// omega_BI_B = omega_BL_B + C_BL omega_LI_L + b_g + noise (the gyro senses the inertial rate).
class Imu {
 public:
  /// Draws the initial biases from the seed.
  /// @param settings validated here.
  /// @param seed     seed of the noise stream.
  /// @throws std::invalid_argument for bad settings.
  Imu(const ImuSettings& settings, std::uint64_t seed);
  /// Takes one sample, then advances the biases' random walk by one period.
  /// @param truth the true state.
  /// @param out   receives the sample.
  /// @return out.status.
  SensorStatus measure(const SensorTruth& truth, ImuSample& out) noexcept;
  /// @return the current true gyro bias b_g in B (rad/s).
  const Eigen::Vector3d& gyro_bias() const { return b_g_; }
  /// @return the current true accelerometer bias b_a in B (m/s^2).
  const Eigen::Vector3d& accel_bias() const { return b_a_; }
  /// @return the settings.
  const ImuSettings& settings() const { return settings_; }

 private:
  ImuSettings settings_;
  Random rng_;
  Eigen::Vector3d b_g_, b_a_;
};

/// Star tracker settings.
struct StarTrackerSettings {
  double period{1.0};                                       ///< sample period (s), > 0
  Eigen::Vector3d sigma_B{2e-5, 2e-5, 1e-4};                ///< attitude noise per B axis (rad), >= 0
  Eigen::Vector3d misalignment_B{Eigen::Vector3d::Zero()};  ///< constant rotation error (rad; not estimated)
  double dropout_probability{0.0};                          ///< probability that a sample is lost, in [0, 1]
  /// @throws std::invalid_argument naming the first bad field ("star_tracker.<field>").
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// One star tracker sample.
struct StarTrackerMeasurement {
  double t{0.0};                              ///< sample time (s)
  SensorStatus status{SensorStatus::Ok};      ///< outcome; q_BL is valid only for Ok
  math::Quaternion q_BL{0.0, 0.0, 0.0, 1.0};  ///< measured q_B/L (unit)
};

/// Star tracker: q_meas = q_B/L (x) exp(misalignment_B + sigma_B .* N(0, I)). The tracker measures
/// the attitude relative to I; L's attitude relative to I is known on board (ephemeris), so it is
/// reported relative to L.
class StarTracker {
 public:
  /// @param settings validated here.
  /// @param seed     seed of the noise stream.
  /// @throws std::invalid_argument for bad settings.
  StarTracker(const StarTrackerSettings& settings, std::uint64_t seed);
  /// Takes one sample.
  /// @param truth the true state.
  /// @param out   receives the sample.
  /// @return out.status.
  SensorStatus measure(const SensorTruth& truth, StarTrackerMeasurement& out) noexcept;
  /// @return the settings.
  const StarTrackerSettings& settings() const { return settings_; }

 private:
  StarTrackerSettings settings_;
  Random rng_;
};

}  // namespace tubempc::nav

namespace tubempc::core {

/// Names of nav::SensorStatus.
template <>
struct EnumNames<nav::SensorStatus> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<nav::SensorStatus>, 6> values{
      {{nav::SensorStatus::Ok, "Ok", "ok"},
       {nav::SensorStatus::Dropout, "Dropout", "dropout"},
       {nav::SensorStatus::OutOfRange, "OutOfRange", "out_of_range"},
       {nav::SensorStatus::NoLandmarkVisible, "NoLandmarkVisible", "no_landmark_visible"},
       {nav::SensorStatus::InvalidInput, "InvalidInput", "invalid_input"},
       {nav::SensorStatus::Failed, "Failed", "failed"}}};
};

}  // namespace tubempc::core

namespace tubempc::nav {

// The table of AltimeterSettings::for_each_field.
template <typename V>
void AltimeterSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = AltimeterSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, three = Dim::Three;
  visit(FieldInfo{"boresight_B", "", req, finite, three, one,
                  "beam direction in B (normalised on use), non-zero"},
        &S::boresight_B);
  visit(FieldInfo{"sigma", "m", req, finite, one, one, "range noise standard deviation (m), >= 0"},
        &S::sigma);
  visit(FieldInfo{"bias", "m", req, finite, one, one, "constant range bias (m; not estimated)"}, &S::bias);
  visit(FieldInfo{"min_range", "m", req, finite, one, one, "shortest range measured (m), >= 0"},
        &S::min_range);
  visit(FieldInfo{"max_range", "m", req, finite, one, one, "longest range measured (m), > min_range"},
        &S::max_range);
  visit(FieldInfo{"period", "s", req, finite, one, one, "sample period (s), > 0"}, &S::period);
  visit(FieldInfo{"dropout_probability", "", req, finite, one, one,
                  "probability that a sample is lost, in [0, 1]"},
        &S::dropout_probability);
}

// The table of CameraSettings::for_each_field.
template <typename V>
void CameraSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = CameraSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, two = Dim::Two, three = Dim::Three;
  visit(FieldInfo{"focal_length_px", "px", req, finite, one, one, "focal length (pixels), > 0"},
        &S::focal_length_px);
  visit(FieldInfo{"width_px", "px", req, finite, one, one, "image width (pixels, along x_C), >= 1"},
        &S::width_px);
  visit(FieldInfo{"height_px", "px", req, finite, one, one, "image height (pixels, along y_C), >= 1"},
        &S::height_px);
  visit(
      FieldInfo{"pixel_sigma", "px", req, finite, one, one, "pixel noise standard deviation (pixels), >= 0"},
      &S::pixel_sigma);
  visit(FieldInfo{"pixel_bias", "px", req, finite, two, one, "constant pixel bias (pixels; not estimated)"},
        &S::pixel_bias);
  visit(FieldInfo{"C_BC", "", req, finite, three, three, "camera axes in B (v_B = C_BC v_C), a rotation"},
        &S::C_BC);
  visit(FieldInfo{"max_emission_angle", "rad", req, finite, one, one,
                  "largest angle between normal and view (rad), in (0, pi/2]"},
        &S::max_emission_angle);
  visit(FieldInfo{"max_incidence_angle", "rad", req, finite, one, one,
                  "largest Sun incidence angle (rad), in (0, pi]; pi: no illumination test"},
        &S::max_incidence_angle);
  visit(FieldInfo{"min_range", "m", req, finite, one, one, "nearest landmark observed (m), >= 0"},
        &S::min_range);
  visit(FieldInfo{"max_range", "m", req, finite, one, one, "farthest landmark observed (m), > min_range"},
        &S::max_range);
  visit(FieldInfo{"max_landmarks", "", req, finite, one, one, "most landmarks per frame, in [1, 64]"},
        &S::max_landmarks);
  visit(FieldInfo{"period", "s", req, finite, one, one, "frame period (s), > 0"}, &S::period);
  visit(FieldInfo{"dropout_probability", "", req, finite, one, one,
                  "probability that a frame is lost, in [0, 1]"},
        &S::dropout_probability);
}

// The table of ImuSettings::for_each_field.
template <typename V>
void ImuSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = ImuSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One;
  visit(FieldInfo{"period", "s", req, finite, one, one, "sample period (s), > 0"}, &S::period);
  visit(FieldInfo{"gyro_noise_density", "rad/s/sqrt(Hz)", req, finite, one, one,
                  "gyro angle random walk (rad/s/sqrt(Hz)), >= 0"},
        &S::gyro_noise_density);
  visit(FieldInfo{"gyro_bias_sigma", "rad/s", req, finite, one, one,
                  "standard deviation of the initial gyro bias (rad/s), >= 0"},
        &S::gyro_bias_sigma);
  visit(FieldInfo{"gyro_bias_random_walk", "rad/s^2/sqrt(Hz)", req, finite, one, one,
                  "gyro bias random walk (rad/s^2/sqrt(Hz)), >= 0"},
        &S::gyro_bias_random_walk);
  visit(FieldInfo{"accel_noise_density", "m/s^2/sqrt(Hz)", req, finite, one, one,
                  "accelerometer velocity random walk (m/s^2/sqrt(Hz)), >= 0"},
        &S::accel_noise_density);
  visit(FieldInfo{"accel_bias_sigma", "m/s^2", req, finite, one, one,
                  "standard deviation of the initial accelerometer bias (m/s^2), >= 0"},
        &S::accel_bias_sigma);
  visit(FieldInfo{"accel_bias_random_walk", "m/s^3/sqrt(Hz)", req, finite, one, one,
                  "accelerometer bias random walk (m/s^3/sqrt(Hz)), >= 0"},
        &S::accel_bias_random_walk);
  visit(FieldInfo{"dropout_probability", "", req, finite, one, one,
                  "probability that a sample is lost, in [0, 1]"},
        &S::dropout_probability);
}

// The table of StarTrackerSettings::for_each_field.
template <typename V>
void StarTrackerSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = StarTrackerSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, three = Dim::Three;
  visit(FieldInfo{"period", "s", req, finite, one, one, "sample period (s), > 0"}, &S::period);
  visit(FieldInfo{"sigma_B", "rad", req, finite, three, one, "attitude noise per B axis (rad), >= 0"},
        &S::sigma_B);
  visit(FieldInfo{"misalignment_B", "rad", req, finite, three, one,
                  "constant rotation error, a rotation vector (rad; not estimated)"},
        &S::misalignment_B);
  visit(FieldInfo{"dropout_probability", "", req, finite, one, one,
                  "probability that a sample is lost, in [0, 1]"},
        &S::dropout_probability);
}

}  // namespace tubempc::nav
