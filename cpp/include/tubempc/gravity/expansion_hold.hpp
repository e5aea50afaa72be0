/// @file expansion_hold.hpp
/// A gravity field's first-order expansion held over a distance (docs/model.md M42): the navigation
/// filter's gravity and, with PropagatorSettings::gravity_expansion_tolerance, the truth's.
#pragma once

#include <Eigen/Dense>

#include "tubempc/gravity/gravity_model.hpp"

namespace tubempc::gravity {

/// The expansion a(r) ~ a(r0) + G(r0) (r - r0) about the last point r0 where a field was evaluated,
/// re-evaluated where r leaves the hold distance of r0 (docs/model.md M42):
///
///     d = max(d_min, min(sqrt(2 tol / c), |r0| / 8)),   c = |G(r0) - G(r_prev)|_F / |r0 - r_prev|,
///
/// c the gradient's change per metre between the last two evaluation points (the third derivative of
/// U along the path, which sets the expansion's error, about c d^2 / 2 at a distance d), d = d_min at
/// the first evaluation and with tol = 0. The object is the state of one trajectory (a filter, a run's
/// truth): not shared between threads; no heap allocation after construction.
class ExpansionHold {
 public:
  /// @param min_distance d_min (m), finite and >= 0 (0 with a zero tolerance: an evaluation at every
  ///                     hold()).
  /// @param tolerance    tol (m/s^2), finite and >= 0 (0: the hold is d_min).
  /// @throws std::invalid_argument naming the bad parameter.
  explicit ExpansionHold(double min_distance = 0.0, double tolerance = 0.0);

  /// Makes r_A the expansion's point unless it lies within the hold distance of the current one:
  /// evaluates `field` there and sets the hold distance.
  /// @param field the gravity field (frame A).
  /// @param r_A   position in frame A (m).
  /// @return false when the field cannot be evaluated there (a non-finite r_A or result, the field's
  ///         domain error at its singular point): the expansion is then left as it was.
  bool hold(const GravityModel& field, const Eigen::Vector3d& r_A) noexcept;

  /// @return whether an expansion is held (a successful hold() since construction or reset()).
  bool valid() const noexcept { return valid_; }
  /// The expansion's acceleration a(r0) + G(r0) (r_A - r0) (m/s^2, frame A); valid() must hold.
  /// @param r_A position in frame A (m).
  /// @return the acceleration (m/s^2, frame A).
  Eigen::Vector3d acceleration(const Eigen::Vector3d& r_A) const noexcept {
    return a0_A_ + G0_A_ * (r_A - r0_A_);
  }
  /// @return the expansion's point r0 (m, frame A).
  const Eigen::Vector3d& point_A() const noexcept { return r0_A_; }
  /// @return the gradient G(r0) (1/s^2, frame A).
  const Eigen::Matrix3d& gradient_A() const noexcept { return G0_A_; }
  /// @return the distance the current expansion is held over (m).
  double distance() const noexcept { return hold_; }
  /// @return the field's evaluations since construction or reset().
  long evaluations() const noexcept { return evaluations_; }
  /// @return the largest error of the expansion found at a re-evaluation since construction or
  ///         reset(), |a(r1) - a(r0) - G(r0) (r1 - r0)| at the new point r1 (m/s^2): the expansion's
  ///         error where it was given up, counted only when r1 is within twice the hold distance (a
  ///         jump past it, e.g. a filter's update, is not a distance the expansion was used over).
  double largest_error() const noexcept { return largest_error_; }
  /// @return d_min (m), as constructed.
  double min_distance() const noexcept { return min_distance_; }
  /// @return tol (m/s^2), as constructed.
  double tolerance() const noexcept { return tolerance_; }
  /// Forgets the expansion and the counts (the next hold() evaluates); keeps d_min and tol.
  void reset() noexcept { *this = ExpansionHold(min_distance_, tolerance_, Unchecked{}); }

 private:
  struct Unchecked {};
  ExpansionHold(double min_distance, double tolerance, Unchecked) noexcept
      : min_distance_(min_distance), tolerance_(tolerance) {}

  double min_distance_{0.0};
  double tolerance_{0.0};
  Eigen::Vector3d r0_A_{Eigen::Vector3d::Zero()};
  Eigen::Vector3d a0_A_{Eigen::Vector3d::Zero()};
  Eigen::Matrix3d G0_A_{Eigen::Matrix3d::Zero()};
  bool valid_{false};
  double hold_{0.0};
  long evaluations_{0};
  double largest_error_{0.0};
};

}  // namespace tubempc::gravity
