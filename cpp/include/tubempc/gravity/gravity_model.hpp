/// @file gravity_model.hpp
/// Interface of a gravity field evaluated in the asteroid body-fixed frame A, and the point-mass
/// field (used for far-field checks and as a rotation-invariant test body).
///
/// Sign convention (docs/model.md, "Gravity"): the potential U is positive outside the body and
/// the acceleration is its gradient, a = grad U; the gradient tensor is G = d a / d r = Hess U.
#pragma once

#include <Eigen/Dense>

namespace tubempc::gravity {

/// One evaluation of a gravity field at a point.
struct GravitySample {
  double potential{0.0};                                  ///< U (m^2/s^2), > 0
  Eigen::Vector3d acceleration{Eigen::Vector3d::Zero()};  ///< a = grad U (m/s^2), frame of the point
  Eigen::Matrix3d gradient{Eigen::Matrix3d::Zero()};      ///< G = Hess U (1/s^2), symmetric
};

/// A gravity field in the body-fixed frame A. Implementations are immutable after construction
/// and safe to evaluate from several threads at once; `evaluate` does not allocate.
class GravityModel {
 public:
  virtual ~GravityModel() = default;

  /// Evaluates U, grad U and Hess U at a point.
  /// @param r_A position in the body-fixed frame A (m).
  /// @param out receives U (m^2/s^2), a (m/s^2) and G (1/s^2) at r_A, in frame A.
  virtual void evaluate(const Eigen::Vector3d& r_A, GravitySample& out) const = 0;

  /// The acceleration alone, for callers that need no Hessian (the truth propagation). The default
  /// calls `evaluate`; a model overrides it where skipping the Hessian saves work.
  /// @param r_A position in the body-fixed frame A (m).
  /// @return a = grad U (m/s^2) at r_A, in frame A: the same value as `evaluate`'s.
  virtual Eigen::Vector3d acceleration(const Eigen::Vector3d& r_A) const {
    GravitySample g;
    evaluate(r_A, g);
    return g.acceleration;
  }

  /// Gravitational parameter of the body.
  /// @return G M (m^3/s^2).
  virtual double gm() const = 0;
};

/// Point mass at the origin of A: U = GM / |r|.
class PointMassGravity final : public GravityModel {
 public:
  /// @param gm gravitational parameter (m^3/s^2), finite and > 0.
  /// @throws std::invalid_argument otherwise.
  explicit PointMassGravity(double gm);

  /// Evaluates U = GM/|r|, its gradient and Hessian.
  /// @param r_A position in frame A (m), finite and non-zero.
  /// @param out receives U (m^2/s^2), a (m/s^2) and G (1/s^2).
  /// @throws std::domain_error at r_A = 0 (singular) or for a non-finite r_A.
  void evaluate(const Eigen::Vector3d& r_A, GravitySample& out) const override;
  /// @return G M (m^3/s^2), as constructed.
  double gm() const override { return gm_; }

 private:
  double gm_;
};

}  // namespace tubempc::gravity
