/// @file ray_caster.hpp
/// Ray casting on the asteroid's shape model (docs/model.md, "Navigation"): the first face a ray
/// meets, found through a bounding-volume hierarchy of axis-aligned boxes built at construction
/// (median split along the longest axis of the face centroids' box, at most kLeafFaces faces per
/// leaf). Queries are allocation-free and visit the tree with a fixed-size stack. All coordinates are
/// in the body-fixed frame A (m).
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <limits>
#include <vector>

#include "tubempc/gravity/shape.hpp"

namespace tubempc::nav {

/// The nearest intersection of a ray with the mesh.
struct RayHit {
  bool hit{false};                                    ///< whether the ray meets a face within its range
  double distance{0.0};                               ///< distance from the origin to the hit (m)
  Eigen::Index face{-1};                              ///< the face hit (0-based), -1 without a hit
  Eigen::Vector3d point_A{Eigen::Vector3d::Zero()};   ///< the hit point in A (m)
  Eigen::Vector3d normal_A{Eigen::Vector3d::Zero()};  ///< the face's unit outward normal in A
};

/// Ray caster over a closed triangle mesh. Immutable after construction; queries are const,
/// thread-safe and do not allocate.
class RayCaster {
 public:
  /// Most faces in a leaf of the hierarchy.
  static constexpr int kLeafFaces = 4;
  /// Capacity of the traversal stack; the median split keeps the depth near log2(faces / kLeafFaces),
  /// and construction checks that it fits.
  static constexpr int kMaxDepth = 64;

  /// Builds the hierarchy (O(m log m)).
  /// @param shape the validated mesh (m, frame A); its faces are copied.
  explicit RayCaster(const gravity::Shape& shape);

  /// The first face met by the ray origin_A + s direction_A, 0 < s <= max_distance. Faces are hit
  /// from either side. A non-finite or zero direction, or a non-finite origin, gives no hit.
  /// @param origin_A     ray origin in A (m).
  /// @param direction_A  ray direction in A (normalised here).
  /// @param max_distance largest distance searched (m).
  /// @return the nearest hit (distance along the unit direction, m).
  RayHit cast(const Eigen::Vector3d& origin_A, const Eigen::Vector3d& direction_A,
              double max_distance = std::numeric_limits<double>::infinity()) const;

  /// The same query over every face without the hierarchy (O(m); the tests' reference).
  /// @param origin_A     ray origin in A (m).
  /// @param direction_A  ray direction in A (normalised here).
  /// @param max_distance largest distance searched (m).
  /// @return the nearest hit.
  RayHit cast_all_faces(const Eigen::Vector3d& origin_A, const Eigen::Vector3d& direction_A,
                        double max_distance = std::numeric_limits<double>::infinity()) const;

  /// Whether the segment from from_A to to_A crosses the mesh, its two ends excluded by
  /// `end_margin` (so that a point on the surface does not occlude itself).
  /// @param from_A     segment start in A (m).
  /// @param to_A       segment end in A (m).
  /// @param end_margin length left out at each end (m), >= 0.
  /// @return true if a face is met strictly between the ends (a non-finite input: true).
  bool blocked(const Eigen::Vector3d& from_A, const Eigen::Vector3d& to_A, double end_margin) const;

  /// @return the number of faces.
  Eigen::Index n_faces() const { return static_cast<Eigen::Index>(v0_.size()); }
  /// @return the number of nodes of the hierarchy.
  Eigen::Index n_nodes() const { return static_cast<Eigen::Index>(nodes_.size()); }
  /// @return the depth of the hierarchy (1 for a single leaf).
  int depth() const { return depth_; }
  /// @return the size of the mesh: the diagonal of its bounding box (m).
  double size() const { return size_; }
  /// @return the centre of the mesh's bounding box in A (m).
  const Eigen::Vector3d& box_center_A() const { return center_; }

 private:
  struct Node {
    Eigen::Vector3d lo{Eigen::Vector3d::Zero()}, hi{Eigen::Vector3d::Zero()};  // box (m)
    std::int32_t first{0};  // leaf: first entry of order_; inner: index of the right child
    std::int32_t count{0};  // leaf: number of faces; inner: 0 (the left child follows the node)
  };
  int build(std::int32_t begin, std::int32_t end, std::vector<Eigen::Vector3d>& centroids, int depth);
  // Intersection distance of face f with the ray (Moller-Trumbore), or a negative value.
  double intersect(std::int32_t f, const Eigen::Vector3d& o, const Eigen::Vector3d& d) const;
  RayHit make_hit(std::int32_t face, double s, const Eigen::Vector3d& o, const Eigen::Vector3d& d) const;

  std::vector<Eigen::Vector3d> v0_, e1_, e2_, normal_;  // per face: vertex 0, edges 0->1, 0->2, normal
  std::vector<std::int32_t> order_;                     // faces ordered by leaf
  std::vector<Node> nodes_;
  int depth_{0};
  double size_{0.0};
  Eigen::Vector3d center_{Eigen::Vector3d::Zero()};
};

}  // namespace tubempc::nav
