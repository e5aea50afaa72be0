#include "tubempc/nav/system.hpp"

#include <chrono>
#include <cmath>
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
  count(Sensor::Imu, imu_.measure(truth, imu_sample_));
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
  if (due(Sensor::StarTracker)) {
    count(Sensor::StarTracker, star_tracker_.measure(truth, star_));
    split();
    if (star_.status == SensorStatus::Ok) record(filter_.update_star_tracker(star_), Sensor::StarTracker);
    done();
  }
  if (due(Sensor::Altimeter)) {
    count(Sensor::Altimeter, altimeter_.measure(truth, alt_));
    split();
    if (alt_.status == SensorStatus::Ok) record(filter_.update_altimeter(alt_), Sensor::Altimeter);
    done();
  }
  if (due(Sensor::Camera)) {
    count(Sensor::Camera, camera_.measure(truth, frame_));
    out_.landmarks_visible = frame_.status == SensorStatus::Ok ? frame_.count : 0;
    split();
    if (frame_.status == SensorStatus::Ok) record(filter_.update_camera(frame_), Sensor::Camera);
    done();
  }
  out_.time_sensors += seconds(t0, Clock::now());
}

void NavigationSystem::finish(const Eigen::Vector3d& phi_ref) {
  const Clock::time_point t0 = Clock::now();
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
