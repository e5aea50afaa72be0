#include "tubempc/nav/system.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace tubempc::nav {

namespace {

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw std::invalid_argument("navigation." + field + ": " + why);
}

// Ticks of the base period h in a period p, or -1 when p is not an integer multiple of h.
int ticks(double p, double h) {
  const double r = p / h;
  const double n = std::round(r);
  return n >= 1.0 && std::abs(r - n) <= 1e-9 * n ? static_cast<int>(n) : -1;
}

using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

// The worse of two filter outcomes (numerical failures first).
FilterStatus worse(FilterStatus a, FilterStatus b) {
  auto rank = [](FilterStatus s) {
    switch (s) {
      case FilterStatus::NumericalFailure:
        return 4;
      case FilterStatus::InvalidInput:
      case FilterStatus::StepTooLong:
      case FilterStatus::TimeMismatch:
        return 3;
      case FilterStatus::NoPrediction:
      case FilterStatus::Rejected:
        return 2;
      case FilterStatus::ImuHeld:
        return 1;
      default:
        return 0;
    }
  };
  return rank(b) > rank(a) ? b : a;
}

}  // namespace

const char* to_string(Sensor s) { return core::enum_name(s); }

const char* to_string(NavigationStatus s) { return core::enum_name(s); }

void NavigationSettings::validate() const {
  altimeter.validate();
  camera.validate();
  imu.validate();
  star_tracker.validate();
  filter.validate();
  if (!(initial_sigma.allFinite() && (initial_sigma.array() >= 0.0).all()))
    fail("initial_sigma", "must be finite and >= 0");
  if (!(period_noise_sigma.allFinite() && (period_noise_sigma.array() >= 0.0).all()))
    fail("period_noise_sigma", "must be finite and >= 0");
  if (max_samples < 1) fail("max_samples", "must be >= 1");
  const double h = imu.period;
  if (ticks(altimeter.period, h) < 0)
    fail("altimeter.period", "must be an integer multiple of imu.period (" + std::to_string(h) + " s)");
  if (ticks(camera.period, h) < 0)
    fail("camera.period", "must be an integer multiple of imu.period (" + std::to_string(h) + " s)");
  if (ticks(star_tracker.period, h) < 0)
    fail("star_tracker.period", "must be an integer multiple of imu.period (" + std::to_string(h) + " s)");
}

NavigationSystem::NavigationSystem(std::shared_ptr<const dynamics::ProximityModel> model,
                                   std::shared_ptr<const RayCaster> sensor_caster,
                                   std::shared_ptr<const RayCaster> filter_caster,
                                   std::vector<Landmark> landmarks, const NavigationSettings& settings,
                                   std::uint64_t seed)
    : model_(std::move(model)),
      settings_((settings.validate(), settings)),
      altimeter_(sensor_caster, settings.altimeter, 4 * seed + 1),
      camera_(std::move(sensor_caster), landmarks, settings.camera, 4 * seed + 2),
      imu_(settings.imu, 4 * seed + 3),
      star_tracker_(settings.star_tracker, 4 * seed + 4),
      filter_(model_, std::move(filter_caster), std::move(landmarks), settings.filter),
      rng_(4 * seed + 5) {
  if (!model_) throw std::invalid_argument("navigation: model must not be null");
  const double h = settings_.imu.period;
  every_ = {ticks(settings_.altimeter.period, h), ticks(settings_.camera.period, h), 1,
            ticks(settings_.star_tracker.period, h)};
  for (int i = 0; i < 9; ++i)
    Q_period_(i, i) = settings_.period_noise_sigma(i) * settings_.period_noise_sigma(i);
  set_faults({}, FaultDetectionSettings{});
  reset_detection(0.0);
}

void NavigationSystem::set_faults(const std::vector<SensorFault>& faults,
                                  const FaultDetectionSettings& detection) {
  if (faults.size() > static_cast<std::size_t>(kMaxSensorFaults))
    throw std::invalid_argument("faults: at most " + std::to_string(kMaxSensorFaults) +
                                " injected sensor faults, got " + std::to_string(faults.size()));
  for (const SensorFault& f : faults) f.validate();
  detection.validate();
  std::array<double, kMaxNisDof + 1> threshold{};
  for (std::size_t dof = 1; dof < threshold.size(); ++dof)  // threshold[0] unused: no test has 0 dof
    threshold[dof] = chi_square_upper_quantile(detection.false_alarm_probability, static_cast<int>(dof));
  n_faults_ = static_cast<int>(faults.size());
  for (int i = 0; i < n_faults_; ++i) {
    faults_[static_cast<std::size_t>(i)] = faults[static_cast<std::size_t>(i)];
    faults_[static_cast<std::size_t>(i)].axis_B.normalize();
  }
  detection_ = detection;
  nis_threshold_ = threshold;
}

void NavigationSystem::inject_imu(double t) {
  if (imu_sample_.status != SensorStatus::Ok) return;
  for (int i = 0; i < n_faults_; ++i) {
    const SensorFault& f = faults_[static_cast<std::size_t>(i)];
    if (!f.active(t)) continue;
    switch (f.kind) {
      case SensorFaultKind::GyroBiasStep:
        imu_sample_.omega_BI_B += f.magnitude * f.axis_B;
        break;
      case SensorFaultKind::AccelBiasStep:
        imu_sample_.specific_force_B += f.magnitude * f.axis_B;
        break;
      case SensorFaultKind::GyroScaleStep:
        imu_sample_.omega_BI_B *= 1.0 + f.magnitude;
        break;
      case SensorFaultKind::AccelScaleStep:
        imu_sample_.specific_force_B *= 1.0 + f.magnitude;
        break;
      default:
        break;
    }
  }
}

void NavigationSystem::inject_aiding(Sensor s, double t) {
  for (int i = 0; i < n_faults_; ++i) {
    const SensorFault& f = faults_[static_cast<std::size_t>(i)];
    if (!f.active(t)) continue;
    switch (f.kind) {
      case SensorFaultKind::CameraOutage:
        if (s == Sensor::Camera) frame_.status = SensorStatus::Failed;
        break;
      case SensorFaultKind::LandmarkOutlier:
        if (s == Sensor::Camera && frame_.status == SensorStatus::Ok && frame_.count >= 1)
          frame_.observations[0].pixel.x() += f.magnitude;
        break;
      case SensorFaultKind::LandmarkMismatch:
        if (s == Sensor::Camera && frame_.status == SensorStatus::Ok && frame_.count >= 2)
          std::swap(frame_.observations[0].landmark, frame_.observations[1].landmark);
        break;
      case SensorFaultKind::AltimeterDropout:
        if (s == Sensor::Altimeter) alt_.status = SensorStatus::Failed;
        break;
      case SensorFaultKind::AltimeterSpike:
        if (s == Sensor::Altimeter && alt_.status == SensorStatus::Ok) alt_.range += f.magnitude;
        break;
      case SensorFaultKind::StarTrackerLoss:
        if (s == Sensor::StarTracker) star_.status = SensorStatus::Failed;
        break;
      default:
        break;
    }
  }
}

void NavigationSystem::declare(NavFault f, double t) {
  double& at = out_.detected_at[static_cast<std::size_t>(f)];
  if (std::isnan(at)) at = t;
  if (!out_.fault_detected) {
    out_.fault_detected = true;
    out_.fault_cause = f;
  }
}

void NavigationSystem::check_sample(Sensor s, double t, SensorStatus st, const UpdateResult* r) {
  if (!detection_.enabled) return;
  const int i = static_cast<int>(s);
  if (st == SensorStatus::Ok) last_ok_[i] = t;
  if (r == nullptr) return;
  // Failed: the accepted measurements' NIS beyond the quantile, or every measurement refused by the gate.
  const bool bad = r->accepted == 0 ? r->status == FilterStatus::Rejected
                                    : r->dof >= 1 && r->dof <= kMaxNisDof &&
                                          r->nis > nis_threshold_[static_cast<std::size_t>(r->dof)];
  if (!bad) {
    failing_[i] = 0;
    return;
  }
  ++out_.failed[i];
  if (++failing_[i] < detection_.persistence) return;
  failing_[i] = 0;
  // A second aiding sensor failing while another is faulty or failing: the common cause, the IMU.
  bool other = false;
  for (const Sensor o : {Sensor::Altimeter, Sensor::Camera, Sensor::StarTracker}) {
    const int j = static_cast<int>(o);
    if (j != i) other = other || out_.excluded[j] || failing_[j] > 0;
  }
  other = other || !std::isnan(out_.detected_at[static_cast<int>(NavFault::AltimeterFault)]) ||
          !std::isnan(out_.detected_at[static_cast<int>(NavFault::CameraFault)]) ||
          !std::isnan(out_.detected_at[static_cast<int>(NavFault::StarTrackerFault)]);
  if (other) {
    declare(NavFault::ImuFault, t);
    return;
  }
  declare(s == Sensor::Altimeter ? NavFault::AltimeterFault
          : s == Sensor::Camera  ? NavFault::CameraFault
                                 : NavFault::StarTrackerFault,
          t);
  if (detection_.exclude) out_.excluded[i] = true;
}

void NavigationSystem::check_health(double t) {
  if (!detection_.enabled) return;
  const auto outage = [&](Sensor s, NavFault f) {
    if (t - last_ok_[static_cast<int>(s)] > detection_.outage_time) declare(f, t);
  };
  outage(Sensor::Altimeter, NavFault::AltimeterOutage);
  outage(Sensor::Camera, NavFault::CameraOutage);
  outage(Sensor::StarTracker, NavFault::StarTrackerOutage);
  const double sigma_r = std::sqrt(filter_.covariance().block<3, 3>(0, 0).trace());
  if (!(sigma_r <= detection_.max_position_sigma)) declare(NavFault::CovarianceGrowth, t);
}

void NavigationSystem::reset_detection(double t0) {
  failing_.fill(0);
  last_ok_.fill(t0);
  out_.fault_detected = false;
  out_.fault_cause = NavFault::None;
  out_.detected_at.fill(std::numeric_limits<double>::quiet_NaN());
  out_.excluded.fill(false);
}

SensorTruth NavigationSystem::sensor_truth(double t, const dynamics::TruthState& s,
                                           const Eigen::Vector3d& a_L) const {
  SensorTruth st;
  st.t = t;
  st.r_L = s.segment<3>(0);
  st.q_BL = s.segment<4>(6);
  st.omega_BL_B = s.segment<3>(10);
  st.omega_LI_L = Eigen::Vector3d(0.0, 0.0, model_->mean_motion());
  st.accel_nongrav_L = a_L;
  st.C_AL = model_->C_AL(t);
  return st;
}

void NavigationSystem::record(UpdateResult r, Sensor s) {
  const int i = static_cast<int>(s);
  out_.accepted[i] += r.accepted;
  out_.rejected[i] += r.rejected;
  out_.nis += r.nis;
  out_.nis_dof += r.dof;
  if (r.accepted == 0) out_.filter_status = worse(out_.filter_status, r.status);
}

void NavigationSystem::count(Sensor s, SensorStatus st) {
  const int i = static_cast<int>(s);
  ++out_.samples[i];
  out_.ok[i] += st == SensorStatus::Ok;
  out_.sensor_status[i] = st;
}

void NavigationSystem::propagate_to(const SensorTruth& truth) {
  const Clock::time_point t0 = Clock::now();
  const SensorStatus st = imu_.measure(truth, imu_sample_);
  inject_imu(truth.t);
  count(Sensor::Imu, st);
  const Clock::time_point t1 = Clock::now();
  out_.filter_status = worse(out_.filter_status, filter_.propagate(truth.t, imu_sample_));
  out_.time_sensors += seconds(t0, t1);
  out_.time_filter += seconds(t1, Clock::now());
}

void NavigationSystem::sample(const SensorTruth& truth, bool all) {
  const auto due = [&](Sensor s) { return all || tick_ % every_[static_cast<int>(s)] == 0; };
  // Each sensor: its simulation (timed as the sensors'), then the filter's update (the filter's).
  Clock::time_point t0 = Clock::now(), t1 = t0;
  const auto split = [&] {
    t1 = Clock::now();
    out_.time_sensors += seconds(t0, t1);
  };
  const auto done = [&] {
    t0 = Clock::now();
    out_.time_filter += seconds(t1, t0);
  };
  // Each aiding sensor: measured, its injected faults applied, folded in unless excluded, checked.
  if (due(Sensor::StarTracker)) {
    star_tracker_.measure(truth, star_);
    inject_aiding(Sensor::StarTracker, truth.t);
    count(Sensor::StarTracker, star_.status);
    split();
    UpdateResult r;
    const bool fold = star_.status == SensorStatus::Ok && !excluded(Sensor::StarTracker);
    if (fold) record(r = filter_.update_star_tracker(star_), Sensor::StarTracker);
    check_sample(Sensor::StarTracker, truth.t, star_.status, fold ? &r : nullptr);
    done();
  }
  if (due(Sensor::Altimeter)) {
    altimeter_.measure(truth, alt_);
    inject_aiding(Sensor::Altimeter, truth.t);
    count(Sensor::Altimeter, alt_.status);
    split();
    UpdateResult r;
    const bool fold = alt_.status == SensorStatus::Ok && !excluded(Sensor::Altimeter);
    if (fold) record(r = filter_.update_altimeter(alt_), Sensor::Altimeter);
    check_sample(Sensor::Altimeter, truth.t, alt_.status, fold ? &r : nullptr);
    done();
  }
  if (due(Sensor::Camera)) {
    camera_.measure(truth, frame_);
    inject_aiding(Sensor::Camera, truth.t);
    count(Sensor::Camera, frame_.status);
    out_.landmarks_visible = frame_.status == SensorStatus::Ok ? frame_.count : 0;
    split();
    UpdateResult r;
    const bool fold = frame_.status == SensorStatus::Ok && !excluded(Sensor::Camera);
    if (fold) record(r = filter_.update_camera(frame_), Sensor::Camera);
    check_sample(Sensor::Camera, truth.t, frame_.status, fold ? &r : nullptr);
    done();
  }
  out_.time_sensors += seconds(t0, Clock::now());
}

void NavigationSystem::finish(const Eigen::Vector3d& phi_ref) {
  const Clock::time_point t0 = Clock::now();
  check_health(filter_.state().t);
  const dynamics::StateVector x = filter_.model_state(phi_ref);
  const dynamics::StateMatrix P = filter_.model_covariance(phi_ref);
  out_.gravity_evaluations = static_cast<int>(filter_.gravity_evaluations() - gravity_evaluations_before_);
  out_.time_filter += seconds(t0, Clock::now());
  out_.t = filter_.state().t;
  out_.estimate = filter_.state();
  out_.covariance = filter_.covariance();
  if (x.allFinite() && P.allFinite()) {
    out_.x_hat = x;
    out_.P_x = P;
  } else {  // keep the last finite estimate
    out_.status = NavigationStatus::NumericalFailure;
    return;
  }
  int folded = 0;
  for (int i = 0; i < kSensors; ++i) folded += out_.accepted[i];
  if (out_.filter_status == FilterStatus::NumericalFailure ||
      out_.filter_status == FilterStatus::InvalidInput || out_.filter_status == FilterStatus::StepTooLong)
    out_.status = NavigationStatus::NumericalFailure;
  else
    out_.status = folded > 0 ? NavigationStatus::Ok : NavigationStatus::PredictionOnly;
}

void NavigationSystem::clear_step() {
  out_.samples.fill(0);
  out_.ok.fill(0);
  out_.accepted.fill(0);
  out_.rejected.fill(0);
  out_.sensor_status.fill(SensorStatus::Ok);
  out_.nis = 0.0;
  out_.nis_dof = 0;
  out_.landmarks_visible = 0;
  out_.filter_status = FilterStatus::Ok;
  out_.time_sensors = out_.time_filter = 0.0;
  out_.gravity_evaluations = 0;
  out_.failed.fill(0);
  gravity_evaluations_before_ = filter_.gravity_evaluations();
}

const NavigationStep& NavigationSystem::initialize(double t0, const dynamics::TruthState& truth,
                                                   const Eigen::Vector3d& accel_nongrav_L,
                                                   const Eigen::Vector3d& phi_ref) {
  clear_step();
  if (!std::isfinite(t0) || !truth.allFinite() || !accel_nongrav_L.allFinite() || !phi_ref.allFinite()) {
    out_.status = NavigationStatus::InvalidInput;
    return out_;
  }
  const ImuSettings& imu = settings_.imu;
  NavErrorVector sigma;
  sigma << settings_.initial_sigma, Eigen::Vector3d::Constant(imu.gyro_bias_sigma),
      Eigen::Vector3d::Constant(imu.accel_bias_sigma);
  NavErrorVector e;
  for (int i = 0; i < kNavStates; ++i) e(i) = sigma(i) * rng_.normal();
  NavState x0;
  x0.t = t0;
  x0.r_L = truth.segment<3>(0) - e.segment<3>(0);
  x0.v_L = truth.segment<3>(3) - e.segment<3>(3);
  x0.q_BL = math::quat_mul(truth.segment<4>(6), math::exp_map(-e.segment<3>(6)));
  x0.gyro_bias_B = imu_.gyro_bias() - e.segment<3>(9);
  x0.accel_bias_B = imu_.accel_bias() - e.segment<3>(12);
  NavCovariance P0 = NavCovariance::Zero();
  // A zero sigma still needs a positive definite P0: a floor far below every physical scale.
  P0.diagonal() = sigma.array().square().max(1e-30).matrix();
  const FilterStatus st = filter_.initialize(x0, P0);
  if (st != FilterStatus::Ok) {
    out_.filter_status = st;
    out_.status = NavigationStatus::InvalidInput;
    return out_;
  }
  tick_ = 0;
  t0_ = t0;
  initialized_ = true;
  reset_detection(t0);
  const SensorTruth st0 = sensor_truth(t0, truth, accel_nongrav_L);
  propagate_to(st0);  // zero length: registers the gyro's rate for the estimate's angular velocity
  sample(st0, true);
  finish(phi_ref);
  return out_;
}

const NavigationStep& NavigationSystem::step(
    const Eigen::Ref<const Eigen::VectorXd>& t,
    const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNtruth, Eigen::RowMajor>>& truth,
    const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>& accel_nongrav_L,
    const Eigen::Vector3d& phi_ref) noexcept {
  clear_step();
  if (!initialized_) {
    out_.status = NavigationStatus::NotInitialized;
    return out_;
  }
  const Eigen::Index n = t.size();
  const double h = settings_.imu.period;
  bool valid = n >= 1 && n <= settings_.max_samples && truth.rows() == n && accel_nongrav_L.rows() == n &&
               t.allFinite() && truth.allFinite() && accel_nongrav_L.allFinite() && phi_ref.allFinite();
  for (Eigen::Index j = 0; valid && j < n; ++j)
    valid = std::abs(t(j) - (t0_ + static_cast<double>(tick_ + 1 + j) * h)) <= 1e-6 * h;
  if (!valid) {
    out_.status = NavigationStatus::InvalidInput;
    return out_;
  }
  for (Eigen::Index j = 0; j < n; ++j) {
    const dynamics::TruthState s = truth.row(j).transpose();
    const SensorTruth st = sensor_truth(t(j), s, accel_nongrav_L.row(j).transpose());
    propagate_to(st);
    ++tick_;
    if (j + 1 == n) {
      const Clock::time_point t0 = Clock::now();
      out_.filter_status = worse(out_.filter_status, filter_.add_process_noise(Q_period_));
      out_.time_filter += seconds(t0, Clock::now());
    }
    sample(st, false);
  }
  finish(phi_ref);
  return out_;
}

}  // namespace tubempc::nav
