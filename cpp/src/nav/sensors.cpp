#include "tubempc/nav/sensors.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace tubempc::nav {

namespace {

[[noreturn]] void fail(const char* sensor, const char* field, const std::string& why) {
  throw std::invalid_argument(std::string(sensor) + "." + field + ": " + why);
}

void check_nonnegative(const char* sensor, const char* field, double x) {
  if (!(std::isfinite(x) && x >= 0.0))
    fail(sensor, field, "must be finite and >= 0, got " + std::to_string(x));
}
void check_positive(const char* sensor, const char* field, double x) {
  if (!(std::isfinite(x) && x > 0.0)) fail(sensor, field, "must be finite and > 0, got " + std::to_string(x));
}
void check_probability(const char* sensor, double p) {
  if (!(p >= 0.0 && p <= 1.0))
    fail(sensor, "dropout_probability", "must lie in [0, 1], got " + std::to_string(p));
}

bool finite(const SensorTruth& s) {
  return std::isfinite(s.t) && s.r_L.allFinite() && s.q_BL.allFinite() && s.q_BL.norm() > 1e-12 &&
         s.omega_BL_B.allFinite() && s.omega_LI_L.allFinite() && s.accel_nongrav_L.allFinite() &&
         s.C_AL.allFinite();
}

Eigen::Vector3d normal3(Random& rng) {
  const double a = rng.normal(), b = rng.normal(), c = rng.normal();
  return {a, b, c};
}

}  // namespace

const char* to_string(SensorStatus s) { return core::enum_name(s); }

// ---- altimeter ---------------------------------------------------------------------------------

void AltimeterSettings::validate() const {
  constexpr const char* s = "altimeter";
  if (!boresight_B.allFinite() || !(boresight_B.norm() > 0.0))
    fail(s, "boresight_B", "must be finite and non-zero");
  check_nonnegative(s, "sigma", sigma);
  if (!std::isfinite(bias)) fail(s, "bias", "must be finite");
  check_nonnegative(s, "min_range", min_range);
  if (!(std::isfinite(max_range) && max_range > min_range))
    fail(s, "max_range", "must be finite and > min_range");
  check_positive(s, "period", period);
  check_probability(s, dropout_probability);
}

Altimeter::Altimeter(std::shared_ptr<const RayCaster> caster, const AltimeterSettings& settings,
                     std::uint64_t seed)
    : caster_(std::move(caster)), settings_(settings), rng_(seed) {
  if (!caster_) throw std::invalid_argument("altimeter: caster must not be null");
  settings_.validate();
  boresight_B_ = settings_.boresight_B.normalized();
}

RayHit Altimeter::true_range(const Eigen::Vector3d& r_A, const Eigen::Vector3d& boresight_A,
                             double max_range) const {
  return caster_->cast(r_A, boresight_A, max_range);
}

SensorStatus Altimeter::measure(const SensorTruth& truth, AltimeterMeasurement& out) noexcept {
  out.t = truth.t;
  out.range = 0.0;
  if (!finite(truth)) return out.status = SensorStatus::InvalidInput;
  if (rng_.uniform() < settings_.dropout_probability) return out.status = SensorStatus::Dropout;
  const Eigen::Matrix3d C_LB = math::rotation_matrix(truth.q_BL);
  const Eigen::Vector3d r_A = truth.C_AL * truth.r_L;
  const Eigen::Vector3d b_A = truth.C_AL * (C_LB * boresight_B_);
  const RayHit h = true_range(r_A, b_A, settings_.max_range);
  if (!h.hit || h.distance < settings_.min_range) return out.status = SensorStatus::OutOfRange;
  out.range = h.distance + settings_.bias + settings_.sigma * rng_.normal();
  return out.status = SensorStatus::Ok;
}

// ---- landmarks and camera ----------------------------------------------------------------------

std::vector<Landmark> generate_landmarks(const RayCaster& caster, int count) {
  if (count < 1) throw std::invalid_argument("generate_landmarks: count must be >= 1");
  std::vector<Landmark> out;
  std::vector<bool> taken(static_cast<std::size_t>(caster.n_faces()), false);
  const double golden = 3.14159265358979323846 * (3.0 - std::sqrt(5.0));
  const double reach = 2.0 * caster.size();
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / count;
    const double rho = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Eigen::Vector3d u(rho * std::cos(golden * i), rho * std::sin(golden * i), z);
    const RayHit h = caster.cast(caster.box_center_A() + reach * u, -u, 2.0 * reach);
    if (!h.hit || taken[static_cast<std::size_t>(h.face)]) continue;
    taken[static_cast<std::size_t>(h.face)] = true;
    out.push_back(Landmark{h.point_A, h.normal_A, h.face});
  }
  return out;
}

void CameraSettings::validate() const {
  constexpr const char* s = "camera";
  check_positive(s, "focal_length_px", focal_length_px);
  if (width_px < 1) fail(s, "width_px", "must be >= 1");
  if (height_px < 1) fail(s, "height_px", "must be >= 1");
  check_nonnegative(s, "pixel_sigma", pixel_sigma);
  if (!pixel_bias.allFinite()) fail(s, "pixel_bias", "must be finite");
  if (!C_BC.allFinite() || !(C_BC.transpose() * C_BC).isIdentity(1e-9) || !(C_BC.determinant() > 0.0))
    fail(s, "C_BC", "must be a rotation matrix");
  constexpr double half_pi = 1.5707963267948966;
  if (!(max_emission_angle > 0.0 && max_emission_angle <= half_pi))
    fail(s, "max_emission_angle", "must lie in (0, pi/2]");
  if (!(max_incidence_angle > 0.0 && max_incidence_angle <= 2.0 * half_pi))
    fail(s, "max_incidence_angle", "must lie in (0, pi]");
  check_nonnegative(s, "min_range", min_range);
  if (!(std::isfinite(max_range) && max_range > min_range))
    fail(s, "max_range", "must be finite and > min_range");
  if (max_landmarks < 1 || max_landmarks > kMaxLandmarksPerFrame)
    fail(s, "max_landmarks", "must lie in [1, " + std::to_string(kMaxLandmarksPerFrame) + "]");
  check_positive(s, "period", period);
  check_probability(s, dropout_probability);
}

double CameraSettings::focal_length_from_fov(double fov_rad, int width_px) {
  if (!(fov_rad > 0.0 && fov_rad < 3.14159265358979323846)) fail("camera", "fov", "must lie in (0, pi)");
  if (width_px < 1) fail("camera", "width_px", "must be >= 1");
  return width_px / (2.0 * std::tan(0.5 * fov_rad));
}

NavCamera::NavCamera(std::shared_ptr<const RayCaster> caster, std::vector<Landmark> landmarks,
                     const CameraSettings& settings, std::uint64_t seed)
    : caster_(std::move(caster)), landmarks_(std::move(landmarks)), settings_(settings), rng_(seed) {
  if (!caster_) throw std::invalid_argument("camera: caster must not be null");
  if (landmarks_.empty()) throw std::invalid_argument("camera: the landmark catalogue must not be empty");
  settings_.validate();
  cos_emission_ = std::cos(settings_.max_emission_angle);
  cos_incidence_ = std::cos(settings_.max_incidence_angle);
}

bool NavCamera::project(const Eigen::Vector3d& s_C, Eigen::Vector2d& pixel) const {
  if (!(s_C.z() > 0.0)) return false;
  const double f = settings_.focal_length_px;
  pixel << 0.5 * settings_.width_px + f * s_C.x() / s_C.z(),
      0.5 * settings_.height_px + f * s_C.y() / s_C.z();
  return pixel.x() >= 0.0 && pixel.x() <= settings_.width_px && pixel.y() >= 0.0 &&
         pixel.y() <= settings_.height_px;
}

bool NavCamera::visible_from(int i, const Eigen::Vector3d& r_A, const Eigen::Matrix3d& C_CA,
                             const Eigen::Vector3d& sun_A, Eigen::Vector2d& pixel) const {
  const Landmark& lm = landmarks_[static_cast<std::size_t>(i)];
  const Eigen::Vector3d view_A = r_A - lm.p_A;  // landmark -> camera
  const double range = view_A.norm();
  if (!(range >= settings_.min_range && range <= settings_.max_range)) return false;
  if (lm.normal_A.dot(view_A) < cos_emission_ * range) return false;
  if (lm.normal_A.dot(sun_A) < cos_incidence_) return false;
  if (!project(C_CA * (-view_A), pixel)) return false;
  return !caster_->blocked(lm.p_A, r_A, 1e-9 * caster_->size());
}

bool NavCamera::visible(int i, const SensorTruth& truth, Eigen::Vector2d& pixel) const {
  if (i < 0 || i >= static_cast<int>(landmarks_.size()) || !finite(truth)) return false;
  const Eigen::Matrix3d C_CA =
      settings_.C_BC.transpose() * math::rotation_matrix(truth.q_BL).transpose() * truth.C_AL.transpose();
  return visible_from(i, truth.C_AL * truth.r_L, C_CA, -truth.C_AL.col(0), pixel);  // the Sun is along -x_L
}

SensorStatus NavCamera::measure(const SensorTruth& truth, CameraFrame& out) noexcept {
  out.t = truth.t;
  out.count = 0;
  if (!finite(truth)) return out.status = SensorStatus::InvalidInput;
  if (rng_.uniform() < settings_.dropout_probability) return out.status = SensorStatus::Dropout;
  const Eigen::Vector3d r_A = truth.C_AL * truth.r_L;
  const Eigen::Matrix3d C_CA =
      settings_.C_BC.transpose() * math::rotation_matrix(truth.q_BL).transpose() * truth.C_AL.transpose();
  const Eigen::Vector3d sun_A = -truth.C_AL.col(0);
  Eigen::Vector2d pixel;
  for (int i = 0; i < static_cast<int>(landmarks_.size()) && out.count < settings_.max_landmarks; ++i) {
    if (!visible_from(i, r_A, C_CA, sun_A, pixel)) continue;
    LandmarkObservation& o = out.observations[static_cast<std::size_t>(out.count++)];
    o.landmark = i;
    const double nu = rng_.normal(), nv = rng_.normal();
    o.pixel = pixel + settings_.pixel_bias + settings_.pixel_sigma * Eigen::Vector2d(nu, nv);
  }
  return out.status = out.count > 0 ? SensorStatus::Ok : SensorStatus::NoLandmarkVisible;
}

// ---- IMU ---------------------------------------------------------------------------------------

void ImuSettings::validate() const {
  constexpr const char* s = "imu";
  check_positive(s, "period", period);
  check_nonnegative(s, "gyro_noise_density", gyro_noise_density);
  check_nonnegative(s, "gyro_bias_sigma", gyro_bias_sigma);
  check_nonnegative(s, "gyro_bias_random_walk", gyro_bias_random_walk);
  check_nonnegative(s, "accel_noise_density", accel_noise_density);
  check_nonnegative(s, "accel_bias_sigma", accel_bias_sigma);
  check_nonnegative(s, "accel_bias_random_walk", accel_bias_random_walk);
  check_probability(s, dropout_probability);
}

Imu::Imu(const ImuSettings& settings, std::uint64_t seed) : settings_(settings), rng_(seed) {
  settings_.validate();
  b_g_ = settings_.gyro_bias_sigma * normal3(rng_);
  b_a_ = settings_.accel_bias_sigma * normal3(rng_);
}

SensorStatus Imu::measure(const SensorTruth& truth, ImuSample& out) noexcept {
  out.t = truth.t;
  if (!finite(truth)) return out.status = SensorStatus::InvalidInput;
  const bool lost = rng_.uniform() < settings_.dropout_probability;
  const double root_period = std::sqrt(settings_.period);
  if (!lost) {
    const Eigen::Matrix3d C_BL = math::rotation_matrix(truth.q_BL).transpose();
    out.specific_force_B =
        C_BL * truth.accel_nongrav_L + b_a_ + (settings_.accel_noise_density / root_period) * normal3(rng_);
    out.omega_BI_B = truth.omega_BL_B + C_BL * truth.omega_LI_L + b_g_ +
                     (settings_.gyro_noise_density / root_period) * normal3(rng_);
  }
  b_g_ += settings_.gyro_bias_random_walk * root_period * normal3(rng_);
  b_a_ += settings_.accel_bias_random_walk * root_period * normal3(rng_);
  return out.status = lost ? SensorStatus::Dropout : SensorStatus::Ok;
}

// ---- star tracker ------------------------------------------------------------------------------

void StarTrackerSettings::validate() const {
  constexpr const char* s = "star_tracker";
  check_positive(s, "period", period);
  if (!sigma_B.allFinite() || (sigma_B.array() < 0.0).any()) fail(s, "sigma_B", "must be finite and >= 0");
  if (!misalignment_B.allFinite()) fail(s, "misalignment_B", "must be finite");
  check_probability(s, dropout_probability);
}

StarTracker::StarTracker(const StarTrackerSettings& settings, std::uint64_t seed)
    : settings_(settings), rng_(seed) {
  settings_.validate();
}

SensorStatus StarTracker::measure(const SensorTruth& truth, StarTrackerMeasurement& out) noexcept {
  out.t = truth.t;
  if (!finite(truth)) return out.status = SensorStatus::InvalidInput;
  if (rng_.uniform() < settings_.dropout_probability) return out.status = SensorStatus::Dropout;
  const Eigen::Vector3d error = settings_.misalignment_B + settings_.sigma_B.cwiseProduct(normal3(rng_));
  out.q_BL = math::quat_normalize(math::quat_mul(math::quat_normalize(truth.q_BL), math::exp_map(error)));
  return out.status = SensorStatus::Ok;
}

}  // namespace tubempc::nav
