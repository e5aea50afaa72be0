#include "tubempc/gravity/shape.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tubempc::gravity {

namespace {

using Index = Eigen::Index;

constexpr double kMinRelativeVolume = 1e-12;  // smallest |volume| / diagonal^3 of a component
constexpr double kCoincidentRelative = 1e-9;  // vertices closer than this times the diagonal coincide

[[noreturn]] void fail(const std::string& what) { throw std::invalid_argument("Shape: " + what); }

std::string edge_name(std::int64_t a, std::int64_t b) {
  return "(" + std::to_string(a) + ", " + std::to_string(b) + ")";
}

// One face's traversal of an undirected edge (lo, hi).
struct HalfEdge {
  std::int64_t lo, hi;
  Index face;
  int local;     // which edge of the face: k -> k+1
  bool forward;  // the face traverses lo -> hi
};

void check_indices_and_degeneracy(const Vertices& v, const Faces& f) {
  const Index n = v.rows();
  for (Index i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(v(i, k))) {
        fail("vertex " + std::to_string(i) + " has a non-finite coordinate " + "xyz"[k] + " = " +
             std::to_string(v(i, k)));
      }
    }
  }
  for (Index j = 0; j < f.rows(); ++j) {
    for (int k = 0; k < 3; ++k) {
      if (f(j, k) < 0 || f(j, k) >= n) {
        fail("face " + std::to_string(j) + " has vertex index " + std::to_string(f(j, k)) +
             " out of range [0, " + std::to_string(n) + ")");
      }
    }
    if (f(j, 0) == f(j, 1) || f(j, 1) == f(j, 2) || f(j, 2) == f(j, 0)) {
      fail("face " + std::to_string(j) + " is degenerate (repeated vertex index)");
    }
    const Eigen::Vector3d a = v.row(f(j, 0)).transpose();
    const Eigen::Vector3d e1 = v.row(f(j, 1)).transpose() - a;
    const Eigen::Vector3d e2 = v.row(f(j, 2)).transpose() - a;
    const double lmax2 = std::max({e1.squaredNorm(), e2.squaredNorm(), (e2 - e1).squaredNorm()});
    if (!(e1.cross(e2).norm() > 1e-14 * lmax2)) {
      fail("face " + std::to_string(j) + " is degenerate (zero area)");
    }
  }
}

void check_duplicates(const Faces& f) {
  std::vector<std::pair<std::array<std::int64_t, 3>, Index>> sorted(static_cast<size_t>(f.rows()));
  for (Index j = 0; j < f.rows(); ++j) {
    std::array<std::int64_t, 3> t{f(j, 0), f(j, 1), f(j, 2)};
    std::sort(t.begin(), t.end());
    sorted[static_cast<size_t>(j)] = {t, j};
  }
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 1; i < sorted.size(); ++i) {
    if (sorted[i].first == sorted[i - 1].first) {
      fail("face " + std::to_string(sorted[i].second) + " duplicates face " +
           std::to_string(sorted[i - 1].second));
    }
  }
}

// Sign of orient3d(a, b, c, d) = ((b - a) x (c - a)) . (d - a), zero within a relative rounding band.
int orient_sign(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                const Eigen::Vector3d& d) {
  const Eigen::Vector3d u = b - a, v = c - a, w = d - a;
  const double det = u.cross(v).dot(w);
  const double band = 1e-12 * u.norm() * v.norm() * w.norm();
  return det > band ? 1 : (det < -band ? -1 : 0);
}

using Point2 = Eigen::Vector2d;

int orient2_sign(const Point2& a, const Point2& b, const Point2& c) {
  const Point2 u = b - a, v = c - a;
  const double det = u.x() * v.y() - u.y() * v.x();
  const double band = 1e-12 * u.norm() * v.norm();
  return det > band ? 1 : (det < -band ? -1 : 0);
}

bool on_segment2(const Point2& p, const Point2& a, const Point2& b) {  // p collinear with (a, b)
  return p.x() >= std::min(a.x(), b.x()) && p.x() <= std::max(a.x(), b.x()) &&
         p.y() >= std::min(a.y(), b.y()) && p.y() <= std::max(a.y(), b.y());
}

// Closed segments (p, q) and (a, b) share a point.
bool segments_meet2(const Point2& p, const Point2& q, const Point2& a, const Point2& b) {
  const int o1 = orient2_sign(p, q, a), o2 = orient2_sign(p, q, b);
  const int o3 = orient2_sign(a, b, p), o4 = orient2_sign(a, b, q);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && on_segment2(a, p, q)) || (o2 == 0 && on_segment2(b, p, q)) ||
         (o3 == 0 && on_segment2(p, a, b)) || (o4 == 0 && on_segment2(q, a, b));
}

bool in_triangle2(const Point2& p, const Point2& a, const Point2& b, const Point2& c) {  // closed
  const int s1 = orient2_sign(a, b, p), s2 = orient2_sign(b, c, p), s3 = orient2_sign(c, a, p);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

// Closed segment (p, q) and closed triangle (a, b, c) share a point (3-D; coplanar case in the
// projection that drops the normal's largest component).
bool segment_meets_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const int sp = orient_sign(a, b, c, p), sq = orient_sign(a, b, c, q);
  if (sp * sq > 0) return false;
  if (sp == 0 && sq == 0) {
    Eigen::Index axis = 0;
    (b - a).cross(c - a).cwiseAbs().maxCoeff(&axis);
    const int i = axis == 0 ? 1 : 0, k = axis == 2 ? 1 : 2;
    auto proj = [&](const Eigen::Vector3d& x) { return Point2(x(i), x(k)); };
    const Point2 p2 = proj(p), q2 = proj(q), a2 = proj(a), b2 = proj(b), c2 = proj(c);
    return in_triangle2(p2, a2, b2, c2) || in_triangle2(q2, a2, b2, c2) || segments_meet2(p2, q2, a2, b2) ||
           segments_meet2(p2, q2, b2, c2) || segments_meet2(p2, q2, c2, a2);
  }
  const int s1 = orient_sign(p, q, a, b), s2 = orient_sign(p, q, b, c), s3 = orient_sign(p, q, c, a);
  return (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
}

// Faces j and l intersect other than in the vertices and edge they share (by index).
bool faces_intersect(const Vertices& v, const Faces& f, Index j, Index l) {
  auto P = [&](std::int64_t i) -> Eigen::Vector3d { return v.row(i).transpose(); };
  int shared = 0, sj[3] = {-1, -1, -1}, sl[3] = {-1, -1, -1};  // position of shared corners
  for (int x = 0; x < 3; ++x) {
    for (int y = 0; y < 3; ++y) {
      if (f(j, x) == f(l, y)) {
        sj[x] = y;
        sl[y] = x;
        ++shared;
      }
    }
  }
  if (shared == 0) {
    for (int x = 0; x < 3; ++x) {
      if (segment_meets_triangle(P(f(j, x)), P(f(j, (x + 1) % 3)), P(f(l, 0)), P(f(l, 1)), P(f(l, 2))) ||
          segment_meets_triangle(P(f(l, x)), P(f(l, (x + 1) % 3)), P(f(j, 0)), P(f(j, 1)), P(f(j, 2)))) {
        return true;
      }
    }
    return false;
  }
  int oj = 0, ol = 0;  // a corner of each face that is not shared
  while (sj[oj] >= 0) ++oj;
  while (sl[ol] >= 0) ++ol;
  if (shared == 1) {  // the edges opposite the shared corner, against the other face
    int pj = 0, pl = 0;
    while (sj[pj] < 0) ++pj;
    while (sl[pl] < 0) ++pl;
    return segment_meets_triangle(P(f(j, (pj + 1) % 3)), P(f(j, (pj + 2) % 3)), P(f(l, 0)), P(f(l, 1)),
                                  P(f(l, 2))) ||
           segment_meets_triangle(P(f(l, (pl + 1) % 3)), P(f(l, (pl + 2) % 3)), P(f(j, 0)), P(f(j, 1)),
                                  P(f(j, 2)));
  }
  // A shared edge (e0, e1): the faces overlap iff they are folded flat onto the same side.
  const int e0 = (oj + 1) % 3, e1 = (oj + 2) % 3;
  const Eigen::Vector3d a = P(f(j, e0)), b = P(f(j, e1)), c = P(f(j, oj)), d = P(f(l, ol));
  if (orient_sign(a, b, c, d) != 0) return false;
  const Eigen::Vector3d n = (b - a).cross(c - a);
  return (b - a).cross(d - a).dot(n) > 0.0;
}

// First pair (j, l), j < l, of faces that intersect (faces_intersect), from a bounding-volume
// hierarchy of the faces' boxes (median splits); {-1, -1} when there is none.
std::pair<Index, Index> first_self_intersection(const Vertices& v, const Faces& f) {
  const Index m = f.rows();
  std::vector<Eigen::AlignedBox3d> box(static_cast<size_t>(m));
  for (Index j = 0; j < m; ++j) {
    Eigen::AlignedBox3d b;
    for (int k = 0; k < 3; ++k) b.extend(v.row(f(j, k)).transpose());
    box[static_cast<size_t>(j)] = b;
  }
  struct Node {
    Eigen::AlignedBox3d box;
    Index begin, end;   // range of `order` (leaf) ...
    Index left, right;  // ... or children (inner node: left >= 0)
  };
  std::vector<Index> order(static_cast<size_t>(m));
  for (Index j = 0; j < m; ++j) order[static_cast<size_t>(j)] = j;
  std::vector<Node> nodes;
  nodes.reserve(static_cast<size_t>(2 * m));
  constexpr Index kLeaf = 4;
  std::vector<Index> stack;
  nodes.push_back({Eigen::AlignedBox3d(), 0, m, -1, -1});
  stack.push_back(0);
  while (!stack.empty()) {
    const Index id = stack.back();
    stack.pop_back();
    const Index begin = nodes[static_cast<size_t>(id)].begin, end = nodes[static_cast<size_t>(id)].end;
    Eigen::AlignedBox3d b;
    for (Index q = begin; q < end; ++q) b.extend(box[static_cast<size_t>(order[static_cast<size_t>(q)])]);
    nodes[static_cast<size_t>(id)].box = b;
    if (end - begin <= kLeaf) continue;
    Index axis = 0;
    b.sizes().maxCoeff(&axis);
    const Index mid = (begin + end) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](Index x, Index y) {
      return box[static_cast<size_t>(x)].center()(axis) < box[static_cast<size_t>(y)].center()(axis);
    });
    const auto left = static_cast<Index>(nodes.size());
    nodes.push_back({Eigen::AlignedBox3d(), begin, mid, -1, -1});
    nodes.push_back({Eigen::AlignedBox3d(), mid, end, -1, -1});
    nodes[static_cast<size_t>(id)].left = left;
    nodes[static_cast<size_t>(id)].right = left + 1;
    stack.push_back(left);
    stack.push_back(left + 1);
  }
  for (Index j = 0; j < m; ++j) {
    const Eigen::AlignedBox3d& bj = box[static_cast<size_t>(j)];
    stack.assign(1, 0);
    while (!stack.empty()) {
      const Node& node = nodes[static_cast<size_t>(stack.back())];
      stack.pop_back();
      if (!node.box.intersects(bj)) continue;
      if (node.left >= 0) {
        stack.push_back(node.left);
        stack.push_back(node.right);
        continue;
      }
      for (Index q = node.begin; q < node.end; ++q) {
        const Index l = order[static_cast<size_t>(q)];
        if (l > j && box[static_cast<size_t>(l)].intersects(bj) && faces_intersect(v, f, j, l)) return {j, l};
      }
    }
  }
  return {-1, -1};
}

// First pair of distinct vertices used by faces closer than `tol` (max-norm), {-1, -1} if none:
// the vertices are sorted by their cell of a grid of spacing `tol`, and each is compared with the
// vertices of its own and the 26 neighbouring cells (O(n log n) for any distribution).
std::pair<Index, Index> first_coincident_vertices(const Vertices& v, const Faces& f, double tol) {
  std::vector<char> used(static_cast<size_t>(v.rows()), 0);
  for (Index j = 0; j < f.rows(); ++j) {
    for (int k = 0; k < 3; ++k) used[static_cast<size_t>(f(j, k))] = 1;
  }
  using Cell = std::array<std::int64_t, 3>;
  const Eigen::Vector3d low = v.colwise().minCoeff().transpose();
  auto cell_of = [&](Index i) {
    Cell c{};
    for (int k = 0; k < 3; ++k)
      c[static_cast<size_t>(k)] = static_cast<std::int64_t>(std::floor((v(i, k) - low(k)) / tol));
    return c;
  };
  std::vector<std::pair<Cell, Index>> cells;
  for (Index i = 0; i < v.rows(); ++i) {
    if (used[static_cast<size_t>(i)]) cells.push_back({cell_of(i), i});
  }
  std::sort(cells.begin(), cells.end());
  for (const auto& [c, i] : cells) {
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const Cell n{c[0] + dx, c[1] + dy, c[2] + dz};
          auto it = std::lower_bound(cells.begin(), cells.end(), std::make_pair(n, Index{-1}));
          for (; it != cells.end() && it->first == n; ++it) {
            const Index j = it->second;
            if (j != i && (v.row(i) - v.row(j)).cwiseAbs().maxCoeff() <= tol)
              return {std::min(i, j), std::max(i, j)};
          }
        }
      }
    }
  }
  return {-1, -1};
}

}  // namespace

Shape::Shape(Vertices vertices_m, Faces faces, ShapeRepair repair)
    : vertices_(std::move(vertices_m)), faces_(std::move(faces)) {
  if (vertices_.rows() < 4) fail("needs at least 4 vertices, got " + std::to_string(vertices_.rows()));
  if (faces_.rows() < 4) fail("needs at least 4 faces, got " + std::to_string(faces_.rows()));
  check_indices_and_degeneracy(vertices_, faces_);
  check_duplicates(faces_);

  // Half-edges grouped by undirected edge: a closed 2-manifold has exactly two per edge.
  const Index m = faces_.rows();
  std::vector<HalfEdge> half(static_cast<size_t>(3 * m));
  for (Index j = 0; j < m; ++j) {
    for (int k = 0; k < 3; ++k) {
      const std::int64_t a = faces_(j, k), b = faces_(j, (k + 1) % 3);
      half[static_cast<size_t>(3 * j + k)] = {std::min(a, b), std::max(a, b), j, k, a < b};
    }
  }
  std::sort(half.begin(), half.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.lo != y.lo ? x.lo < y.lo : (x.hi != y.hi ? x.hi < y.hi : x.face < y.face);
  });
  // neighbour[3 j + k] = (face across edge k of face j, whether both traverse it the same way)
  std::vector<std::pair<Index, bool>> neighbour(static_cast<size_t>(3 * m));
  for (size_t i = 0; i < half.size();) {
    size_t g = i;
    while (g < half.size() && half[g].lo == half[i].lo && half[g].hi == half[i].hi) ++g;
    if (g - i == 1) {
      fail("edge " + edge_name(half[i].lo, half[i].hi) + " of face " + std::to_string(half[i].face) +
           " belongs to no other face: the mesh is not closed");
    }
    if (g - i > 2) {
      fail("edge " + edge_name(half[i].lo, half[i].hi) + " is shared by " + std::to_string(g - i) +
           " faces (faces " + std::to_string(half[i].face) + ", " + std::to_string(half[i + 1].face) + ", " +
           std::to_string(half[i + 2].face) + "): not a 2-manifold");
    }
    const HalfEdge& x = half[i];
    const HalfEdge& y = half[i + 1];
    neighbour[static_cast<size_t>(3 * x.face + x.local)] = {y.face, x.forward == y.forward};
    neighbour[static_cast<size_t>(3 * y.face + y.local)] = {x.face, x.forward == y.forward};
    i = g;
  }

  // Orientation by propagation over shared edges, one connected component at a time; a component
  // whose signed volume is negative is inverted as a whole. flip[j]: face j must be reversed.
  std::vector<signed char> flip(static_cast<size_t>(m), -1);
  std::vector<Index> queue;
  queue.reserve(static_cast<size_t>(m));
  const Eigen::Vector3d o = vertices_.colwise().mean().transpose();
  // Length scale of the mesh: the diagonal of the bounding box of the vertices used by faces.
  Eigen::AlignedBox3d bbox;
  for (Index j = 0; j < m; ++j) {
    for (int k = 0; k < 3; ++k) bbox.extend(vertices_.row(faces_(j, k)).transpose());
  }
  const double diagonal = bbox.diagonal().norm();
  auto signed_volume6 = [&](Index j) {
    const Eigen::Vector3d a = vertices_.row(faces_(j, 0)).transpose() - o;
    const Eigen::Vector3d b = vertices_.row(faces_(j, 1)).transpose() - o;
    const Eigen::Vector3d c = vertices_.row(faces_(j, 2)).transpose() - o;
    return a.dot(b.cross(c));
  };
  for (Index seed = 0; seed < m; ++seed) {
    if (flip[static_cast<size_t>(seed)] >= 0) continue;
    const size_t begin = queue.size();
    flip[static_cast<size_t>(seed)] = 0;
    queue.push_back(seed);
    for (size_t q = begin; q < queue.size(); ++q) {
      const Index j = queue[q];
      for (int k = 0; k < 3; ++k) {
        const auto [other, same] = neighbour[static_cast<size_t>(3 * j + k)];
        const signed char want = static_cast<signed char>(flip[static_cast<size_t>(j)] ^ (same ? 1 : 0));
        signed char& f_other = flip[static_cast<size_t>(other)];
        if (f_other < 0) {
          f_other = want;
          queue.push_back(other);
        } else if (f_other != want) {
          fail("the component containing face " + std::to_string(seed) +
               " cannot be oriented consistently (non-orientable surface; conflict at face " +
               std::to_string(other) + ")");
        }
      }
    }
    // Signed volume (times 6) of the component with the propagated orientation, from tetrahedra with
    // apex at the vertex mean (any apex gives the same value for a closed surface).
    double vol6 = 0.0;
    for (size_t q = begin; q < queue.size(); ++q) {
      const double s = signed_volume6(queue[q]);
      vol6 += flip[static_cast<size_t>(queue[q])] ? -s : s;
    }
    if (!(std::abs(vol6) > 6.0 * kMinRelativeVolume * diagonal * diagonal * diagonal)) {
      fail("the component containing face " + std::to_string(seed) +
           " encloses no volume (|volume| = " + std::to_string(std::abs(vol6) / 6.0) +
           " m^3 <= " + std::to_string(kMinRelativeVolume) + " * bounding-box diagonal^3)");
    }
    const bool invert = vol6 < 0.0;
    Index first_flipped = -1;
    Index n_comp_flipped = 0;
    for (size_t q = begin; q < queue.size(); ++q) {
      signed char& f = flip[static_cast<size_t>(queue[q])];
      if (invert) f = static_cast<signed char>(1 - f);
      if (f) {
        ++n_comp_flipped;
        if (first_flipped < 0 || queue[q] < first_flipped) first_flipped = queue[q];
      }
    }
    if (repair == ShapeRepair::None && n_comp_flipped > 0) {
      if (n_comp_flipped == static_cast<Index>(queue.size() - begin)) {
        fail("the faces of the component containing face " + std::to_string(seed) +
             " are oriented inward (negative signed volume); reverse them or use ShapeRepair::Orient");
      }
      fail("face " + std::to_string(first_flipped) +
           " is oriented inconsistently with its neighbours (it traverses a shared edge in the same "
           "direction as the adjacent face); use ShapeRepair::Orient to repair");
    }
    n_flipped_ += n_comp_flipped;
  }
  for (Index j = 0; j < m; ++j) {
    if (flip[static_cast<size_t>(j)]) std::swap(faces_(j, 1), faces_(j, 2));
  }

  const double coincident_tol = kCoincidentRelative * diagonal;
  if (const auto [a, b] = first_coincident_vertices(vertices_, faces_, coincident_tol); a >= 0) {
    fail("vertex " + std::to_string(b) + " coincides with vertex " + std::to_string(a) + " (closer than " +
         std::to_string(coincident_tol) + " m, " + std::to_string(kCoincidentRelative) +
         " * bounding-box diagonal): duplicated vertex");
  }
  if (const auto [j, l] = first_self_intersection(vertices_, faces_); j >= 0) {
    fail("face " + std::to_string(j) + " intersects face " + std::to_string(l) +
         ": the surface intersects itself");
  }

  // Unique edges with face_a traversing v0 -> v1.
  edges_.reserve(static_cast<size_t>(3 * m / 2));
  for (size_t i = 0; i < half.size(); i += 2) {
    const HalfEdge& x = half[i];
    const HalfEdge& y = half[i + 1];
    const bool x_forward = x.forward != static_cast<bool>(flip[static_cast<size_t>(x.face)]);
    edges_.push_back(x_forward ? MeshEdge{x.lo, x.hi, x.face, y.face} : MeshEdge{x.lo, x.hi, y.face, x.face});
  }

  // Mass properties from the tetrahedra (o, a, b, c), o the vertex mean: int x x^T over the tetra
  // (0, a, b, c) is det/120 (a a^T + b b^T + c c^T + s s^T) with s = a + b + c.
  double vol6 = 0.0;
  Eigen::Vector3d moment24 = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second120 = Eigen::Matrix3d::Zero();
  for (Index j = 0; j < m; ++j) {
    const Eigen::Vector3d a = vertices_.row(faces_(j, 0)).transpose() - o;
    const Eigen::Vector3d b = vertices_.row(faces_(j, 1)).transpose() - o;
    const Eigen::Vector3d c = vertices_.row(faces_(j, 2)).transpose() - o;
    const Eigen::Vector3d s = a + b + c;
    const double det = a.dot(b.cross(c));
    vol6 += det;
    moment24 += det * s;
    second120 += det * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  volume_ = vol6 / 6.0;
  const Eigen::Vector3d c_rel = moment24 / 24.0 / volume_;
  center_of_mass_ = o + c_rel;
  Eigen::Matrix3d second = second120 / 120.0 - volume_ * c_rel * c_rel.transpose();
  second = 0.5 * (second + second.transpose()).eval();
  inertia_unit_ = second.trace() * Eigen::Matrix3d::Identity() - second;
}

double Shape::mean_radius() const {
  constexpr double kPi = 3.14159265358979323846;
  return std::cbrt(3.0 * volume_ / (4.0 * kPi));
}

}  // namespace tubempc::gravity
