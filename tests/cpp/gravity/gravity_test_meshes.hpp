// Meshes for the gravity tests: boxes, tetrahedra, a lumpy latitude-longitude body and the Bennu
// radar model (read from ../shared/data when present).
#pragma once

#include <array>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "tubempc/gravity/shape.hpp"

namespace gravity_test {

inline constexpr double kPi = 3.14159265358979323846;

using tubempc::gravity::Faces;
using tubempc::gravity::Vertices;

struct Mesh {
  Vertices v;
  Faces f;
};

// Axis-aligned box [x0, x1] x [y0, y1] x [z0, z1] (m), 12 outward faces.
inline Mesh box(double x0, double x1, double y0, double y1, double z0, double z1) {
  Mesh m;
  m.v.resize(8, 3);
  for (int i = 0; i < 8; ++i) m.v.row(i) << ((i & 1) ? x1 : x0), ((i & 2) ? y1 : y0), ((i & 4) ? z1 : z0);
  m.f.resize(12, 3);
  m.f << 0, 2, 1, 1, 2, 3,  // z = z0 (normal -z)
      4, 5, 6, 5, 7, 6,     // z = z1
      0, 1, 4, 1, 5, 4,     // y = y0
      2, 6, 3, 3, 6, 7,     // y = y1
      0, 4, 2, 2, 4, 6,     // x = x0
      1, 3, 5, 3, 7, 5;     // x = x1
  return m;
}

// Tetrahedron with vertices p0..p3 (outward orientation chosen from the signed volume).
inline Mesh tetrahedron(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                        const Eigen::Vector3d& p3) {
  Mesh m;
  m.v.resize(4, 3);
  m.v << p0.transpose(), p1.transpose(), p2.transpose(), p3.transpose();
  const bool positive = (p1 - p0).dot((p2 - p0).cross(p3 - p0)) > 0.0;
  m.f.resize(4, 3);
  if (positive) {
    m.f << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  } else {
    m.f << 0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2;
  }
  return m;
}

// Latitude-longitude sphere of radius r(theta, phi) = radius (1 + lumps), n_lat bands, n_lon sectors.
inline Mesh lumpy_body(int n_lat, int n_lon, double radius, double lump = 0.15) {
  Mesh m;
  const int nv = 2 + (n_lat - 1) * n_lon;
  m.v.resize(nv, 3);
  auto r_of = [&](double th, double ph) {
    return radius * (1.0 + lump * (std::sin(2.0 * th) * std::cos(3.0 * ph) + 0.5 * std::cos(th) +
                                   0.3 * std::sin(th) * std::sin(ph)));
  };
  const double pi = 3.14159265358979323846;
  m.v.row(0) << 0.0, 0.0, r_of(0.0, 0.0);
  m.v.row(nv - 1) << 0.0, 0.0, -r_of(pi, 0.0);
  for (int i = 1; i < n_lat; ++i) {
    const double th = pi * i / n_lat;
    for (int j = 0; j < n_lon; ++j) {
      const double ph = 2.0 * pi * j / n_lon;
      const double r = r_of(th, ph);
      m.v.row(1 + (i - 1) * n_lon + j) << r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph),
          r * std::cos(th);
    }
  }
  std::vector<std::array<std::int64_t, 3>> faces;
  auto id = [&](int i, int j) { return static_cast<std::int64_t>(1 + (i - 1) * n_lon + (j % n_lon)); };
  for (int j = 0; j < n_lon; ++j) faces.push_back({0, id(1, j), id(1, j + 1)});
  for (int i = 1; i < n_lat - 1; ++i) {
    for (int j = 0; j < n_lon; ++j) {
      faces.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      faces.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  }
  for (int j = 0; j < n_lon; ++j) faces.push_back({nv - 1, id(n_lat - 1, j + 1), id(n_lat - 1, j)});
  m.f.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t k = 0; k < faces.size(); ++k) {
    m.f.row(static_cast<Eigen::Index>(k)) << faces[k][0], faces[k][1], faces[k][2];
  }
  return m;
}

// The Bennu radar model (km, 1-based "v"/"f" lines) in metres, if ../shared/data has it.
inline std::optional<Mesh> bennu_radar() {
  std::ifstream in(std::string(TUBEMPC_SHARED_DATA_DIR) + "/101955bennu.tab");
  if (!in) return std::nullopt;
  std::vector<std::array<double, 3>> v;
  std::vector<std::array<std::int64_t, 3>> f;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      std::array<double, 3> x{};
      s >> x[0] >> x[1] >> x[2];
      v.push_back({1000.0 * x[0], 1000.0 * x[1], 1000.0 * x[2]});
    } else if (tag == "f") {
      std::array<std::int64_t, 3> x{};
      s >> x[0] >> x[1] >> x[2];
      f.push_back({x[0] - 1, x[1] - 1, x[2] - 1});
    }
  }
  Mesh m;
  m.v.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) m.v.row(static_cast<Eigen::Index>(i)) << v[i][0], v[i][1], v[i][2];
  m.f.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (size_t i = 0; i < f.size(); ++i) m.f.row(static_cast<Eigen::Index>(i)) << f[i][0], f[i][1], f[i][2];
  return m;
}

}  // namespace gravity_test
