/// @file faults.hpp
/// Sensor faults and their detection in the navigation step (docs/model.md M49-M50; issue #43).
///
/// Injection (M49): a `SensorFault` is a failure of one sensor over [t_start, t_start + duration),
/// applied by NavigationSystem to the sensor's output where the fault physically is: a blind camera
/// or a lost star tracker or altimeter return gives no sample (status `SensorStatus::Failed`), a
/// landmark outlier shifts one landmark's pixel, a mismatch swaps two landmarks' identities, an
/// altimeter spike adds to the range, an IMU bias step adds to the gyro's rate or the accelerometer's
/// specific force, an IMU scale step multiplies them. The sensors' noise streams are drawn as without
/// the fault (the fault-free run's draws are unchanged).
///
/// Detection (M50), allocation-free, in every navigation call:
/// - per aiding sensor (altimeter, camera, star tracker), a sample fails when its accepted
///   measurements' NIS exceeds the chi-square quantile of probability 1 - false_alarm_probability for
///   its degrees of freedom, or when the filter's per-measurement gate refused all of them; a sensor
///   whose samples fail `persistence` times in a row is declared faulty and, with `exclude`, no longer
///   folded in (a landmark refused by the gate alone is an outlier rejected individually, not a fault);
/// - when a second aiding sensor is declared faulty while another one is (or fails in the same
///   window), the common cause is the propagation: an IMU fault (the sensor is then not excluded);
/// - a sensor without an Ok sample for `outage_time` is in outage;
/// - the position's standard deviation sqrt(trace P_rr) beyond `max_position_sigma` is covariance growth.
/// Each detection is a named `NavFault` with its time; the first is the run's fault cause.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <limits>

#include "tubempc/core/fields.hpp"

namespace tubempc::nav {

/// Kinds of injected sensor fault.
enum class SensorFaultKind {
  CameraOutage,      ///< the camera gives no frame (blind)
  LandmarkOutlier,   ///< the first landmark of each frame is shifted by `magnitude` pixels along u
  LandmarkMismatch,  ///< the first two landmarks of each frame swap identities (a wrong match)
  AltimeterDropout,  ///< the altimeter gives no range
  AltimeterSpike,    ///< the range is off by `magnitude` metres
  GyroBiasStep,      ///< the gyro's rate gains `magnitude` rad/s along axis_B
  AccelBiasStep,     ///< the accelerometer's specific force gains `magnitude` m/s^2 along axis_B
  GyroScaleStep,     ///< the gyro's rate is multiplied by 1 + magnitude
  AccelScaleStep,    ///< the specific force is multiplied by 1 + magnitude
  StarTrackerLoss,   ///< the star tracker gives no attitude
};
/// Name of a sensor fault kind.
/// @param k the kind.
/// @return "camera_outage", "landmark_outlier", ..., "star_tracker_loss".
const char* to_string(SensorFaultKind k);

/// One injected sensor fault.
struct SensorFault {
  SensorFaultKind kind{SensorFaultKind::CameraOutage};       ///< what fails
  double t_start{0.0};                                       ///< onset (s), finite
  double duration{std::numeric_limits<double>::infinity()};  ///< how long (s), > 0 (inf: to the end)
  /// Size, in the kind's unit: px (outlier), m (spike), rad/s (gyro bias), m/s^2 (accel bias), 1 (scale);
  /// finite; unused by outages, dropouts, losses and mismatches.
  double magnitude{0.0};
  Eigen::Vector3d axis_B{Eigen::Vector3d::UnitX()};  ///< direction of a bias step in B (normalised), non-zero
  /// @param t time (s).
  /// @return whether the fault acts at t.
  bool active(double t) const noexcept { return t >= t_start && t - t_start < duration; }
  /// @throws std::invalid_argument naming the bad field ("faults.<field>").
  void validate() const;
};

/// Most injected sensor faults of one run.
inline constexpr int kMaxSensorFaults = 8;

/// Fault detection settings.
struct FaultDetectionSettings {
  bool enabled{true};  ///< run the detection (false: no status is ever raised)
  bool exclude{true};  ///< a sensor declared faulty is no longer folded in
  /// Probability that one fault-free sample of a sensor fails its NIS test, in (0, 1): the test's
  /// threshold is the chi-square quantile of 1 - this for the sample's degrees of freedom.
  double false_alarm_probability{1e-3};
  int persistence{3};        ///< failed samples in a row that declare a sensor faulty, >= 1
  double outage_time{10.0};  ///< longest time without an Ok sample before an outage is declared (s), > 0
  double max_position_sigma{std::numeric_limits<double>::infinity()};  ///< bound on sqrt(trace P_rr) (m), > 0
  /// @throws std::invalid_argument naming the bad field ("faults.<field>").
  void validate() const;
};

/// A detection: what the navigation step declared.
enum class NavFault {
  None,               ///< nothing detected
  AltimeterFault,     ///< the altimeter's innovations failed repeatedly (excluded)
  CameraFault,        ///< the camera's frames failed repeatedly (excluded)
  StarTrackerFault,   ///< the star tracker's innovations failed repeatedly (excluded)
  ImuFault,           ///< two aiding sensors failed together: the propagation (IMU) is at fault
  AltimeterOutage,    ///< no altimeter range for outage_time
  CameraOutage,       ///< no camera frame with a landmark for outage_time
  StarTrackerOutage,  ///< no star tracker attitude for outage_time
  CovarianceGrowth,   ///< the position's standard deviation beyond max_position_sigma
};
/// Number of NavFault values (the size of NavigationStep::detected_at).
inline constexpr int kNavFaults = 9;
/// Name of a detection.
/// @param f the detection.
/// @return "none", "altimeter_fault", ..., "covariance_growth".
const char* to_string(NavFault f);

/// Largest degrees of freedom of one sample's NIS (a full camera frame: 2 per landmark).
inline constexpr int kMaxNisDof = 128;

/// The chi-square quantile: x with P(X > x) = q for X chi-square with `dof` degrees of freedom
/// (regularised incomplete gamma function, bisection to 1e-12 relative). Set-up use.
/// @param q   upper-tail probability, in (0, 1).
/// @param dof degrees of freedom, >= 1.
/// @return the quantile.
/// @throws std::invalid_argument for q outside (0, 1) or dof < 1.
double chi_square_upper_quantile(double q, int dof);

/// The upper-tail probability P(X > x) of a chi-square with `dof` degrees of freedom.
/// @param x   value, >= 0.
/// @param dof degrees of freedom, >= 1.
/// @return Q(dof / 2, x / 2).
double chi_square_upper_tail(double x, int dof);

}  // namespace tubempc::nav

namespace tubempc::core {

/// Names of nav::SensorFaultKind.
template <>
struct EnumNames<nav::SensorFaultKind> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<nav::SensorFaultKind>, 10> values{
      {{nav::SensorFaultKind::CameraOutage, "CameraOutage", "camera_outage"},
       {nav::SensorFaultKind::LandmarkOutlier, "LandmarkOutlier", "landmark_outlier"},
       {nav::SensorFaultKind::LandmarkMismatch, "LandmarkMismatch", "landmark_mismatch"},
       {nav::SensorFaultKind::AltimeterDropout, "AltimeterDropout", "altimeter_dropout"},
       {nav::SensorFaultKind::AltimeterSpike, "AltimeterSpike", "altimeter_spike"},
       {nav::SensorFaultKind::GyroBiasStep, "GyroBiasStep", "gyro_bias_step"},
       {nav::SensorFaultKind::AccelBiasStep, "AccelBiasStep", "accel_bias_step"},
       {nav::SensorFaultKind::GyroScaleStep, "GyroScaleStep", "gyro_scale_step"},
       {nav::SensorFaultKind::AccelScaleStep, "AccelScaleStep", "accel_scale_step"},
       {nav::SensorFaultKind::StarTrackerLoss, "StarTrackerLoss", "star_tracker_loss"}}};
};

/// Names of nav::NavFault.
template <>
struct EnumNames<nav::NavFault> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<nav::NavFault>, 9> values{
      {{nav::NavFault::None, "None", "none"},
       {nav::NavFault::AltimeterFault, "AltimeterFault", "altimeter_fault"},
       {nav::NavFault::CameraFault, "CameraFault", "camera_fault"},
       {nav::NavFault::StarTrackerFault, "StarTrackerFault", "star_tracker_fault"},
       {nav::NavFault::ImuFault, "ImuFault", "imu_fault"},
       {nav::NavFault::AltimeterOutage, "AltimeterOutage", "altimeter_outage"},
       {nav::NavFault::CameraOutage, "CameraOutage", "camera_outage"},
       {nav::NavFault::StarTrackerOutage, "StarTrackerOutage", "star_tracker_outage"},
       {nav::NavFault::CovarianceGrowth, "CovarianceGrowth", "covariance_growth"}}};
};

}  // namespace tubempc::core
