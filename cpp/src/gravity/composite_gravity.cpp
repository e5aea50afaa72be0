#include "tubempc/gravity/composite_gravity.hpp"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace tubempc::gravity {

namespace {

// The reference density of the parts' polyhedra built by CompositeGravity::part (kg/m^3).
constexpr double kReferenceDensity = 1.0;

std::string part_name(std::size_t i) { return "CompositeGravity: part " + std::to_string(i); }

}  // namespace

GravityPart CompositeGravity::part(Shape shape, double density, const Eigen::Vector3d& offset_A) {
  if (!std::isfinite(density) || density == 0.0) {
    throw std::invalid_argument("CompositeGravity::part: density must be finite and non-zero (kg/m^3), got " +
                                std::to_string(density));
  }
  if (!offset_A.allFinite()) throw std::invalid_argument("CompositeGravity::part: offset_A must be finite");
  return GravityPart{std::make_shared<const PolyhedronGravity>(std::move(shape), kReferenceDensity), density,
                     offset_A};
}

CompositeGravity::CompositeGravity(std::vector<GravityPart> parts) : parts_(std::move(parts)) {
  if (parts_.empty()) throw std::invalid_argument("CompositeGravity: needs at least one part");
  factor_.reserve(parts_.size());
  Eigen::Vector3d first_moment = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    const GravityPart& p = parts_[i];
    if (!p.polyhedron) throw std::invalid_argument(part_name(i) + ": null polyhedron");
    if (!std::isfinite(p.density) || p.density == 0.0) {
      throw std::invalid_argument(part_name(i) + ": density must be finite and non-zero (kg/m^3), got " +
                                  std::to_string(p.density));
    }
    if (!p.offset_A.allFinite()) throw std::invalid_argument(part_name(i) + ": offset_A must be finite");
    factor_.push_back(p.density / p.polyhedron->density());
    const double m = p.density * p.polyhedron->shape().volume();
    mass_ += m;
    first_moment += m * (p.polyhedron->shape().center_of_mass() + p.offset_A);
  }
  if (!(mass_ > 0.0)) {
    throw std::invalid_argument("CompositeGravity: the parts' total mass must be > 0 kg, got " +
                                std::to_string(mass_));
  }
  center_of_mass_ = first_moment / mass_;
  for (const GravityPart& p : parts_) {
    const Shape& s = p.polyhedron->shape();
    const double m = p.density * s.volume();
    const Eigen::Vector3d d = s.center_of_mass() + p.offset_A - center_of_mass_;
    inertia_ +=
        s.inertia(p.density) + m * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
}

void CompositeGravity::evaluate(const Eigen::Vector3d& r_A, GravitySample& out) const {
  out = GravitySample{};
  GravitySample s;
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    parts_[i].polyhedron->evaluate(r_A - parts_[i].offset_A, s);
    out.potential += factor_[i] * s.potential;
    out.acceleration += factor_[i] * s.acceleration;
    out.gradient += factor_[i] * s.gradient;
  }
}

Eigen::Vector3d CompositeGravity::acceleration(const Eigen::Vector3d& r_A) const {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    a += factor_[i] * parts_[i].polyhedron->acceleration(r_A - parts_[i].offset_A);
  }
  return a;
}

double CompositeGravity::laplacian(const Eigen::Vector3d& r_A) const {
  double l = 0.0;
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    l += factor_[i] * parts_[i].polyhedron->laplacian(r_A - parts_[i].offset_A);
  }
  return l;
}

CompositeGravity CompositeGravity::translated(const Eigen::Vector3d& d_A) const {
  if (!d_A.allFinite()) throw std::invalid_argument("CompositeGravity::translated: d_A must be finite");
  std::vector<GravityPart> moved = parts_;
  for (GravityPart& p : moved) p.offset_A += d_A;
  return CompositeGravity(std::move(moved));
}

}  // namespace tubempc::gravity
