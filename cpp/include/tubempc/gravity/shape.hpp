/// @file shape.hpp
/// A validated closed triangle mesh of constant density (the asteroid's shape model) and its mass
/// properties. Coordinates are in metres in the body-fixed frame A (docs/model.md, "Gravity").
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

namespace tubempc::gravity {

/// Vertex coordinates, one vertex per row (m).
using Vertices = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// Triangular faces, one face per row: three 0-based vertex indices, counter-clockwise seen from
/// outside (outward normal by the right-hand rule).
using Faces = Eigen::Matrix<std::int64_t, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// What Shape's constructor may change in the mesh it is given.
enum class ShapeRepair {
  None,   ///< reject any orientation problem with an error naming the face (all other mesh errors
          ///< are always rejected: see Shape)
  Orient  ///< flip faces to a consistent orientation (propagation over shared edges), then flip
          ///< every closed component whose signed volume is negative so that normals point outward
};

/// An edge of the mesh with the two faces that share it: face_a traverses v0 -> v1 and face_b
/// traverses v1 -> v0.
struct MeshEdge {
  std::int64_t v0{0};      ///< first vertex (0-based index)
  std::int64_t v1{0};      ///< second vertex (0-based index)
  std::int64_t face_a{0};  ///< face traversing v0 -> v1 (0-based index)
  std::int64_t face_b{0};  ///< face traversing v1 -> v0 (0-based index)
};

/// A closed, consistently outward-oriented triangle mesh, validated on construction.
///
/// Checks, each with a std::invalid_argument naming the offending vertex, face or edge: at least 4
/// vertices and 4 faces; finite coordinates; vertex indices in [0, n_vertices); no degenerate face
/// (repeated index or zero area); no duplicate face (same vertex set); closed 2-manifold (every
/// edge shared by exactly two faces); consistent orientation (every edge traversed once in each
/// direction); every connected component encloses a volume |V| > 1e-12 d^3 (d the diagonal of the
/// bounding box of the vertices used by faces), positive after orientation; no two distinct vertices
/// used by faces within 1e-9 d of each other (max-norm; coincident vertices, e.g. a duplicated vertex
/// line); no self-intersection (two faces meeting anywhere but in the corners and edge they share by
/// index, found with a bounding-volume hierarchy over the faces and a segment-triangle test on
/// orientation signs with a 1e-12 relative rounding band, which counts touching as meeting: O(m log m)).
/// Only orientation problems can be repaired (`repair == ShapeRepair::Orient`); the other checks
/// always reject. Vertices referenced by no face are kept (they do not contribute to anything).
class Shape {
 public:
  /// @param vertices_m vertex coordinates (m), n x 3.
  /// @param faces      0-based vertex indices, m x 3.
  /// @param repair     whether orientation errors are repaired or rejected.
  /// @throws std::invalid_argument naming the offending vertex, face or edge (see the class comment).
  Shape(Vertices vertices_m, Faces faces, ShapeRepair repair = ShapeRepair::None);

  /// @return the vertices, n x 3 (m).
  const Vertices& vertices() const { return vertices_; }
  /// @return the faces, m x 3 0-based vertex indices, outward orientation (after any repair).
  const Faces& faces() const { return faces_; }
  /// @return the number of vertices n.
  Eigen::Index n_vertices() const { return vertices_.rows(); }
  /// @return the number of faces m.
  Eigen::Index n_faces() const { return faces_.rows(); }
  /// @return the unique edges (3 m / 2 of them), each with its two faces.
  const std::vector<MeshEdge>& edges() const { return edges_; }
  /// @return the number of faces flipped by ShapeRepair::Orient (0 without repair).
  Eigen::Index n_flipped_faces() const { return n_flipped_; }

  /// @return the enclosed volume (m^3), > 0.
  double volume() const { return volume_; }
  /// @return the centre of mass for a constant density (m).
  const Eigen::Vector3d& center_of_mass() const { return center_of_mass_; }
  /// @return the inertia tensor about the centre of mass per unit density (m^5):
  ///         int (|x|^2 I - x x^T) dV.
  const Eigen::Matrix3d& inertia_per_unit_density() const { return inertia_unit_; }
  /// Inertia tensor about the centre of mass for a constant density.
  /// @param density density (kg/m^3).
  /// @return density times inertia_per_unit_density() (kg m^2).
  Eigen::Matrix3d inertia(double density) const { return density * inertia_unit_; }
  /// @return the radius of the sphere of equal volume (m).
  double mean_radius() const;

 private:
  Vertices vertices_;
  Faces faces_;
  std::vector<MeshEdge> edges_;
  Eigen::Index n_flipped_{0};
  double volume_{0.0};
  Eigen::Vector3d center_of_mass_{Eigen::Vector3d::Zero()};
  Eigen::Matrix3d inertia_unit_{Eigen::Matrix3d::Zero()};
};

}  // namespace tubempc::gravity
