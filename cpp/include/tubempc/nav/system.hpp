/// @file system.hpp
/// Navigation in the closed loop (docs/model.md "Output-feedback tube", M39): one object owning the four
/// sensors and the filter, and one allocation-free call per control period that samples the sensors
/// at their rates from the truth the plant hands it, propagates the filter and folds the
/// measurements in, and returns the estimate in the controller's 12-state with its covariance and
/// per-sensor statuses.
///
/// Timing: the base rate is the IMU's period h; dt (the control period) and every other sensor's
/// period are integer multiples of h. The plant propagates the truth in sub-steps of h and hands the
/// samples of one period (times t_k + h, ..., t_k + dt = t_{k+1}, the last one after the period's
/// additive disturbance) to `step`. At each sample the IMU is sampled (its specific force is the
/// non-gravitational acceleration over the sub-step ending there, as an integrating accelerometer's;
/// its rate the angular velocity at the sample), the filter is propagated to the sample's time with
/// it, and the sensors whose period divides the sample's tick are sampled and folded in. What of the
/// additive per-period disturbance (paper Eq. 16/18) no sensor senses is a process noise added at the
/// period's end (`NavigationSettings::period_noise_sigma`) before that sample's measurements: for the
/// project's plant, which adds it to the state there (a jump), on r, v and the attitude (the jump of the
/// angular velocity is read by the gyro at that sample); for Basilisk's, which applies it as forces and
/// torques over the period, on r and v (the gyro measures the torques' turn; docs/model.md M39).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "tubempc/core/fields.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/nav/faults.hpp"
#include "tubempc/nav/filter.hpp"
#include "tubempc/nav/random.hpp"
#include "tubempc/nav/sensors.hpp"

namespace tubempc::nav {

/// The four sensors, in the order of the per-sensor arrays of NavigationStep.
enum class Sensor { Altimeter = 0, Camera = 1, Imu = 2, StarTracker = 3 };
/// Number of sensors (the size of NavigationStep's per-sensor arrays).
inline constexpr int kSensors = 4;
/// Name of a sensor.
/// @param s the sensor.
/// @return "altimeter", "camera", "imu" or "star_tracker".
const char* to_string(Sensor s);

/// Settings of the navigation system: the true sensors, the filter (whose sensor settings are its
/// model of them) and the initial and per-period uncertainty.
struct NavigationSettings {
  AltimeterSettings altimeter{};       ///< the true altimeter
  CameraSettings camera{};             ///< the true camera
  ImuSettings imu{};                   ///< the true IMU; its period is the base rate h
  StarTrackerSettings star_tracker{};  ///< the true star tracker
  FilterSettings filter{};             ///< the filter, with its model of the sensors
  /// Standard deviations of the initial estimation error [r_L (m), v_L (m/s), theta (rad)], each >= 0;
  /// the biases' are the IMU's gyro_bias_sigma and accel_bias_sigma.
  Eigen::Matrix<double, 9, 1> initial_sigma =
      (Eigen::Matrix<double, 9, 1>() << 1.0, 1.0, 1.0, 0.01, 0.01, 0.01, 1e-3, 1e-3, 1e-3).finished();
  /// Standard deviations of the per-period additive disturbance as the filter models it: what of it no
  /// sensor senses [r_L (m), v_L (m/s), theta (rad)], each >= 0, added to P at every period's end.
  Eigen::Matrix<double, 9, 1> period_noise_sigma = Eigen::Matrix<double, 9, 1>::Zero();
  int max_samples{256};  ///< most samples of one period (the call's bound), >= 1
  /// @throws std::invalid_argument naming the first bad field ("navigation.<field>", or the sensor's):
  ///         also when a sensor's period is not an integer multiple of the IMU's.
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// Outcome of a navigation call.
enum class NavigationStatus {
  Ok,                ///< at least one measurement was folded in and every filter call succeeded
  PredictionOnly,    ///< no measurement was folded in (every due sensor failed or was refused): prediction
  NumericalFailure,  ///< a filter call failed for numerics (that call undone) or the estimate was not finite
  InvalidInput,      ///< non-finite truth, wrong sample times or too many samples: nothing changed
  NotInitialized,    ///< step called before initialize
};
/// Name of a navigation status.
/// @param s the status.
/// @return its name ("ok", "prediction_only", "numerical_failure", "invalid_input", "not_initialized").
const char* to_string(NavigationStatus s);

/// Result of one navigation call; storage owned by the system, overwritten by every call.
struct NavigationStep {
  NavigationStatus status{NavigationStatus::NotInitialized};  ///< outcome
  double t{0.0};                                              ///< the estimate's time (s)
  /// The estimate in the controller's state [r_L (m), v_L (m/s), phi (rad), omega_BL_B (rad/s)], finite.
  dynamics::StateVector x_hat{dynamics::StateVector::Zero()};
  dynamics::StateMatrix P_x{dynamics::StateMatrix::Identity()};  ///< covariance of x_hat's error (12 x 12)
  NavState estimate{};                                           ///< the filter's estimate
  NavCovariance covariance{NavCovariance::Identity()};           ///< the filter's covariance (15 x 15)
  /// Per sensor (Sensor order): the status of its last sample in this call (Ok if it did not sample).
  std::array<SensorStatus, kSensors> sensor_status{};
  std::array<int, kSensors> samples{};           ///< per sensor: samples taken in this call
  std::array<int, kSensors> ok{};                ///< per sensor: samples with status Ok
  std::array<int, kSensors> accepted{};          ///< per sensor: measurements folded in (camera: landmarks)
  std::array<int, kSensors> rejected{};          ///< per sensor: measurements refused by the filter
  int landmarks_visible{0};                      ///< landmarks in the last camera frame of this call
  FilterStatus filter_status{FilterStatus::Ok};  ///< the worst filter outcome of the call (Ok if none failed)
  double nis{0.0};                               ///< sum of the accepted measurements' NIS in this call
  int nis_dof{0};                                ///< its degrees of freedom
  /// Wall time of the call's sensor simulation (s): the truth side, which flight hardware replaces.
  double time_sensors{0.0};
  /// Wall time of the call's onboard estimator (s): the filter's propagation and updates, and the
  /// estimate's conversion to the controller's state.
  double time_filter{0.0};
  int gravity_evaluations{0};  ///< the filter's polyhedral gravity evaluations in this call
  /// Fault detection (nav/faults.hpp, M50), latched over the run: whether any fault was detected so far.
  bool fault_detected{false};
  NavFault fault_cause{NavFault::None};  ///< the first detection (None while fault_detected is false)
  /// Per NavFault: the time of its first detection (s), NaN while not detected.
  std::array<double, kNavFaults> detected_at{};
  std::array<bool, kSensors> excluded{};  ///< per sensor: declared faulty and no longer folded in
  std::array<int, kSensors> failed{};     ///< per sensor: samples of this call that failed their NIS test
};

/// The navigation system (see the file comment). Lifecycle: construct (allocates), `initialize` at
/// the mission's start, then `step` once per control period.
class NavigationSystem {
 public:
  /// @param model         the filter's proximity model, non-null (also gives C_AL(t) and n to the sensors).
  /// @param sensor_caster ray caster on the true shape (the sensors), non-null.
  /// @param filter_caster ray caster on the onboard shape model (the filter), non-null.
  /// @param landmarks     the landmark catalogue (frame A), non-empty.
  /// @param settings      validated here.
  /// @param seed          seed of the run: each sensor and the initial error draw get their own stream.
  /// @throws std::invalid_argument for a null pointer, an empty catalogue or bad settings.
  NavigationSystem(std::shared_ptr<const dynamics::ProximityModel> model,
                   std::shared_ptr<const RayCaster> sensor_caster,
                   std::shared_ptr<const RayCaster> filter_caster, std::vector<Landmark> landmarks,
                   const NavigationSettings& settings, std::uint64_t seed);

  /// Starts the filter at the true state with an initial error drawn from the settings' sigmas,
  /// samples every sensor at t0 and folds the measurements in. Allocation-free.
  /// @param t0              time (s).
  /// @param truth           the true state [r_L, v_L, q_B/L, omega_BL_B] (13).
  /// @param accel_nongrav_L the true non-gravitational acceleration at t0 (m/s^2, in L).
  /// @param phi_ref         the rotation vector the branch of phi is chosen nearest to (rad).
  /// @return the estimate (internal storage, valid until the next call).
  const NavigationStep& initialize(double t0, const dynamics::TruthState& truth,
                                   const Eigen::Vector3d& accel_nongrav_L, const Eigen::Vector3d& phi_ref);

  /// One control period: samples j = 0..n-1 of the truth at times t_j = t_last + (j + 1) h (the last
  /// one the period's end, after its additive disturbance). Allocation-free; never throws.
  /// @param t               sample times (s), n >= 1.
  /// @param truth           rows: the true state (13) at each time.
  /// @param accel_nongrav_L rows: the true non-gravitational acceleration (thrust, SRP) in L over the
  ///                        sub-step (t_j - h, t_j] (m/s^2).
  /// @param phi_ref         the rotation vector the branch of phi is chosen nearest to (rad).
  /// @return the estimate at the last sample (internal storage, valid until the next call).
  const NavigationStep& step(
      const Eigen::Ref<const Eigen::VectorXd>& t,
      const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNtruth, Eigen::RowMajor>>&
          truth,
      const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>& accel_nongrav_L,
      const Eigen::Vector3d& phi_ref) noexcept;

  /// Sets the injected sensor faults and the detection's settings (set-up: before initialize).
  /// @param faults    the injected faults (at most kMaxSensorFaults), each validated.
  /// @param detection the detection's settings, validated.
  /// @throws std::invalid_argument naming the bad field ("faults.<field>"), or for too many faults.
  void set_faults(const std::vector<SensorFault>& faults, const FaultDetectionSettings& detection);
  /// @return the detection's settings.
  const FaultDetectionSettings& fault_detection() const { return detection_; }
  /// @param dof degrees of freedom, in [1, kMaxNisDof].
  /// @return the NIS test's threshold for a sample of dof degrees of freedom.
  double nis_threshold(int dof) const { return nis_threshold_[static_cast<std::size_t>(dof)]; }

  /// @return the last call's result.
  const NavigationStep& last() const { return out_; }
  /// @return the filter.
  const NavigationFilter& filter() const { return filter_; }
  /// @return the IMU (its true biases).
  const Imu& imu() const { return imu_; }
  /// @return the settings.
  const NavigationSettings& settings() const { return settings_; }
  /// @return the base rate h = the IMU's period (s).
  double base_period() const { return settings_.imu.period; }

 private:
  // Zeroes the step's counters and statuses before a call fills them.
  void clear_step();
  SensorTruth sensor_truth(double t, const dynamics::TruthState& s, const Eigen::Vector3d& a_L) const;
  // Samples the IMU at truth.t and propagates the filter to it with that sample.
  void propagate_to(const SensorTruth& truth);
  // Samples the sensors (but the IMU) due at the current tick from `truth` and folds them in.
  void sample(const SensorTruth& truth, bool all);
  void count(Sensor s, SensorStatus st);
  void record(UpdateResult r, Sensor s);
  void finish(const Eigen::Vector3d& phi_ref);
  // The injected faults acting at t on the IMU sample / the aiding sensors' outputs.
  void inject_imu(double t);
  void inject_aiding(Sensor s, double t);
  // Whether sensor s is excluded (declared faulty, with exclusion on).
  bool excluded(Sensor s) const { return out_.excluded[static_cast<int>(s)]; }
  // The detection's bookkeeping after sensor s's sample at t: its status and, when folded in, the update.
  void check_sample(Sensor s, double t, SensorStatus st, const UpdateResult* r);
  // Declares a detection at t (the first time only).
  void declare(NavFault f, double t);
  // The outage and covariance tests at t (end of a call).
  void check_health(double t);
  void reset_detection(double t0);

  std::shared_ptr<const dynamics::ProximityModel> model_;
  NavigationSettings settings_;
  Altimeter altimeter_;
  NavCamera camera_;
  Imu imu_;
  StarTracker star_tracker_;
  NavigationFilter filter_;
  Random rng_;
  std::array<int, kSensors> every_{};  // sample every this many ticks
  long tick_{0};                       // base periods since initialize
  double t0_{0.0};
  ImuSample imu_sample_{};  // the last IMU sample, held over the next interval
  AltimeterMeasurement alt_{};
  CameraFrame frame_{};
  StarTrackerMeasurement star_{};
  NavCovariance Q_period_{NavCovariance::Zero()};
  long gravity_evaluations_before_{0};  // the filter's count when the call started
  bool initialized_{false};
  std::array<SensorFault, kMaxSensorFaults> faults_{};
  int n_faults_{0};
  FaultDetectionSettings detection_{};
  std::array<double, kMaxNisDof + 1> nis_threshold_{};  // by degrees of freedom
  std::array<int, kSensors> failing_{};                 // failed samples in a row, per sensor
  std::array<double, kSensors> last_ok_{};              // time of the last Ok sample, per sensor
  NavigationStep out_{};
};

}  // namespace tubempc::nav

namespace tubempc::core {

/// Names of nav::Sensor.
template <>
struct EnumNames<nav::Sensor> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<nav::Sensor>, 4> values{
      {{nav::Sensor::Altimeter, "Altimeter", "altimeter"},
       {nav::Sensor::Camera, "Camera", "camera"},
       {nav::Sensor::Imu, "Imu", "imu"},
       {nav::Sensor::StarTracker, "StarTracker", "star_tracker"}}};
};

/// Names of nav::NavigationStatus.
template <>
struct EnumNames<nav::NavigationStatus> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<nav::NavigationStatus>, 5> values{
      {{nav::NavigationStatus::Ok, "Ok", "ok"},
       {nav::NavigationStatus::PredictionOnly, "PredictionOnly", "prediction_only"},
       {nav::NavigationStatus::NumericalFailure, "NumericalFailure", "numerical_failure"},
       {nav::NavigationStatus::InvalidInput, "InvalidInput", "invalid_input"},
       {nav::NavigationStatus::NotInitialized, "NotInitialized", "not_initialized"}}};
};

}  // namespace tubempc::core

namespace tubempc::nav {

// The table of NavigationSettings::for_each_field.
template <typename V>
void NavigationSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = NavigationSettings;
  constexpr bool req = false, finite = false;
  constexpr Dim one = Dim::One, nine = Dim::Nine;
  visit(FieldInfo{"altimeter", "", req, finite, one, one, "the true altimeter"}, &S::altimeter);
  visit(FieldInfo{"camera", "", req, finite, one, one, "the true camera"}, &S::camera);
  visit(FieldInfo{"imu", "", req, finite, one, one, "the true IMU; its period is the base rate h"}, &S::imu);
  visit(FieldInfo{"star_tracker", "", req, finite, one, one, "the true star tracker"}, &S::star_tracker);
  visit(FieldInfo{"filter", "", req, finite, one, one, "the filter, with its model of the sensors"},
        &S::filter);
  visit(FieldInfo{"initial_sigma", "m, m/s, rad", req, finite, nine, one,
                  "initial estimation error sigmas [r_L (m), v_L (m/s), theta (rad)], each >= 0"},
        &S::initial_sigma);
  visit(FieldInfo{"period_noise_sigma", "m, m/s, rad", req, finite, nine, one,
                  "per-period disturbance sigmas [r_L (m), v_L (m/s), theta (rad)] added to P, each >= 0"},
        &S::period_noise_sigma);
  visit(FieldInfo{"max_samples", "", req, finite, one, one, "most samples of one period, >= 1"},
        &S::max_samples);
}

}  // namespace tubempc::nav
