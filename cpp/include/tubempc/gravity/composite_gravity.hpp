/// @file composite_gravity.hpp
/// Gravity of a heterogeneous body as a superposition of homogeneous polyhedra (docs/model.md,
/// "Physical environment"): part i is a closed mesh of signed density rho_i (kg/m^3) placed at the
/// offset o_i in the body frame A, and the field is the sum of the parts' fields,
///
///     U(r) = sum_i (rho_i / rho_0) U_i,0(r - o_i),     and likewise grad U and Hess U,
///
/// with U_i,0 the field of part i's mesh at the reference density rho_0 = 1 kg/m^3
/// (gravity::PolyhedronGravity, Werner and Scheeres 1997). A denser or lighter region inside a body
/// is a part of the region's density contrast (negative for a deficit) added to the body's part:
/// inside the region the Laplacian is then -4 pi G (rho_body + rho_region). The mass is
/// sum_i rho_i V_i and the centre of mass sum_i rho_i V_i (c_i + o_i) / M (c_i the centroid of mesh i).
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "tubempc/gravity/gravity_model.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc/gravity/shape.hpp"

namespace tubempc::gravity {

/// One homogeneous part of a CompositeGravity.
struct GravityPart {
  /// The part's mesh in its own coordinates (m), shared between copies of the composite.
  std::shared_ptr<const PolyhedronGravity> polyhedron;
  /// The part's density (kg/m^3), non-zero and finite; negative for a density deficit.
  double density{0.0};
  /// Where the part's mesh coordinates are placed in A: a point p of the mesh lies at p + offset_A (m).
  Eigen::Vector3d offset_A{Eigen::Vector3d::Zero()};
};

/// A sum of homogeneous polyhedra of signed densities (see the file comment). Immutable after
/// construction; `evaluate`, `acceleration` and `laplacian` neither allocate nor lock and may be called
/// from several threads at once.
class CompositeGravity final : public GravityModel {
 public:
  /// The same part's mesh and placement with a reference polyhedron of 1 kg/m^3 built here.
  /// @param shape    the part's mesh (m), in its own coordinates.
  /// @param density  the part's density (kg/m^3), finite and non-zero (negative: a deficit).
  /// @param offset_A where the mesh's coordinates are placed in A (m), finite.
  /// @return the part.
  /// @throws std::invalid_argument for a zero or non-finite density or a non-finite offset.
  static GravityPart part(Shape shape, double density, const Eigen::Vector3d& offset_A);

  /// @param parts one or more parts (see GravityPart), each with a non-null polyhedron, a finite
  ///              non-zero density and a finite offset, whose masses sum to a positive total mass.
  /// @throws std::invalid_argument naming the first bad part, or for a total mass <= 0.
  explicit CompositeGravity(std::vector<GravityPart> parts);

  /// U, grad U and Hess U at a point: the sums over the parts.
  /// @param r_A position in frame A (m), finite with |r_A - o_i| < 1e150 m.
  /// @param out receives U (m^2/s^2), a = grad U (m/s^2) and G = Hess U (1/s^2), in A.
  /// @throws std::domain_error for a non-finite or too large r_A.
  void evaluate(const Eigen::Vector3d& r_A, GravitySample& out) const override;

  /// a = grad U alone: the sum of the parts' accelerations (the same value as `evaluate`'s).
  /// @param r_A position in frame A (m), finite.
  /// @return a (m/s^2) in A.
  /// @throws std::domain_error for a non-finite or too large r_A.
  Eigen::Vector3d acceleration(const Eigen::Vector3d& r_A) const override;

  /// Laplacian of U at a point.
  /// @param r_A position in frame A (m), finite.
  /// @return -4 pi G times the sum of the densities of the parts that contain r_A (1/s^2); 0 outside all.
  /// @throws std::domain_error for a non-finite or too large r_A.
  double laplacian(const Eigen::Vector3d& r_A) const;

  /// @return G M (m^3/s^2), M = sum_i rho_i V_i.
  double gm() const override { return kGravitationalConstant * mass_; }
  /// @return the total mass M = sum_i rho_i V_i (kg).
  double mass() const { return mass_; }
  /// @return the centre of mass sum_i rho_i V_i (c_i + o_i) / M in A (m).
  const Eigen::Vector3d& center_of_mass() const { return center_of_mass_; }
  /// @return the inertia tensor about the centre of mass (kg m^2), the parts' inertias moved there
  ///         (parallel axes) and summed with their signed densities.
  const Eigen::Matrix3d& inertia() const { return inertia_; }
  /// @return the parts, in the order given.
  const std::vector<GravityPart>& parts() const { return parts_; }

  /// The same body moved by d: every part's offset plus d (the meshes are shared, not rebuilt).
  /// @param d_A translation in A (m), finite.
  /// @return the moved composite (its centre of mass is center_of_mass() + d_A).
  /// @throws std::invalid_argument for a non-finite d_A.
  CompositeGravity translated(const Eigen::Vector3d& d_A) const;

 private:
  std::vector<GravityPart> parts_;
  std::vector<double> factor_;  // rho_i / the polyhedron's density
  double mass_{0.0};
  Eigen::Vector3d center_of_mass_{Eigen::Vector3d::Zero()};
  Eigen::Matrix3d inertia_{Eigen::Matrix3d::Zero()};
};

}  // namespace tubempc::gravity
