#include "tubempc/nav/ray_caster.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tubempc::nav {

namespace {

// Slab test: does the ray o + s d (inv_d = 1/d) enter the box for some s in [0, s_max]?
bool box_hit(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& o,
             const Eigen::Vector3d& inv_d, double s_max) {
  double s0 = 0.0, s1 = s_max;
  for (int i = 0; i < 3; ++i) {
    double a = (lo(i) - o(i)) * inv_d(i);
    double b = (hi(i) - o(i)) * inv_d(i);
    if (std::isnan(a) || std::isnan(b)) {  // d_i = 0 with o_i on a slab plane: inside the slab
      if (o(i) < lo(i) || o(i) > hi(i)) return false;
      continue;
    }
    if (a > b) std::swap(a, b);
    s0 = std::max(s0, a);
    s1 = std::min(s1, b);
    if (s0 > s1) return false;
  }
  return true;
}

}  // namespace

RayCaster::RayCaster(const gravity::Shape& shape) {
  const auto& V = shape.vertices();
  const auto& F = shape.faces();
  const auto m = static_cast<std::int32_t>(F.rows());
  std::vector<Eigen::Vector3d> centroids(static_cast<std::size_t>(m));
  v0_.resize(centroids.size());
  e1_.resize(centroids.size());
  e2_.resize(centroids.size());
  normal_.resize(centroids.size());
  order_.resize(centroids.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (std::int32_t f = 0; f < m; ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)).transpose(), b = V.row(F(f, 1)).transpose(),
                          c = V.row(F(f, 2)).transpose();
    v0_[f] = a;
    e1_[f] = b - a;
    e2_[f] = c - a;
    normal_[f] = e1_[f].cross(e2_[f]).normalized();
    centroids[f] = (a + b + c) / 3.0;
    order_[f] = f;
    lo = lo.cwiseMin(a).cwiseMin(b).cwiseMin(c);
    hi = hi.cwiseMax(a).cwiseMax(b).cwiseMax(c);
  }
  size_ = (hi - lo).norm();
  center_ = 0.5 * (hi + lo);
  nodes_.reserve(2 * static_cast<std::size_t>(m) / kLeafFaces + 2);
  build(0, m, centroids, 1);
  if (depth_ > kMaxDepth) throw std::invalid_argument("RayCaster: hierarchy deeper than kMaxDepth");
}

int RayCaster::build(std::int32_t begin, std::int32_t end, std::vector<Eigen::Vector3d>& centroids,
                     int depth) {
  depth_ = std::max(depth_, depth);
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back(Node{});
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  Eigen::Vector3d clo = lo, chi = hi;
  for (std::int32_t i = begin; i < end; ++i) {
    const std::int32_t f = order_[i];
    const Eigen::Vector3d b = v0_[f] + e1_[f], c = v0_[f] + e2_[f];
    lo = lo.cwiseMin(v0_[f]).cwiseMin(b).cwiseMin(c);
    hi = hi.cwiseMax(v0_[f]).cwiseMax(b).cwiseMax(c);
    clo = clo.cwiseMin(centroids[f]);
    chi = chi.cwiseMax(centroids[f]);
  }
  nodes_[index].lo = lo;
  nodes_[index].hi = hi;
  if (end - begin <= kLeafFaces) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  int axis = 0;
  (chi - clo).maxCoeff(&axis);
  const std::int32_t mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](std::int32_t a, std::int32_t b) { return centroids[a](axis) < centroids[b](axis); });
  build(begin, mid, centroids, depth + 1);
  const int right = build(mid, end, centroids, depth + 1);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

double RayCaster::intersect(std::int32_t f, const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  const Eigen::Vector3d p = d.cross(e2_[f]);
  const double det = e1_[f].dot(p);
  if (det == 0.0) return -1.0;  // ray parallel to the face's plane
  const double inv = 1.0 / det;
  const Eigen::Vector3d t = o - v0_[f];
  const double u = t.dot(p) * inv;
  constexpr double kEdge = 1e-12;  // barycentric tolerance: a ray through an edge meets both faces
  if (u < -kEdge || u > 1.0 + kEdge) return -1.0;
  const Eigen::Vector3d q = t.cross(e1_[f]);
  const double v = d.dot(q) * inv;
  if (v < -kEdge || u + v > 1.0 + kEdge) return -1.0;
  return e2_[f].dot(q) * inv;
}

RayHit RayCaster::make_hit(std::int32_t face, double s, const Eigen::Vector3d& o,
                           const Eigen::Vector3d& d) const {
  RayHit h;
  if (face < 0) return h;
  h.hit = true;
  h.distance = s;
  h.face = face;
  h.point_A = o + s * d;
  h.normal_A = normal_[face];
  return h;
}

RayHit RayCaster::cast(const Eigen::Vector3d& origin_A, const Eigen::Vector3d& direction_A,
                       double max_distance) const {
  const double norm = direction_A.norm();
  if (!origin_A.allFinite() || !(norm > 0.0) || !std::isfinite(norm) || std::isnan(max_distance)) return {};
  const Eigen::Vector3d d = direction_A / norm;
  const Eigen::Vector3d inv_d = d.cwiseInverse();
  double best = max_distance;
  std::int32_t best_face = -1;
  int stack[kMaxDepth + 1];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!box_hit(node.lo, node.hi, origin_A, inv_d, best)) continue;
    if (node.count > 0) {
      for (std::int32_t i = node.first; i < node.first + node.count; ++i) {
        const double s = intersect(order_[i], origin_A, d);
        if (s > 0.0 && s <= best) {
          best = s;
          best_face = order_[i];
        }
      }
    } else {
      // Depth-first: the left child (next node) is visited first; both fit since the depth is bounded.
      const int self = static_cast<int>(&node - nodes_.data());
      stack[top++] = node.first;
      stack[top++] = self + 1;
    }
  }
  return make_hit(best_face, best, origin_A, d);
}

RayHit RayCaster::cast_all_faces(const Eigen::Vector3d& origin_A, const Eigen::Vector3d& direction_A,
                                 double max_distance) const {
  const double norm = direction_A.norm();
  if (!origin_A.allFinite() || !(norm > 0.0) || !std::isfinite(norm) || std::isnan(max_distance)) return {};
  const Eigen::Vector3d d = direction_A / norm;
  double best = max_distance;
  std::int32_t best_face = -1;
  for (std::int32_t f = 0; f < static_cast<std::int32_t>(v0_.size()); ++f) {
    const double s = intersect(f, origin_A, d);
    if (s > 0.0 && s <= best) {
      best = s;
      best_face = f;
    }
  }
  return make_hit(best_face, best, origin_A, d);
}

bool RayCaster::blocked(const Eigen::Vector3d& from_A, const Eigen::Vector3d& to_A, double end_margin) const {
  const Eigen::Vector3d d = to_A - from_A;
  const double length = d.norm();
  if (!std::isfinite(length) || !std::isfinite(end_margin)) return true;
  if (length <= 2.0 * end_margin) return false;
  const Eigen::Vector3d u = d / length;
  const RayHit h = cast(from_A + end_margin * u, u, length - 2.0 * end_margin);
  return h.hit;
}

}  // namespace tubempc::nav
