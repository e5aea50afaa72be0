#include "tubempc/nav/filter.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "tubempc/math/so3.hpp"

namespace tubempc::nav {

namespace {

using Mat15 = NavCovariance;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

[[noreturn]] void fail(const char* field, const std::string& why) {
  throw std::invalid_argument(std::string("filter.") + field + ": " + why);
}

bool finite(const NavState& x) {
  return std::isfinite(x.t) && x.r_L.allFinite() && x.v_L.allFinite() && x.q_BL.allFinite() &&
         x.q_BL.norm() > 1e-12 && x.gyro_bias_B.allFinite() && x.accel_bias_B.allFinite();
}

bool same_time(double a, double b) { return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b)); }

Mat15 symmetric(const Mat15& P) { return 0.5 * (P + P.transpose()); }

// Drops the cross-covariances between translation [r, v, b_a] and attitude [theta, b_g] (FilterSettings::split).
void decouple(Mat15& P) {
  P.block<6, 6>(0, 6).setZero();
  P.block<6, 6>(6, 0).setZero();
  P.block<3, 6>(12, 6).setZero();
  P.block<6, 3>(6, 12).setZero();
}

// The columns of dx a landmark's pixel depends on: dr (0..2) and dtheta (6..8).
using Mat2x6 = Eigen::Matrix<double, 2, 6>;
using Mat15x6 = Eigen::Matrix<double, kNavStates, 6>;

// The rotations a frame's landmarks share: C_LA = C_AL^T and C_CL = C_BC^T C_LB^T (camera from L).
struct CameraView {
  Eigen::Matrix3d C_LA;
  Eigen::Matrix3d C_CL;
  Eigen::Matrix3d C_CB;
};

CameraView camera_view(const dynamics::ProximityModel& model, const CameraSettings& cam, const NavState& x) {
  CameraView view;
  view.C_LA = model.C_AL(x.t).transpose();
  view.C_CB = cam.C_BC.transpose();
  view.C_CL = view.C_CB * math::rotation_matrix(x.q_BL).transpose();
  return view;
}

// Pixel of the landmark p_A seen from r_L and its Jacobian on [dr, dtheta] (2 x 6; the dtheta part zero
// for the split filter); false when it is behind the camera.
bool project(const CameraSettings& cam, const CameraView& view, const Eigen::Vector3d& r_L,
             const Eigen::Vector3d& p_A, bool split, Eigen::Vector2d& pixel, Mat2x6* H) {
  const Eigen::Vector3d s_L = view.C_LA * p_A - r_L;
  const Eigen::Vector3d s_C = view.C_CL * s_L;
  if (!(s_C.z() > 1e-6 * s_C.norm())) return false;
  const double f = cam.focal_length_px, iz = 1.0 / s_C.z();
  pixel << 0.5 * cam.width_px + f * s_C.x() * iz, 0.5 * cam.height_px + f * s_C.y() * iz;
  if (H != nullptr) {
    Eigen::Matrix<double, 2, 3> J;
    J << f * iz, 0.0, -f * s_C.x() * iz * iz, 0.0, f * iz, -f * s_C.y() * iz * iz;
    H->leftCols<3>().noalias() = -J * view.C_CL;
    if (split) {
      H->rightCols<3>().setZero();
    } else {
      const Eigen::Vector3d s_B = view.C_CB.transpose() * s_C;
      H->rightCols<3>().noalias() = J * view.C_CB * math::skew(s_B);
    }
  }
  return true;
}

// An update call's status from its counts: Ok when anything was folded in, else NumericalFailure when a
// measurement failed for numerics, else Rejected (the gate).
FilterStatus outcome(const UpdateResult& r) {
  if (r.accepted > 0) return FilterStatus::Ok;
  return r.failed > 0 ? FilterStatus::NumericalFailure : FilterStatus::Rejected;
}

}  // namespace

const char* to_string(FilterStatus s) { return core::enum_name(s); }

NavErrorVector nav_error(const NavState& estimate, const NavState& truth) {
  NavErrorVector dx;
  dx.segment<3>(0) = truth.r_L - estimate.r_L;
  dx.segment<3>(3) = truth.v_L - estimate.v_L;
  dx.segment<3>(6) = math::log_map(
      math::quat_mul(math::quat_conj(math::quat_normalize(estimate.q_BL)), math::quat_normalize(truth.q_BL)));
  dx.segment<3>(9) = truth.gyro_bias_B - estimate.gyro_bias_B;
  dx.segment<3>(12) = truth.accel_bias_B - estimate.accel_bias_B;
  return dx;
}

double nees(const NavState& estimate, const NavCovariance& covariance, const NavState& truth) {
  const Eigen::LLT<NavCovariance> llt(symmetric(covariance));
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  const NavErrorVector dx = nav_error(estimate, truth);
  return dx.dot(llt.solve(dx));
}

void FilterSettings::validate() const {
  altimeter.validate();
  camera.validate();
  if (!(camera.pixel_sigma > 0.0))
    fail("camera.pixel_sigma", "must be > 0 (a frame's landmarks are folded in as information, R^-1)");
  star_tracker.validate();
  imu.validate();
  if (!(std::isfinite(accel_model_noise) && accel_model_noise >= 0.0))
    fail("accel_model_noise", "must be finite and >= 0");
  if (!(std::isfinite(altimeter_terrain_sigma) && altimeter_terrain_sigma >= 0.0))
    fail("altimeter_terrain_sigma", "must be finite and >= 0");
  if (!(innovation_gate > 0.0)) fail("innovation_gate", "must be > 0");
  if (!(std::isfinite(gravity_relinearization_distance) && gravity_relinearization_distance >= 0.0))
    fail("gravity_relinearization_distance", "must be finite and >= 0");
  if (!(std::isfinite(gravity_expansion_tolerance) && gravity_expansion_tolerance >= 0.0))
    fail("gravity_expansion_tolerance", "must be finite and >= 0");
  if (!(std::isfinite(max_step) && max_step > 0.0)) fail("max_step", "must be finite and > 0");
  if (!(std::isfinite(covariance_step) && covariance_step >= 0.0))
    fail("covariance_step", "must be finite and >= 0");
  if (max_substeps < 1) fail("max_substeps", "must be >= 1");
}

NavigationFilter::NavigationFilter(std::shared_ptr<const dynamics::ProximityModel> model,
                                   std::shared_ptr<const RayCaster> caster, std::vector<Landmark> landmarks,
                                   const FilterSettings& settings)
    : model_(std::move(model)),
      caster_(std::move(caster)),
      landmarks_(std::move(landmarks)),
      settings_(settings) {
  if (!model_) throw std::invalid_argument("filter: model must not be null");
  if (!caster_) throw std::invalid_argument("filter: caster must not be null");
  settings_.validate();
  gravity_ = gravity::ExpansionHold(settings_.gravity_relinearization_distance,
                                    settings_.gravity_expansion_tolerance);
  boresight_B_ = settings_.altimeter.boresight_B.normalized();
  const double n = model_->mean_motion();
  D_tidal_ = (n * n * Eigen::Vector3d(3.0, 0.0, -1.0)).asDiagonal();
  omega_LI_L_ = Eigen::Vector3d(0.0, 0.0, n);
  const ImuSettings& imu_s = settings_.imu;
  Qc_.block<3, 3>(3, 3).diagonal().setConstant(imu_s.accel_noise_density * imu_s.accel_noise_density +
                                               settings_.accel_model_noise * settings_.accel_model_noise);
  Qc_.block<3, 3>(6, 6).diagonal().setConstant(imu_s.gyro_noise_density * imu_s.gyro_noise_density);
  Qc_.block<3, 3>(9, 9).diagonal().setConstant(imu_s.gyro_bias_random_walk * imu_s.gyro_bias_random_walk);
  Qc_.block<3, 3>(12, 12).diagonal().setConstant(imu_s.accel_bias_random_walk * imu_s.accel_bias_random_walk);
}

FilterStatus NavigationFilter::initialize(const NavState& x0, const NavCovariance& P0) {
  if (!finite(x0) || !P0.allFinite()) return FilterStatus::InvalidInput;
  const Eigen::LLT<NavCovariance> llt(symmetric(P0));
  if (llt.info() != Eigen::Success) return FilterStatus::InvalidInput;
  x_ = x0;
  x_.q_BL = math::quat_normalize(x0.q_BL);
  P_ = symmetric(P0);
  if (settings_.split) decouple(P_);
  F_pending_.setZero();
  pending_span_ = 0.0;
  f_B_ = x_.accel_bias_B;  // no IMU sample yet: zero specific force and rate
  omega_BI_B_ = x_.gyro_bias_B + math::rotation_matrix(x_.q_BL).transpose() * omega_LI_L_;
  rate_sampled_ = false;
  initialized_ = true;
  return FilterStatus::Ok;
}

FilterStatus NavigationFilter::add_process_noise(const NavCovariance& Q) {
  if (!initialized_ || !Q.allFinite()) return FilterStatus::InvalidInput;
  propagate_covariance();
  P_ = symmetric(P_ + Q);
  if (settings_.split) decouple(P_);
  return FilterStatus::Ok;
}

FilterStatus NavigationFilter::propagate(double t_to, const ImuSample& imu) {
  if (!initialized_ || !std::isfinite(t_to) || t_to < x_.t) return FilterStatus::InvalidInput;
  FilterStatus status = FilterStatus::Ok;
  // Two gyro samples that bracket the interval (the last good one at the filter's time, this one at
  // t_to): the attitude follows the rate interpolated linearly between them (M30), exact for a
  // constant angular acceleration; otherwise the rate is held.
  const Eigen::Vector3d omega_start = omega_BI_B_;
  bool ramp = false;
  if (imu.status == SensorStatus::Ok && imu.specific_force_B.allFinite() && imu.omega_BI_B.allFinite()) {
    const double tol = 1e-9 * (1.0 + std::abs(t_to));
    ramp = rate_sampled_ && std::abs(rate_time_ - x_.t) <= tol && std::abs(imu.t - t_to) <= tol;
    f_B_ = imu.specific_force_B;
    omega_BI_B_ = imu.omega_BI_B;
    rate_time_ = imu.t;
    rate_sampled_ = true;
  } else {
    status = FilterStatus::ImuHeld;
  }
  const double span = t_to - x_.t;
  if (span == 0.0) return status;
  const double pieces = std::ceil(span / settings_.max_step - 1e-9);
  if (!(pieces <= settings_.max_substeps)) return FilterStatus::StepTooLong;
  const int n_sub = std::max(1, static_cast<int>(pieces));
  const double h = span / n_sub;

  const NavState x_backup = x_;
  const Mat15 P_backup = P_;
  const Mat15 F_backup = F_pending_;
  const double span_backup = pending_span_;
  const auto undo = [&] {
    x_ = x_backup;
    P_ = P_backup;
    F_pending_ = F_backup;
    pending_span_ = span_backup;
  };
  const double flush_at = settings_.covariance_step * (1.0 - 1e-9);
  const Eigen::Matrix3d coriolis = -2.0 * math::skew(omega_LI_L_);
  for (int s = 0; s < n_sub; ++s) {
    const double t = x_.t;
    const Eigen::Vector3d f_hat = f_B_ - x_.accel_bias_B;
    const double mid = (static_cast<double>(s) + 0.5) / static_cast<double>(n_sub);
    const Eigen::Vector3d w_BI =
        (ramp ? Eigen::Vector3d(omega_start + mid * (omega_BI_B_ - omega_start)) : omega_BI_B_) -
        x_.gyro_bias_B;
    const Eigen::Matrix3d C_LB = math::rotation_matrix(x_.q_BL);
    const Eigen::Matrix3d C_AL = model_->C_AL(t);
    const Eigen::Vector3d r_A = C_AL * x_.r_L;
    if (!gravity_.hold(*model_->gravity(), r_A)) {  // r = 0: nothing to propagate
      undo();
      return FilterStatus::NumericalFailure;
    }
    // M42: the first-order expansion about r0, rotated into L at the sub-step's start.
    const Eigen::Matrix3d G = C_AL.transpose() * gravity_.gradient_A() * C_AL;
    const Eigen::Vector3d a_grav = C_AL.transpose() * gravity_.acceleration(r_A);
    // Translation: M1 with that affine gravity over the sub-step (exact for it to O(h^5)).
    Mat6 A = Mat6::Zero();
    A.block<3, 3>(0, 3).setIdentity();
    A.block<3, 3>(3, 0) = G + D_tidal_;
    A.block<3, 3>(3, 3) = coriolis;
    Vec6 z;
    z << x_.r_L, x_.v_L;
    Vec6 c = Vec6::Zero();
    c.tail<3>() = a_grav - G * x_.r_L + C_LB * f_hat;
    const Vec6 d1 = A * z + c;
    const Vec6 d2 = A * d1, d3 = A * d2, d4 = A * d3;
    z += h * d1 + (h * h / 2.0) * d2 + (h * h * h / 6.0) * d3 + (h * h * h * h / 24.0) * d4;
    // Attitude: the rate at the sub-step's midpoint held over it.
    const Eigen::Vector3d w_BL = w_BI - C_LB.transpose() * omega_LI_L_;
    x_.q_BL = math::quat_normalize(math::quat_mul(x_.q_BL, math::exp_map(w_BL * h)));
    x_.r_L = z.head<3>();
    x_.v_L = z.tail<3>();
    x_.t = (s + 1 == n_sub) ? t_to : t + h;
    // The error dynamics' integral over the sub-step, for the covariance (M30 over the pending span).
    F_pending_.block<6, 6>(0, 0) += h * A;
    F_pending_.block<3, 3>(3, 6) -= h * C_LB * math::skew(f_hat);
    F_pending_.block<3, 3>(3, 12) -= h * C_LB;
    F_pending_.block<3, 3>(6, 6) -= h * math::skew(w_BI);
    F_pending_.block<3, 3>(6, 9).diagonal().array() -= h;
    pending_span_ += h;
    if (pending_span_ >= flush_at) propagate_covariance();
  }
  if (!finite(x_) || !P_.allFinite() || !F_pending_.allFinite()) {
    undo();
    return FilterStatus::NumericalFailure;
  }
  return status;
}

void NavigationFilter::propagate_covariance() const {
  if (!(pending_span_ > 0.0)) return;
  // M30 with F the mean of the sub-steps' error dynamics over the span h (Taylor series of Phi and Van
  // Loan's integral to h^3).
  const double h = pending_span_;
  const Mat15 F = F_pending_ / h;
  const Mat15 F2 = F * F;
  const Mat15 Phi = Mat15::Identity() + h * F + (h * h / 2.0) * F2 + (h * h * h / 6.0) * F2 * F;
  const Mat15 FQ = F * Qc_;
  const Mat15 FFQ = F * FQ;
  const Mat15 Qd = h * Qc_ + (h * h / 2.0) * (FQ + FQ.transpose()) +
                   (h * h * h / 6.0) * (FFQ + 2.0 * FQ * F.transpose() + FFQ.transpose());
  P_ = symmetric(Phi * P_ * Phi.transpose() + Qd);
  if (settings_.split) decouple(P_);
  F_pending_.setZero();
  pending_span_ = 0.0;
}

template <int M>
bool NavigationFilter::fold(const Eigen::Matrix<double, M, 1>& residual,
                            const Eigen::Matrix<double, M, kNavStates>& H,
                            const Eigen::Matrix<double, M, M>& R, UpdateResult& result) {
  using MatM = Eigen::Matrix<double, M, M>;
  propagate_covariance();
  const Eigen::Matrix<double, M, kNavStates> HP = H * P_;
  const MatM S = HP * H.transpose() + R;
  const Eigen::LLT<MatM> llt(0.5 * (S + S.transpose()));
  if (llt.info() != Eigen::Success || !residual.allFinite()) {
    ++result.rejected;
    ++result.failed;
    return false;
  }
  const double nis = residual.dot(llt.solve(residual));
  if (!(nis <= settings_.innovation_gate)) {
    ++result.rejected;
    return false;
  }
  const Eigen::Matrix<double, kNavStates, M> K = llt.solve(HP).transpose();
  const NavErrorVector dx = K * residual;
  const NavState x_backup = x_;
  const Mat15 P_backup = P_;
  // Joseph form (I - K H) P (I - K H)^T + K R K^T, expanded (an identity for any K): O(15^2 M).
  const Mat15 KHP = K * HP;
  P_ = symmetric(P_ - KHP - KHP.transpose() + K * S * K.transpose());
  inject(dx);
  if (settings_.split) decouple(P_);
  if (!finite(x_) || !P_.allFinite()) {
    x_ = x_backup;
    P_ = P_backup;
    ++result.rejected;
    ++result.failed;
    return false;
  }
  ++result.accepted;
  result.nis += nis;
  result.dof += M;
  return true;
}

void NavigationFilter::inject(const NavErrorVector& dx) {
  x_.r_L += dx.segment<3>(0);
  x_.v_L += dx.segment<3>(3);
  const Eigen::Vector3d dtheta = dx.segment<3>(6);
  x_.q_BL = math::quat_normalize(math::quat_mul(x_.q_BL, math::exp_map(dtheta)));
  x_.gyro_bias_B += dx.segment<3>(9);
  x_.accel_bias_B += dx.segment<3>(12);
  // Reset of the attitude error to the new estimate (first order).
  const Eigen::Matrix3d Gamma = Eigen::Matrix3d::Identity() - 0.5 * math::skew(dtheta);
  const Eigen::Matrix<double, 3, kNavStates> rows = Gamma * P_.middleRows<3>(6);
  P_.middleRows<3>(6) = rows;
  const Eigen::Matrix<double, kNavStates, 3> cols = P_.middleCols<3>(6) * Gamma.transpose();
  P_.middleCols<3>(6) = cols;
  P_ = symmetric(P_);
}

bool NavigationFilter::predict_range(double& range, Eigen::Matrix<double, 1, kNavStates>* H) const {
  if (!initialized_) return false;
  const Eigen::Matrix3d C_LB = math::rotation_matrix(x_.q_BL);
  const Eigen::Matrix3d C_AL = model_->C_AL(x_.t);
  const Eigen::Vector3d d_L = C_LB * boresight_B_;
  const RayHit hit = caster_->cast(C_AL * x_.r_L, C_AL * d_L, 2.0 * settings_.altimeter.max_range);
  const Eigen::Vector3d n_L = C_AL.transpose() * hit.normal_A;
  const double nd = n_L.dot(d_L);
  if (!hit.hit || !(std::abs(nd) > 1e-3)) return false;
  range = hit.distance;
  if (H != nullptr) {
    // range = n.(p - r) / n.d on the face's plane; d = C_LB Exp(dtheta) b_B.
    H->setZero();
    H->block<1, 3>(0, 0) = -n_L.transpose() / nd;
    if (!settings_.split)
      H->block<1, 3>(0, 6) = hit.distance * n_L.transpose() * C_LB * math::skew(boresight_B_) / nd;
  }
  return true;
}

UpdateResult NavigationFilter::update_altimeter(const AltimeterMeasurement& m) {
  UpdateResult result;
  if (!initialized_) return result.status = FilterStatus::InvalidInput, result;
  if (m.status != SensorStatus::Ok) return result.status = FilterStatus::NoMeasurement, result;
  if (!std::isfinite(m.range)) return result.status = FilterStatus::InvalidInput, result;
  if (!same_time(m.t, x_.t)) return result.status = FilterStatus::TimeMismatch, result;
  double range = 0.0;
  Eigen::Matrix<double, 1, kNavStates> H;
  if (!predict_range(range, &H)) {
    result.rejected = 1;
    return result.status = FilterStatus::NoPrediction, result;
  }
  const Eigen::Matrix<double, 1, 1> y(m.range - settings_.altimeter.bias - range);
  const Eigen::Matrix<double, 1, 1> R(settings_.altimeter.sigma * settings_.altimeter.sigma +
                                      settings_.altimeter_terrain_sigma * settings_.altimeter_terrain_sigma);
  fold<1>(y, H, R, result);
  result.status = outcome(result);
  return result;
}

bool NavigationFilter::predict_pixel(int landmark, Eigen::Vector2d& pixel,
                                     Eigen::Matrix<double, 2, kNavStates>* H) const {
  if (!initialized_ || landmark < 0 || landmark >= static_cast<int>(landmarks_.size())) return false;
  Mat2x6 H6;
  if (!project(settings_.camera, camera_view(*model_, settings_.camera, x_), x_.r_L,
               landmarks_[static_cast<std::size_t>(landmark)].p_A, settings_.split, pixel,
               H != nullptr ? &H6 : nullptr))
    return false;
  if (H != nullptr) {
    H->setZero();
    H->block<2, 3>(0, 0) = H6.leftCols<3>();
    H->block<2, 3>(0, 6) = H6.rightCols<3>();
  }
  return true;
}

UpdateResult NavigationFilter::update_camera(const CameraFrame& frame) {
  UpdateResult result;
  if (!initialized_) return result.status = FilterStatus::InvalidInput, result;
  if (frame.status != SensorStatus::Ok) return result.status = FilterStatus::NoMeasurement, result;
  if (!same_time(frame.t, x_.t)) return result.status = FilterStatus::TimeMismatch, result;
  propagate_covariance();
  const CameraView view = camera_view(*model_, settings_.camera, x_);
  // The frame's prior covariance on the columns E = [dr, dtheta] the pixels touch: P E and E^T P E.
  Mat15x6 PE;
  PE << P_.middleCols<3>(0), P_.middleCols<3>(6);
  Mat6 P_ee;
  P_ee << PE.middleRows<3>(0), PE.middleRows<3>(6);
  const double var = settings_.camera.pixel_sigma * settings_.camera.pixel_sigma;
  const Eigen::Matrix2d R = Eigen::Vector2d::Constant(var).asDiagonal();
  // Each landmark is gated against the frame's prior (its NIS with S_i = H_i P H_i^T + R); the accepted
  // ones' information H^T R^-1 H and H^T R^-1 y is accumulated on E.
  Mat6 info = Mat6::Zero();
  Vec6 b = Vec6::Zero();
  double yRy = 0.0;
  Mat2x6 H;
  Eigen::Vector2d pixel;
  bool predicted = false;
  int accepted = 0;
  const int count = std::min(std::max(frame.count, 0), kMaxLandmarksPerFrame);
  for (int i = 0; i < count; ++i) {
    const LandmarkObservation& o = frame.observations[static_cast<std::size_t>(i)];
    if (o.landmark < 0 || o.landmark >= static_cast<int>(landmarks_.size()) ||
        !project(settings_.camera, view, x_.r_L, landmarks_[static_cast<std::size_t>(o.landmark)].p_A,
                 settings_.split, pixel, &H)) {
      ++result.rejected;
      continue;
    }
    predicted = true;
    const Eigen::Vector2d y = o.pixel - settings_.camera.pixel_bias - pixel;
    const Eigen::Matrix2d S = H * P_ee * H.transpose() + R;
    const Eigen::LLT<Eigen::Matrix2d> llt(0.5 * (S + S.transpose()));
    if (llt.info() != Eigen::Success || !y.allFinite()) {
      ++result.rejected;
      ++result.failed;
      continue;
    }
    if (!(y.dot(llt.solve(y)) <= settings_.innovation_gate)) {
      ++result.rejected;
      continue;
    }
    info.noalias() += H.transpose() * H / var;
    b.noalias() += H.transpose() * y / var;
    yRy += y.squaredNorm() / var;
    ++accepted;
  }
  if (!predicted) return result.status = FilterStatus::NoPrediction, result;
  if (accepted == 0) return result.status = outcome(result), result;
  // The stacked Kalman update of the accepted landmarks from their information on E (Woodbury):
  // K = P H^T (H P H^T + R)^-1 = P E M^-1 E^T H^T R^-1 with M = I + info P_ee (its eigenvalues >= 1),
  // dx = P E M^-1 b, K H = P E M^-1 info E^T, K R K^T = P E M^-1 info M^-T E^T P; P in Joseph form.
  const Mat6 M = Mat6::Identity() + info * P_ee;
  const Eigen::PartialPivLU<Mat6> lu(M.transpose());
  const Mat15x6 PEMinv = lu.solve(PE.transpose()).transpose();  // P E M^-1
  const Mat15x6 KH_E = PEMinv * info;                           // K H restricted to E's columns
  const NavErrorVector dx = PEMinv * b;
  // The frame's NIS y^T S^-1 y = y^T R^-1 y - b^T (P+)_EE b, with (P+) E = P E M^-1.
  Vec6 dx_e;
  dx_e << dx.segment<3>(0), dx.segment<3>(6);
  const double nis = yRy - b.dot(dx_e);
  const NavState x_backup = x_;
  const Mat15 P_backup = P_;
  const Mat15 KHP = KH_E * PE.transpose();
  P_ = symmetric(P_ - KHP - KHP.transpose() + KH_E * P_ee * KH_E.transpose() +
                 PEMinv * info * PEMinv.transpose());
  inject(dx);
  if (settings_.split) decouple(P_);
  if (!finite(x_) || !P_.allFinite() || !std::isfinite(nis)) {
    x_ = x_backup;
    P_ = P_backup;
    result.rejected += accepted;
    result.failed += accepted;
    return result.status = FilterStatus::NumericalFailure, result;
  }
  result.accepted = accepted;
  result.nis = nis;
  result.dof = 2 * accepted;
  result.status = FilterStatus::Ok;
  return result;
}

UpdateResult NavigationFilter::update_star_tracker(const StarTrackerMeasurement& m) {
  UpdateResult result;
  if (!initialized_) return result.status = FilterStatus::InvalidInput, result;
  if (m.status != SensorStatus::Ok) return result.status = FilterStatus::NoMeasurement, result;
  if (!m.q_BL.allFinite() || !(m.q_BL.norm() > 1e-12))
    return result.status = FilterStatus::InvalidInput, result;
  if (!same_time(m.t, x_.t)) return result.status = FilterStatus::TimeMismatch, result;
  const math::Quaternion q_meas =
      math::quat_mul(math::quat_normalize(m.q_BL), math::exp_map(-settings_.star_tracker.misalignment_B));
  const Eigen::Vector3d y = math::log_map(math::quat_mul(math::quat_conj(x_.q_BL), q_meas));
  Eigen::Matrix<double, 3, kNavStates> H = Eigen::Matrix<double, 3, kNavStates>::Zero();
  H.block<3, 3>(0, 6).setIdentity();
  const Eigen::Matrix3d R = settings_.star_tracker.sigma_B.cwiseAbs2().asDiagonal();
  fold<3>(y, H, R, result);
  result.status = outcome(result);
  return result;
}

Eigen::Vector3d NavigationFilter::omega_BL_B() const {
  return omega_BI_B_ - x_.gyro_bias_B - math::rotation_matrix(x_.q_BL).transpose() * omega_LI_L_;
}

Eigen::Vector3d NavigationFilter::phi_near(const Eigen::Vector3d& phi_ref) const {
  return math::nearest_representative(math::log_map(x_.q_BL), phi_ref);
}

dynamics::StateVector NavigationFilter::model_state(const Eigen::Vector3d& phi_ref) const {
  dynamics::StateVector x;
  x << x_.r_L, x_.v_L, phi_near(phi_ref), omega_BL_B();
  return x;
}

dynamics::StateMatrix NavigationFilter::model_covariance(const Eigen::Vector3d& phi_ref) const {
  Eigen::Matrix<double, dynamics::kNx, kNavStates> J =
      Eigen::Matrix<double, dynamics::kNx, kNavStates>::Zero();
  J.block<6, 6>(0, 0).setIdentity();
  J.block<3, 3>(6, 6) = math::right_jacobian_inverse(phi_near(phi_ref));
  J.block<3, 3>(9, 9) = -Eigen::Matrix3d::Identity();
  propagate_covariance();
  dynamics::StateMatrix C = J * P_ * J.transpose();
  const double g = settings_.imu.gyro_noise_density;
  C.block<3, 3>(9, 9).diagonal().array() += g * g / settings_.imu.period;
  return 0.5 * (C + C.transpose());
}

}  // namespace tubempc::nav
