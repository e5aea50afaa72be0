#include "tubempc/math/so3.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace tubempc::math {
namespace {

constexpr double kPi = 3.14159265358979323846;

template <typename Derived>
std::string format_vector(const Eigen::MatrixBase<Derived>& v) {
  std::ostringstream os;
  os.precision(17);
  os << '[';
  for (Eigen::Index i = 0; i < v.size(); ++i) os << (i ? ", " : "") << v(i);
  os << ']';
  return os.str();
}

void require_finite(const Eigen::Vector3d& phi, const char* what) {
  if (!phi.allFinite()) {
    throw std::invalid_argument(std::string(what) + ": rotation vector must be finite, got " +
                                format_vector(phi));
  }
}

}  // namespace

Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d S;
  S << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return S;
}

Quaternion quat_mul(const Quaternion& q, const Quaternion& p) {
  const Eigen::Vector3d qv = q.head<3>();
  const Eigen::Vector3d pv = p.head<3>();
  Quaternion r;
  r.head<3>() = p(3) * qv + q(3) * pv + qv.cross(pv);
  r(3) = q(3) * p(3) - qv.dot(pv);
  return r;
}

Quaternion quat_mul_odot(const Quaternion& q, const Quaternion& p) { return quat_mul(p, q); }

Quaternion quat_conj(const Quaternion& q) { return Quaternion(-q(0), -q(1), -q(2), q(3)); }

Quaternion quat_identity() { return Quaternion(0.0, 0.0, 0.0, 1.0); }

Quaternion quat_normalize(const Quaternion& q) {
  if (!q.allFinite()) {
    throw std::invalid_argument("quaternion must be finite, got " + format_vector(q));
  }
  const double n = q.norm();
  if (n < 1e-12) {
    throw std::invalid_argument("quaternion must be nonzero (norm >= 1e-12), got " + format_vector(q));
  }
  return q / n;
}

Eigen::Matrix3d rotation_matrix(const Quaternion& q_in) {
  const Quaternion q = quat_normalize(q_in);
  const Eigen::Vector3d v = q.head<3>();
  const double w = q(3);
  return (w * w - v.squaredNorm()) * Eigen::Matrix3d::Identity() + 2.0 * v * v.transpose() +
         2.0 * w * skew(v);
}

Quaternion quat_from_rotation_matrix(const Eigen::Matrix3d& R) {
  if (!R.allFinite()) {
    throw std::invalid_argument("rotation matrix must be finite");
  }
  const double orth = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orth > 1e-6 || R.determinant() < 0.0) {
    throw std::invalid_argument("matrix is not a rotation (|R^T R - I| = " + std::to_string(orth) +
                                ", det = " + std::to_string(R.determinant()) + ")");
  }
  // Shepperd: pick the largest of w^2, x^2, y^2, z^2 (times 4) for a well-conditioned division.
  const double tr = R.trace();
  Quaternion q;
  const Eigen::Vector4d d(R(0, 0), R(1, 1), R(2, 2), tr);
  Eigen::Index i = 0;
  d.maxCoeff(&i);
  if (i == 3) {
    const double s = 2.0 * std::sqrt(1.0 + tr);
    q << (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s, (R(1, 0) - R(0, 1)) / s, 0.25 * s;
  } else {
    const Eigen::Index j = (i + 1) % 3;
    const Eigen::Index k = (i + 2) % 3;
    const double s = 2.0 * std::sqrt(1.0 + R(i, i) - R(j, j) - R(k, k));
    q(i) = 0.25 * s;
    q(j) = (R(j, i) + R(i, j)) / s;
    q(k) = (R(k, i) + R(i, k)) / s;
    q(3) = (R(k, j) - R(j, k)) / s;
  }
  if (q(3) < 0.0) q = -q;
  return q / q.norm();
}

Quaternion exp_map(const Eigen::Vector3d& phi) {
  require_finite(phi, "exp_map");
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  // sin(t/2)/t with its series below t = 1e-4 (error < 1e-20).
  const double s = t < 1e-4 ? 0.5 - t2 / 48.0 : std::sin(0.5 * t) / t;
  Quaternion q;
  q.head<3>() = s * phi;
  q(3) = std::cos(0.5 * t);
  return q;
}

Eigen::Vector3d log_map(const Quaternion& q_in) {
  Quaternion q = quat_normalize(q_in);
  if (q(3) < 0.0) q = -q;  // same rotation; keeps |phi| <= pi
  const Eigen::Vector3d v = q.head<3>();
  const double vn = v.norm();
  // angle = 2 atan2(|v|, w); phi = angle * v / |v|. The ratio angle/|v| -> 2/w (1 - |v|^2/(3w^2))
  // as |v| -> 0.
  if (vn < 1e-8) {
    return (2.0 / q(3)) * (1.0 - vn * vn / (3.0 * q(3) * q(3))) * v;
  }
  return (2.0 * std::atan2(vn, q(3)) / vn) * v;
}

Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& phi) {
  require_finite(phi, "right_jacobian");
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  double a = 0.0;  // (1 - cos t) / t^2
  double b = 0.0;  // (t - sin t) / t^3
  if (t < 1e-4) {
    a = 0.5 - t2 / 24.0;
    b = 1.0 / 6.0 - t2 / 120.0;
  } else {
    a = (1.0 - std::cos(t)) / t2;
    b = (t - std::sin(t)) / (t2 * t);
  }
  const Eigen::Matrix3d S = skew(phi);
  return Eigen::Matrix3d::Identity() - a * S + b * S * S;
}

Eigen::Vector3d nearest_representative(const Eigen::Vector3d& phi, const Eigen::Vector3d& phi_ref) noexcept {
  const double angle = phi.norm();
  if (!(angle > 0.0) || !std::isfinite(angle) || !phi_ref.allFinite()) return phi;
  Eigen::Vector3d best = phi;
  double best_d = (phi - phi_ref).squaredNorm();
  for (const double n : {-1.0, 1.0}) {
    const Eigen::Vector3d candidate = phi * ((angle + n * 2.0 * kPi) / angle);
    const double d = (candidate - phi_ref).squaredNorm();
    if (candidate.norm() < 2.0 * kPi - 1e-3 && d < best_d) {
      best = candidate;
      best_d = d;
    }
  }
  return best;
}

Eigen::Matrix3d right_jacobian_inverse(const Eigen::Vector3d& phi) {
  require_finite(phi, "right_jacobian_inverse");
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  if (t >= 2.0 * kPi - 1e-6) {
    throw std::invalid_argument("right_jacobian_inverse: singular for |phi| >= 2 pi, got |phi| = " +
                                std::to_string(t));
  }
  // c = (1 - (t/2) cot(t/2)) / t^2, series 1/12 + t^2/720 below t = 1e-3.
  const double c =
      t < 1e-3 ? 1.0 / 12.0 + t2 / 720.0 : (1.0 - 0.5 * t * std::cos(0.5 * t) / std::sin(0.5 * t)) / t2;
  const Eigen::Matrix3d S = skew(phi);
  return Eigen::Matrix3d::Identity() + 0.5 * S + c * S * S;
}

}  // namespace tubempc::math
