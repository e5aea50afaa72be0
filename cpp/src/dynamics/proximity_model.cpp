#include "tubempc/dynamics/proximity_model.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "tubempc/math/expm.hpp"
#include "tubempc/math/so3.hpp"

namespace tubempc::dynamics {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string num(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

void require(bool ok, const std::string& field, const std::string& rule, double value) {
  if (!ok) throw std::invalid_argument("ModelParams." + field + ": must be " + rule + ", got " + num(value));
}

template <typename Derived>
void require_finite(const Eigen::MatrixBase<Derived>& v, const char* where, const char* what) {
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v(i))) {
      throw std::domain_error(std::string(where) + ": " + what + "[" + std::to_string(i) +
                              "] is not finite (" + num(v(i)) + ")");
    }
  }
}

// Hill (tidal) gradient n^2 diag(3, 0, -1) applied to r.
Eigen::Vector3d hill_tidal(double n, const Eigen::Vector3d& r) {
  const double n2 = n * n;
  return Eigen::Vector3d(3.0 * n2 * r.x(), 0.0, -n2 * r.z());
}

}  // namespace

const char* to_string(Kinematics k) { return core::enum_name(k); }

const char* to_string(DiscretizationStatus s) { return core::enum_name(s); }

void ModelParams::validate() const {
  require(std::isfinite(mu_sun) && mu_sun >= 0.0, "mu_sun", "finite and >= 0 (m^3/s^2)", mu_sun);
  require(std::isfinite(orbit_radius) && orbit_radius > 0.0, "orbit_radius", "finite and > 0 (m)",
          orbit_radius);
  require(std::isfinite(beta_srp) && beta_srp >= 0.0, "beta_srp", "finite and >= 0 (m^3/s^2)", beta_srp);
  require(std::isfinite(spin_rate), "spin_rate", "finite (rad/s)", spin_rate);
  require(std::isfinite(spin_angle0), "spin_angle0", "finite (rad)", spin_angle0);
  require(std::isfinite(glide_slope_angle) && glide_slope_angle > 0.0 && glide_slope_angle < 0.5 * kPi,
          "glide_slope_angle", "in (0, pi/2) rad", glide_slope_angle);
  require(std::isfinite(los_angle) && los_angle > 0.0 && los_angle < 0.5 * kPi, "los_angle",
          "in (0, pi/2) rad", los_angle);
  if (!inertia_B.allFinite()) throw std::invalid_argument("ModelParams.inertia_B: must be finite");
  const double asym = (inertia_B - inertia_B.transpose()).cwiseAbs().maxCoeff();
  require(asym <= 1e-12 * inertia_B.cwiseAbs().maxCoeff(), "inertia_B", "symmetric (max |J - J^T|)", asym);
  const double lmin = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia_B).eigenvalues().minCoeff();
  require(lmin > 0.0, "inertia_B", "positive definite (smallest eigenvalue, kg m^2)", lmin);
  const double bn = boresight_B.norm();
  require(std::isfinite(bn) && bn > 1e-12, "boresight_B", "finite and nonzero (norm)", bn);
  const double an = glide_slope_axis_A.norm();
  require(std::isfinite(an) && an > 1e-12, "glide_slope_axis_A", "finite and nonzero (norm)", an);
  const double pn = glide_slope_apex_A.norm();
  require(std::isfinite(pn), "glide_slope_apex_A", "finite (norm, m)", pn);
  if (kinematics != Kinematics::FirstOrder && kinematics != Kinematics::Exact) {
    throw std::invalid_argument("ModelParams.kinematics: unknown value");
  }
}

double ModelParams::mean_motion() const {
  return std::sqrt(mu_sun / (orbit_radius * orbit_radius * orbit_radius));
}

ProximityModel::ProximityModel(std::shared_ptr<const gravity::GravityModel> gravity,
                               const ModelParams& params, std::shared_ptr<const ExtraAcceleration> extra)
    : gravity_(std::move(gravity)), params_(params), extra_(std::move(extra)) {
  if (!gravity_) throw std::invalid_argument("ProximityModel: gravity model must not be null");
  params_.validate();
  params_.boresight_B.normalize();
  params_.glide_slope_axis_A.normalize();
  n_ = params_.mean_motion();
  srp_accel_ = params_.srp_enabled ? params_.beta_srp / (params_.orbit_radius * params_.orbit_radius) : 0.0;
  J_inv_ = params_.inertia_B.inverse();
}

double ProximityModel::spin_angle(double t) const { return params_.spin_angle0 + rotation_rate_AL() * t; }

Eigen::Matrix3d ProximityModel::C_AL(double t) const {
  const double th = spin_angle(t);
  const double c = std::cos(th);
  const double s = std::sin(th);
  Eigen::Matrix3d C;
  C << c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0;
  return C;
}

void ProximityModel::glide_slope_cone_L(double t, Eigen::Vector3d& apex_L, Eigen::Vector3d& axis_L) const {
  const Eigen::Matrix3d C = C_AL(t);
  apex_L.noalias() = C.transpose() * params_.glide_slope_apex_A;
  axis_L.noalias() = C.transpose() * params_.glide_slope_axis_A;
}

math::Quaternion ProximityModel::q_AL(double t) const {
  const double h = 0.5 * spin_angle(t);
  return math::Quaternion(0.0, 0.0, -std::sin(h), std::cos(h));
}

void ProximityModel::gravity_L(double t, const Eigen::Vector3d& r_L, Eigen::Vector3d& a_L,
                               Eigen::Matrix3d& G_L) const {
  const Eigen::Matrix3d C = C_AL(t);
  gravity::GravitySample g;
  gravity_->evaluate(C * r_L, g);
  a_L.noalias() = C.transpose() * g.acceleration;
  G_L.noalias() = C.transpose() * g.gradient * C;
}

void ProximityModel::translational(double t, const Eigen::Vector3d& r, const Eigen::Vector3d& v,
                                   const Eigen::Vector3d& u_p, Eigen::Vector3d& a_L, Eigen::Matrix3d* da_dr,
                                   Eigen::Matrix3d* da_dv, const gravity::ExpansionHold* held) const {
  Eigen::Vector3d a_g;
  Eigen::Matrix3d G_L;
  if (da_dr) {
    gravity_L(t, r, a_g, G_L);
  } else {  // no Jacobian wanted (the truth derivative): the acceleration alone, or its held expansion
    const Eigen::Matrix3d C = C_AL(t);
    a_g.noalias() =
        C.transpose() * (held != nullptr ? held->acceleration(C * r) : gravity_->acceleration(C * r));
  }
  // -2 n z x v = 2 n [v_y, -v_x, 0]
  a_L = Eigen::Vector3d(2.0 * n_ * v.y(), -2.0 * n_ * v.x(), 0.0) + hill_tidal(n_, r) + a_g + u_p;
  a_L.x() += srp_accel_;
  if (da_dr) {
    *da_dr = G_L;
    (*da_dr)(0, 0) += 3.0 * n_ * n_;
    (*da_dr)(2, 2) -= n_ * n_;
    da_dv->setZero();
    (*da_dv)(0, 1) = 2.0 * n_;
    (*da_dv)(1, 0) = -2.0 * n_;
  }
  if (extra_) {
    a_L += extra_->acceleration(t, r, v);
    if (da_dr) {
      Eigen::Matrix3d Er;
      Eigen::Matrix3d Ev;
      extra_->jacobian(t, r, v, Er, Ev);
      *da_dr += Er;
      *da_dv += Ev;
    }
  }
}

Eigen::Vector3d ProximityModel::rotational(const Eigen::Matrix3d& C_BL, const Eigen::Vector3d& w,
                                           const Eigen::Vector3d& T) const {
  const Eigen::Vector3d w_LI = n_ * C_BL.col(2);  // C_BL n z_L
  const Eigen::Vector3d Om = w + w_LI;
  const Eigen::Matrix3d& J = params_.inertia_B;
  return J_inv_ * (T - Om.cross(J * Om)) + w.cross(w_LI);
}

Eigen::Vector3d ProximityModel::phi_dot(const Eigen::Vector3d& phi, const Eigen::Vector3d& omega_BL_B) const {
  if (params_.kinematics == Kinematics::FirstOrder) return omega_BL_B;
  return math::right_jacobian_inverse(phi) * omega_BL_B;
}

StateVector ProximityModel::f(double t, const StateVector& x, const InputVector& u) const {
  if (!std::isfinite(t)) throw std::domain_error("ProximityModel::f: t is not finite");
  require_finite(x, "ProximityModel::f", "x");
  require_finite(u, "ProximityModel::f", "u");
  StateVector out;
  Eigen::Vector3d a;
  translational(t, x.segment<3>(0), x.segment<3>(3), u.head<3>(), a, nullptr, nullptr);
  const Eigen::Vector3d phi = x.segment<3>(6);
  const Eigen::Vector3d w = x.segment<3>(9);
  const Eigen::Matrix3d C_BL = math::rotation_matrix(math::exp_map(phi)).transpose();
  out.segment<3>(0) = x.segment<3>(3);
  out.segment<3>(3) = a;
  out.segment<3>(6) = phi_dot(phi, w);
  out.segment<3>(9) = rotational(C_BL, w, u.tail<3>());
  return out;
}

void ProximityModel::linearize(double t, const StateVector& x, const InputVector& u, StateVector& f_out,
                               StateMatrix& A, InputMatrix& B) const {
  if (!std::isfinite(t)) throw std::domain_error("ProximityModel::linearize: t is not finite");
  require_finite(x, "ProximityModel::linearize", "x");
  require_finite(u, "ProximityModel::linearize", "u");
  A.setZero();
  B.setZero();
  const Eigen::Vector3d r = x.segment<3>(0);
  const Eigen::Vector3d v = x.segment<3>(3);
  const Eigen::Vector3d phi = x.segment<3>(6);
  const Eigen::Vector3d w = x.segment<3>(9);
  const Eigen::Vector3d T = u.tail<3>();

  // Translation.
  Eigen::Vector3d a;
  Eigen::Matrix3d da_dr;
  Eigen::Matrix3d da_dv;
  translational(t, r, v, u.head<3>(), a, &da_dr, &da_dv);
  f_out.segment<3>(0) = v;
  f_out.segment<3>(3) = a;
  A.block<3, 3>(0, 3).setIdentity();
  A.block<3, 3>(3, 0) = da_dr;
  A.block<3, 3>(3, 3) = da_dv;
  B.block<3, 3>(3, 0).setIdentity();

  // Attitude.
  Eigen::Matrix<double, 6, 1> f_r;
  Eigen::Matrix<double, 6, 6> A_r;
  Eigen::Matrix<double, 6, 3> B_r;
  rotational_jacobians(phi, w, T, f_r, A_r, B_r);
  f_out.segment<6>(6) = f_r;
  A.block<6, 6>(6, 6) = A_r;
  B.block<6, 3>(6, 3) = B_r;
}

void ProximityModel::rotational_jacobians(const Eigen::Vector3d& phi, const Eigen::Vector3d& w,
                                          const Eigen::Vector3d& T, Eigen::Matrix<double, 6, 1>& f_r,
                                          Eigen::Matrix<double, 6, 6>& A_r,
                                          Eigen::Matrix<double, 6, 3>& B_r) const {
  A_r.setZero();
  B_r.setZero();
  // Kinematics.
  if (params_.kinematics == Kinematics::FirstOrder) {
    f_r.head<3>() = w;
    A_r.block<3, 3>(0, 3).setIdentity();
  } else {
    Eigen::Matrix3d Jr_inv;
    Eigen::Matrix3d dh_dphi;
    right_jacobian_inverse_and_derivative(phi, w, Jr_inv, dh_dphi);
    f_r.head<3>() = Jr_inv * w;
    A_r.block<3, 3>(0, 0) = dh_dphi;
    A_r.block<3, 3>(0, 3) = Jr_inv;
  }

  // Rotational dynamics g = J^-1 (T - Om x J Om) + w x w_LI, Om = w + w_LI, w_LI = Exp(phi)^T n z.
  // dg/dOm|_(w_LI fixed) = -J^-1 ([Om]x J - [J Om]x); dg/dw = that - [w_LI]x;
  // dg/dw_LI = that + [w]x; dw_LI/dphi = [w_LI]x Jr(phi) (Exp(phi + d) ~ Exp(phi) Exp(Jr d)).
  const Eigen::Matrix3d C_BL = math::rotation_matrix(math::exp_map(phi)).transpose();
  const Eigen::Vector3d w_LI = n_ * C_BL.col(2);
  const Eigen::Vector3d Om = w + w_LI;
  const Eigen::Matrix3d& J = params_.inertia_B;
  const Eigen::Vector3d JOm = J * Om;
  f_r.tail<3>() = J_inv_ * (T - Om.cross(JOm)) + w.cross(w_LI);
  const Eigen::Matrix3d dgdOm = -J_inv_ * (math::skew(Om) * J - math::skew(JOm));
  A_r.block<3, 3>(3, 3) = dgdOm - math::skew(w_LI);
  A_r.block<3, 3>(3, 0) = (dgdOm + math::skew(w)) * math::skew(w_LI) * math::right_jacobian(phi);
  B_r.block<3, 3>(3, 0) = J_inv_;
}

DiscretizationStatus ProximityModel::discretize(double t, double dt, const StateVector& x_ref,
                                                const InputVector& u_ref, StateMatrix& Ad, InputMatrix& Bd,
                                                StateVector& cd) const {
  if (!std::isfinite(t) || !std::isfinite(dt) || !x_ref.allFinite() || !u_ref.allFinite()) {
    return DiscretizationStatus::NonFiniteInput;
  }
  if (params_.kinematics == Kinematics::Exact && x_ref.segment<3>(6).norm() >= 2.0 * kPi - 1e-6) {
    return DiscretizationStatus::NonFiniteResult;  // Jr^-1 singular
  }
  StateVector fx;
  StateMatrix A;
  InputMatrix B;
  linearize(t, x_ref, u_ref, fx, A, B);
  if (!fx.allFinite() || !A.allFinite()) return DiscretizationStatus::NonFiniteResult;
  const StateVector c = fx - A * x_ref - B * u_ref;
  // Translation (r, v; u_p) and rotation (phi, w; T) are decoupled in this model, so the exponential
  // of the block-diagonal augmented matrix is taken per block: two 10 x 10 exponentials instead of
  // one 19 x 19 (the same result, about 4x fewer operations). The coupling blocks are checked, not
  // assumed, and the single exponential is kept for any model where they are nonzero.
  const bool decoupled = A.topRightCorner<6, 6>().isZero(0.0) && A.bottomLeftCorner<6, 6>().isZero(0.0) &&
                         B.topRightCorner<6, 3>().isZero(0.0) && B.bottomLeftCorner<6, 3>().isZero(0.0);
  if (!decoupled) {
    if (!math::zoh_discretize<kNx, kNu>(A, B, c, dt, Ad, Bd, cd))
      return DiscretizationStatus::NonFiniteResult;
    return DiscretizationStatus::Ok;
  }
  Eigen::Matrix<double, 6, 6> Ad_p, Ad_r;
  Eigen::Matrix<double, 6, 3> Bd_p, Bd_r;
  Eigen::Matrix<double, 6, 1> cd_p, cd_r;
  const Eigen::Matrix<double, 6, 6> A_p = A.topLeftCorner<6, 6>(), A_r = A.bottomRightCorner<6, 6>();
  const Eigen::Matrix<double, 6, 3> B_p = B.topLeftCorner<6, 3>(), B_r = B.bottomRightCorner<6, 3>();
  const Eigen::Matrix<double, 6, 1> c_p = c.head<6>(), c_r = c.tail<6>();
  if (!math::zoh_discretize<6, 3>(A_p, B_p, c_p, dt, Ad_p, Bd_p, cd_p) ||
      !math::zoh_discretize<6, 3>(A_r, B_r, c_r, dt, Ad_r, Bd_r, cd_r)) {
    return DiscretizationStatus::NonFiniteResult;
  }
  Ad.setZero();
  Bd.setZero();
  Ad.topLeftCorner<6, 6>() = Ad_p;
  Ad.bottomRightCorner<6, 6>() = Ad_r;
  Bd.topLeftCorner<6, 3>() = Bd_p;
  Bd.bottomRightCorner<6, 3>() = Bd_r;
  cd << cd_p, cd_r;
  return DiscretizationStatus::Ok;
}

DiscretizationStatus ProximityModel::discretize_rotation(double dt, const Eigen::Vector3d& phi,
                                                         const Eigen::Vector3d& omega_BL_B,
                                                         const Eigen::Vector3d& T_B,
                                                         Eigen::Matrix<double, 6, 6>& Ad_r,
                                                         Eigen::Matrix<double, 6, 3>& Bd_r,
                                                         Eigen::Matrix<double, 6, 1>& cd_r) const {
  if (!std::isfinite(dt) || !phi.allFinite() || !omega_BL_B.allFinite() || !T_B.allFinite()) {
    return DiscretizationStatus::NonFiniteInput;
  }
  if (params_.kinematics == Kinematics::Exact && phi.norm() >= 2.0 * kPi - 1e-6) {
    return DiscretizationStatus::NonFiniteResult;  // Jr^-1 singular
  }
  Eigen::Matrix<double, 6, 1> f_r;
  Eigen::Matrix<double, 6, 6> A_r;
  Eigen::Matrix<double, 6, 3> B_r;
  rotational_jacobians(phi, omega_BL_B, T_B, f_r, A_r, B_r);
  if (!f_r.allFinite() || !A_r.allFinite()) return DiscretizationStatus::NonFiniteResult;
  Eigen::Matrix<double, 6, 1> x_r;
  x_r << phi, omega_BL_B;
  const Eigen::Matrix<double, 6, 1> c_r = f_r - A_r * x_r - B_r * T_B;
  if (!math::zoh_discretize<6, 3>(A_r, B_r, c_r, dt, Ad_r, Bd_r, cd_r))
    return DiscretizationStatus::NonFiniteResult;
  return DiscretizationStatus::Ok;
}

TruthState ProximityModel::truth_derivative(double t, const TruthState& s, const InputVector& u,
                                            const Eigen::Matrix<double, 6, 1>& disturbance,
                                            const gravity::ExpansionHold* gravity) const {
  TruthState ds;
  Eigen::Vector3d a;
  translational(t, s.segment<3>(0), s.segment<3>(3), u.head<3>(), a, nullptr, nullptr, gravity);
  const math::Quaternion q = s.segment<4>(6);
  const Eigen::Vector3d w = s.segment<3>(10);
  // R(q) of a non-unit q (mid-stage) is normalised inside rotation_matrix.
  const Eigen::Matrix3d C_BL = math::rotation_matrix(q).transpose();
  ds.segment<3>(0) = s.segment<3>(3);
  ds.segment<3>(3) = a + disturbance.head<3>();
  ds.segment<4>(6) = 0.5 * math::quat_mul(q, math::Quaternion(w.x(), w.y(), w.z(), 0.0));
  ds.segment<3>(10) = rotational(C_BL, w, u.tail<3>()) + disturbance.tail<3>();
  return ds;
}

void right_jacobian_inverse_and_derivative(const Eigen::Vector3d& phi, const Eigen::Vector3d& w,
                                           Eigen::Matrix3d& Jr_inv, Eigen::Matrix3d& d_Jrinv_w_dphi) {
  // Jr^-1 = I + 1/2 S + c(t) S^2, S = [phi]x, t = |phi|, c = (1 - (t/2) cot(t/2)) / t^2.
  // h = Jr^-1 w = w + 1/2 phi x w + c (phi (phi.w) - w t^2), so
  // dh/dphi = -1/2 [w]x + c ((phi.w) I + phi w^T - 2 w phi^T) + (c'/t) (phi x (phi x w)) phi^T.
  // With k = t^2 c = sum_{n>=1} |B_2n| t^2n / (2n)! (Bernoulli numbers), c'/t has the series
  // sum_{n>=2} (2n-2) |B_2n| t^(2n-4) / (2n)!, used below t = 0.5 (truncation < 1e-12 relative at t = 0.5).
  if (!phi.allFinite() || !w.allFinite()) {
    throw std::domain_error("right_jacobian_inverse_and_derivative: phi and w must be finite");
  }
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  if (t >= 2.0 * kPi - 1e-6) {
    throw std::domain_error(
        "right_jacobian_inverse_and_derivative: singular for |phi| >= 2 pi, got |phi| = " + num(t));
  }
  double c = 0.0;
  double dc_over_t = 0.0;
  if (t < 0.5) {
    // c = 1/12 + t^2/720 + t^4/30240 + t^6/1209600 + t^8/47900160 + |B_12| t^10/12! + ...
    constexpr double kB12 = 691.0 / 2730.0;
    constexpr double kB14 = 7.0 / 6.0;
    c = 1.0 / 12.0 +
        t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 + t2 * (1.0 / 1209600.0 +
                                                        t2 * (1.0 / 47900160.0 + t2 * kB12 / 479001600.0))));
    dc_over_t =
        1.0 / 360.0 +
        t2 * (1.0 / 7560.0 +
              t2 * (1.0 / 201600.0 + t2 * (8.0 / 47900160.0 + t2 * (10.0 * kB12 / 479001600.0 +
                                                                    t2 * 12.0 * kB14 / 87178291200.0))));
  } else {
    const double half = 0.5 * t;
    const double s = std::sin(half);
    const double cot = std::cos(half) / s;
    const double k = 1.0 - half * cot;
    const double dk = -0.5 * cot + t / (4.0 * s * s);
    c = k / t2;
    dc_over_t = dk / (t2 * t) - 2.0 * k / (t2 * t2);
  }
  const Eigen::Matrix3d S = math::skew(phi);
  Jr_inv = Eigen::Matrix3d::Identity() + 0.5 * S + c * S * S;
  const double pw = phi.dot(w);
  const Eigen::Vector3d ppw = phi * pw - w * t2;  // phi x (phi x w)
  d_Jrinv_w_dphi = -0.5 * math::skew(w) +
                   c * (pw * Eigen::Matrix3d::Identity() + phi * w.transpose() - 2.0 * w * phi.transpose()) +
                   dc_over_t * ppw * phi.transpose();
}

StateVector truth_to_state(const TruthState& s, const Eigen::Vector3d& phi_ref) {
  if (!s.allFinite()) throw std::domain_error("truth_to_state: truth state is not finite");
  if (!phi_ref.allFinite()) throw std::domain_error("truth_to_state: phi_ref is not finite");
  StateVector x;
  x.head<6>() = s.head<6>();
  x.segment<3>(6) = math::nearest_representative(math::log_map(s.segment<4>(6)), phi_ref);
  x.segment<3>(9) = s.segment<3>(10);
  return x;
}

TruthState state_to_truth(const StateVector& x) {
  if (!x.allFinite()) throw std::domain_error("state_to_truth: state is not finite");
  TruthState s;
  s.head<6>() = x.head<6>();
  s.segment<4>(6) = math::exp_map(x.segment<3>(6));
  s.segment<3>(10) = x.segment<3>(9);
  return s;
}

}  // namespace tubempc::dynamics
