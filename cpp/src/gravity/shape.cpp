#include "tubempc/gravity/shape.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace tubempc::gravity {

namespace {

using Index = Eigen::Index;

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
      fail("face " + std::to_string(sorted[i].second) + " duplicates face " + std::to_string(sorted[i - 1].second));
    }
  }
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
    if (vol6 == 0.0 || !std::isfinite(vol6)) {
      fail("the component containing face " + std::to_string(seed) + " encloses no volume");
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
