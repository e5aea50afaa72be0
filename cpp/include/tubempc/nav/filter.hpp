/// @file filter.hpp
/// The onboard navigation filter (docs/model.md, "Navigation"; docs/decisions.md, "Navigation"): one
/// joint error-state extended Kalman filter for the translation (r_L, v_L) and the attitude (q_B/L,
/// multiplicative error), with the gyro and accelerometer biases. The IMU drives the prediction: the
/// gyro's rate propagates the attitude, the accelerometer's specific force (thrust, SRP) is added to
/// the modelled accelerations of M1 (polyhedral gravity, Coriolis and tidal terms of L); the
/// altimeter and the star tracker correct it one measurement at a time (scalar and 3-D updates), a
/// camera frame's landmarks in one stacked update from their information (docs/model.md M31), all in
/// Joseph form. Fixed-size Eigen matrices throughout:
/// after construction no call allocates, and every call reports a FilterStatus instead of throwing.
///
/// Error state (15): dx = [dr_L (m), dv_L (m/s), dtheta (rad), db_g (rad/s), db_a (m/s^2)] with
/// r = r^ + dr, v = v^ + dv, q_B/L = q^_B/L (x) exp(dtheta) (C_LB = C^_LB Exp(dtheta)),
/// b_g = b^_g + db_g, b_a = b^_a + db_a.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <memory>
#include <vector>

#include "tubempc/core/fields.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/expansion_hold.hpp"
#include "tubempc/gravity/gravity_model.hpp"
#include "tubempc/math/so3.hpp"
#include "tubempc/nav/ray_caster.hpp"
#include "tubempc/nav/sensors.hpp"

namespace tubempc::nav {

inline constexpr int kNavStates = 15;  ///< dimension of the error state dx
/// Error-state vector dx = [dr_L (m), dv_L (m/s), dtheta (rad), db_g (rad/s), db_a (m/s^2)].
using NavErrorVector = Eigen::Matrix<double, kNavStates, 1>;
/// Error-state covariance (15 x 15, in the units of dx squared).
using NavCovariance = Eigen::Matrix<double, kNavStates, kNavStates>;

/// The navigation state (the estimate, or the truth it is compared with).
struct NavState {
  double t{0.0};                                          ///< time (s)
  Eigen::Vector3d r_L{Eigen::Vector3d::Zero()};           ///< position in L (m)
  Eigen::Vector3d v_L{Eigen::Vector3d::Zero()};           ///< velocity in L (m/s)
  math::Quaternion q_BL{0.0, 0.0, 0.0, 1.0};              ///< attitude q_B/L, unit
  Eigen::Vector3d gyro_bias_B{Eigen::Vector3d::Zero()};   ///< gyro bias b_g in B (rad/s)
  Eigen::Vector3d accel_bias_B{Eigen::Vector3d::Zero()};  ///< accelerometer bias b_a in B (m/s^2)
};

/// The error dx between a reference state and an estimate (truth minus estimate; dtheta =
/// log(q^* (x) q)).
/// @param estimate the estimate x^.
/// @param truth    the reference x.
/// @return dx with x = x^ (+) dx.
NavErrorVector nav_error(const NavState& estimate, const NavState& truth);

/// Normalised estimation error squared dx^T P^-1 dx.
/// @param estimate   the estimate.
/// @param covariance its covariance P (positive definite).
/// @param truth      the reference.
/// @return the NEES (chi-square with 15 degrees of freedom for a consistent filter), or NaN when P is
///         not positive definite.
double nees(const NavState& estimate, const NavCovariance& covariance, const NavState& truth);

/// What the filter assumes about the sensors and the dynamics. The sensors' Settings types are reused:
/// their noise is the filter's model of it and their biases (altimeter bias, pixel bias, star tracker
/// misalignment) are known calibrations the filter subtracts.
struct FilterSettings {
  AltimeterSettings altimeter{};       ///< beam, range noise, calibrated bias, max range
  CameraSettings camera{};             ///< intrinsics, C_BC, pixel noise, calibrated bias
  StarTrackerSettings star_tracker{};  ///< attitude noise, calibrated misalignment
  ImuSettings imu{};                   ///< noise densities and bias random walks of the IMU
  double accel_model_noise{
      0.0};  ///< extra acceleration noise density for unmodelled forces (m/s^2/sqrt(Hz)), >= 0
  /// Range noise added in quadrature to the altimeter's (m), >= 0: the range to a faceted shape model
  /// is piecewise linear in the state, and a beam that crosses a facet edge between the estimate and
  /// the truth leaves the linearisation (docs/decisions.md, "Navigation").
  double altimeter_terrain_sigma{0.1};
  /// Largest accepted NIS of one measurement, > 0 (inf: no gate); a landmark's is taken against the
  /// frame's prior covariance.
  double innovation_gate{1e4};
  /// Shortest distance (m, >= 0) the estimate may move in frame A from the point where the filter last
  /// evaluated the polyhedral gravity and its gradient before it evaluates them again; in between, the
  /// gravity is the first-order expansion about that point, a = a(r0) + G(r0) (r - r0), whose error is
  /// about half the third derivative of U times the distance squared (docs/model.md M42). 0 (with a
  /// zero gravity_expansion_tolerance): an evaluation at every sub-step.
  double gravity_relinearization_distance{1.0};
  /// The expansion's error tolerance (m/s^2, >= 0): the hold distance is lengthened to
  /// sqrt(2 tol / c), c = |G(r1) - G(r0)|_F / |r1 - r0| from the last two evaluations (the third
  /// derivative of U along the path), at most |r1| / 8 (r1 the new point in A, from the body's centre
  /// of mass) and never below gravity_relinearization_distance (M42). 0: the fixed distance.
  double gravity_expansion_tolerance{1e-7};
  double max_step{0.5};  ///< longest propagation sub-step (s), > 0
  /// Longest span (s, >= 0) over which the covariance waits for its propagation: the sub-steps' error
  /// dynamics are integrated as they come and P is propagated once over the span with their mean
  /// (M30), when the span reaches this length and before any use of P (an update, added noise, a read).
  /// 0: at every sub-step.
  double covariance_step{1.0};
  int max_substeps{64};  ///< most sub-steps of one propagate call, >= 1 (a longer call is refused)
  /// Emulate two separate filters (translation [r, v, b_a], attitude [theta, b_g]) instead of the joint
  /// one: the cross-covariances between the two are dropped after every step and the altimeter's and the
  /// camera's attitude Jacobians are dropped (the translation filter takes the attitude as known). The
  /// alternative of docs/decisions.md ("One joint filter"), kept for its measurement.
  bool split{false};
  /// @throws std::invalid_argument naming the first bad field ("filter.<field>", or the sensor's).
  void validate() const;

  /// The fields, once (core::FieldInfo per member, in the order scenario files write them): drive the
  /// scenario file's records and the Python attributes.
  /// @param visit a callable taking (const core::FieldInfo&, member pointer).
  template <typename V>
  static void for_each_field(V&& visit);
};

/// Outcome of a filter call.
enum class FilterStatus {
  Ok,                ///< done
  ImuHeld,           ///< propagated with the last good IMU sample (this one was not Ok)
  NoMeasurement,     ///< the measurement's status was not Ok: nothing to fold in (prediction only)
  Rejected,          ///< every measurement failed the innovation gate (prediction only)
  NoPrediction,      ///< the measurement cannot be predicted from the estimate (beam misses, landmark behind)
  TimeMismatch,      ///< the measurement's time is not the filter's time (call propagate first)
  StepTooLong,       ///< the propagation would need more than max_substeps sub-steps: not done
  InvalidInput,      ///< a non-finite input or a time going backwards: nothing changed
  NumericalFailure,  ///< an innovation covariance not positive definite or a non-finite result: undone
};
/// Name of a filter status.
/// @param s the status.
/// @return its name ("ok", "imu_held", ...).
const char* to_string(FilterStatus s);

/// Result of one update call.
struct UpdateResult {
  FilterStatus status{FilterStatus::Ok};  ///< outcome (Ok when at least one measurement was folded in)
  int accepted{0};                        ///< scalar, 2-D or 3-D measurements folded in
  int rejected{0};                        ///< measurements refused (gate, no prediction, numerics)
  int failed{0};  ///< of those, refused for numerics (S not positive definite, non-finite result)
  /// NIS of the accepted measurements, y^T S^-1 y of their stacked innovation (a frame's landmarks
  /// together; for one measurement, its own).
  double nis{0.0};
  int dof{0};  ///< degrees of freedom of that sum (components accepted)
};

/// The joint error-state EKF. Lifecycle: construct (set-up, may allocate), `initialize`, then per IMU
/// sample `propagate` and, at the same time, the `update_*` of the sensors that sampled.
class NavigationFilter {
 public:
  /// @param model     the proximity model (gravity in A, frame rotation, mean motion), non-null. Its
  ///                  SRP term is not used: the accelerometer measures it.
  /// @param caster    ray caster on the shape model (the altimeter's prediction), non-null.
  /// @param landmarks the landmark catalogue (frame A), as the camera's.
  /// @param settings  validated here.
  /// @throws std::invalid_argument for a null pointer or bad settings.
  NavigationFilter(std::shared_ptr<const dynamics::ProximityModel> model,
                   std::shared_ptr<const RayCaster> caster, std::vector<Landmark> landmarks,
                   const FilterSettings& settings);

  /// Sets the estimate and its covariance.
  /// @param x0 the initial estimate (its time is the filter's).
  /// @param P0 its covariance, symmetric positive definite.
  /// @return Ok, or InvalidInput (non-finite input or P0 not positive definite; nothing changed).
  FilterStatus initialize(const NavState& x0, const NavCovariance& P0);

  /// Propagates from the filter's time to t_to with the IMU sample over the interval, in sub-steps of
  /// at most max_step: attitude by the gyro's rate (interpolated linearly between the last good sample
  /// and this one when they bracket the interval, i.e. were taken at the filter's time and at t_to;
  /// otherwise this sample's rate held), translation
  /// by M1 with the polyhedral gravity's first-order expansion (about the last evaluation point, see
  /// FilterSettings::gravity_relinearization_distance) plus the measured specific force, covariance by
  /// the Taylor series of the error dynamics to third order.
  /// @param t_to time to reach (s), >= the filter's time.
  /// @param imu  the IMU sample; if its status is not Ok the last good sample is used (ImuHeld).
  /// @return Ok, ImuHeld, StepTooLong, InvalidInput or NumericalFailure (the last three: unchanged).
  FilterStatus propagate(double t_to, const ImuSample& imu);

  /// Adds a covariance to P at the filter's time: an instantaneous process noise that no IMU
  /// senses, such as the closed loop's additive per-period disturbance (docs/model.md M39).
  /// @param Q the covariance added (symmetric positive semi-definite, units of dx squared).
  /// @return Ok, or InvalidInput (not initialised, or Q non-finite; nothing changed).
  FilterStatus add_process_noise(const NavCovariance& Q);

  /// Folds an altimeter range in (scalar update).
  /// @param m the sample, at the filter's time.
  /// @return the result.
  UpdateResult update_altimeter(const AltimeterMeasurement& m);
  /// Folds a camera frame in: each landmark's 2-D pixel is gated against the frame's prior covariance,
  /// the accepted ones are folded in together (one stacked update, computed from their information on
  /// the position and attitude errors; docs/model.md M31).
  /// @param frame the frame, at the filter's time.
  /// @return the result.
  UpdateResult update_camera(const CameraFrame& frame);
  /// Folds a star tracker attitude in (3-D update).
  /// @param m the sample, at the filter's time.
  /// @return the result.
  UpdateResult update_star_tracker(const StarTrackerMeasurement& m);

  /// @return the estimate.
  const NavState& state() const { return x_; }
  /// @return the error-state covariance P (symmetric positive semi-definite) at the filter's time
  ///         (a pending propagation, FilterSettings::covariance_step, is done first).
  const NavCovariance& covariance() const {
    propagate_covariance();
    return P_;
  }
  /// @return the estimate of omega_BL_B from the last good gyro sample (rad/s).
  Eigen::Vector3d omega_BL_B() const;
  /// The controller's state x = [r_L, v_L, phi, omega_BL_B] from the estimate.
  /// @param phi_ref rotation vector (rad) the branch of phi = log(q^_B/L) is chosen nearest to
  ///                (math::nearest_representative, as dynamics::truth_to_state).
  /// @return the model state estimate.
  dynamics::StateVector model_state(const Eigen::Vector3d& phi_ref) const;
  /// Covariance of model_state(phi_ref)'s error: dphi = Jr(phi)^-1 dtheta, domega = -db_g - gyro
  /// noise over one IMU period.
  /// @param phi_ref as for model_state.
  /// @return the 12 x 12 covariance (units of x squared).
  dynamics::StateMatrix model_covariance(const Eigen::Vector3d& phi_ref) const;
  /// Predicted pixel of a landmark from the estimate (the calibrated pixel bias not added) and its
  /// Jacobian with respect to the error state.
  /// @param landmark catalogue index.
  /// @param pixel    receives (u, v) (pixels).
  /// @param H        if non-null, receives d pixel / d dx (2 x 15).
  /// @return false when not initialised, the landmark is behind the camera or the index is out of range.
  bool predict_pixel(int landmark, Eigen::Vector2d& pixel,
                     Eigen::Matrix<double, 2, kNavStates>* H = nullptr) const;
  /// Predicted altimeter range from the estimate (the calibrated bias not added) and its Jacobian.
  /// @param range receives the distance along the beam to the shape model (m).
  /// @param H     if non-null, receives d range / d dx (1 x 15).
  /// @return false when not initialised or the beam meets no face within 2 max_range, or grazes one.
  bool predict_range(double& range, Eigen::Matrix<double, 1, kNavStates>* H = nullptr) const;
  /// @return the settings.
  const FilterSettings& settings() const { return settings_; }
  /// @return whether initialize has succeeded.
  bool initialized() const { return initialized_; }
  /// @return evaluations of the polyhedral gravity (with its gradient) since construction.
  long gravity_evaluations() const { return gravity_.evaluations(); }
  /// @return the largest error of the gravity's expansion found at a re-evaluation since construction,
  ///         |a(r1) - a(r0) - G(r0) (r1 - r0)| at the new point r1 (m/s^2): the expansion's error at
  ///         the end of its hold (re-evaluations after an update's jump past twice the hold left out).
  double gravity_expansion_error() const { return gravity_.largest_error(); }

 private:
  template <int M>
  bool fold(const Eigen::Matrix<double, M, 1>& residual, const Eigen::Matrix<double, M, kNavStates>& H,
            const Eigen::Matrix<double, M, M>& R, UpdateResult& result);
  void inject(const NavErrorVector& dx);
  // Propagates P over the pending span (FilterSettings::covariance_step); nothing when there is none.
  void propagate_covariance() const;
  Eigen::Vector3d phi_near(const Eigen::Vector3d& phi_ref) const;

  std::shared_ptr<const dynamics::ProximityModel> model_;
  std::shared_ptr<const RayCaster> caster_;
  std::vector<Landmark> landmarks_;
  FilterSettings settings_;
  Eigen::Vector3d boresight_B_;
  Eigen::Matrix3d D_tidal_;  // n^2 diag(3, 0, -1) (1/s^2)
  Eigen::Vector3d omega_LI_L_;
  NavState x_;
  // P and the integral of the error dynamics F over the span P has not been propagated across yet: the
  // covariance is brought up to the filter's time lazily, also by const readers.
  mutable NavCovariance P_{NavCovariance::Identity()};
  mutable NavCovariance F_pending_{NavCovariance::Zero()};
  mutable double pending_span_{0.0};
  NavCovariance Qc_{NavCovariance::Zero()};       // continuous process noise density (units of dx^2 / s)
  Eigen::Vector3d f_B_{Eigen::Vector3d::Zero()};  // last good specific force (m/s^2)
  Eigen::Vector3d omega_BI_B_{Eigen::Vector3d::Zero()};  // last good gyro rate (rad/s)
  double rate_time_{0.0};                                // time of that sample (s)
  bool rate_sampled_{false};        // omega_BI_B_ is a gyro sample (not initialize's assumption)
  gravity::ExpansionHold gravity_;  // the gravity's expansion (FilterSettings, M42)
  bool initialized_{false};
};

}  // namespace tubempc::nav

namespace tubempc::core {

/// Names of nav::FilterStatus.
template <>
struct EnumNames<nav::FilterStatus> {
  /// The values, their identifiers and names.
  static constexpr std::array<EnumName<nav::FilterStatus>, 9> values{
      {{nav::FilterStatus::Ok, "Ok", "ok"},
       {nav::FilterStatus::ImuHeld, "ImuHeld", "imu_held"},
       {nav::FilterStatus::NoMeasurement, "NoMeasurement", "no_measurement"},
       {nav::FilterStatus::Rejected, "Rejected", "rejected"},
       {nav::FilterStatus::NoPrediction, "NoPrediction", "no_prediction"},
       {nav::FilterStatus::TimeMismatch, "TimeMismatch", "time_mismatch"},
       {nav::FilterStatus::StepTooLong, "StepTooLong", "step_too_long"},
       {nav::FilterStatus::InvalidInput, "InvalidInput", "invalid_input"},
       {nav::FilterStatus::NumericalFailure, "NumericalFailure", "numerical_failure"}}};
};

}  // namespace tubempc::core

namespace tubempc::nav {

// The table of FilterSettings::for_each_field.
template <typename V>
void FilterSettings::for_each_field(V&& visit) {
  using core::Dim;
  using core::FieldInfo;
  using S = FilterSettings;
  constexpr bool req = false, inf = true, finite = false;
  constexpr Dim one = Dim::One;
  visit(FieldInfo{"altimeter", "", req, finite, one, one, "the filter's altimeter model"}, &S::altimeter);
  visit(FieldInfo{"camera", "", req, finite, one, one, "the filter's camera model"}, &S::camera);
  visit(FieldInfo{"star_tracker", "", req, finite, one, one, "the filter's star tracker model"},
        &S::star_tracker);
  visit(FieldInfo{"imu", "", req, finite, one, one, "the filter's IMU model"}, &S::imu);
  visit(FieldInfo{"accel_model_noise", "m/s^2/sqrt(Hz)", req, finite, one, one,
                  "extra acceleration noise density for unmodelled forces (m/s^2/sqrt(Hz)), >= 0"},
        &S::accel_model_noise);
  visit(FieldInfo{"altimeter_terrain_sigma", "m", req, finite, one, one,
                  "range noise added in quadrature to the altimeter's (m), >= 0"},
        &S::altimeter_terrain_sigma);
  visit(FieldInfo{"innovation_gate", "", req, inf, one, one,
                  "largest accepted NIS of one measurement, > 0 (inf: no gate)"},
        &S::innovation_gate);
  visit(FieldInfo{"gravity_relinearization_distance", "m", req, finite, one, one,
                  "shortest move in A (m) before the gravity is evaluated again, >= 0"},
        &S::gravity_relinearization_distance);
  visit(FieldInfo{"gravity_expansion_tolerance", "m/s^2", req, finite, one, one,
                  "error tolerance of the gravity's first-order expansion (m/s^2), >= 0; 0: fixed distance"},
        &S::gravity_expansion_tolerance);
  visit(FieldInfo{"max_step", "s", req, finite, one, one, "longest propagation sub-step (s), > 0"},
        &S::max_step);
  visit(FieldInfo{"covariance_step", "s", req, finite, one, one,
                  "longest span over which the covariance waits for its propagation (s), >= 0"},
        &S::covariance_step);
  visit(FieldInfo{"max_substeps", "", req, finite, one, one, "most sub-steps of one propagate call, >= 1"},
        &S::max_substeps);
  visit(FieldInfo{"split", "", req, finite, one, one,
                  "emulate two separate filters (translation, attitude) instead of the joint one"},
        &S::split);
}

}  // namespace tubempc::nav
