#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>
#include <string>

#include "gravity_test_meshes.hpp"
#include "tubempc/gravity/shape.hpp"

using gravity_test::box;
using gravity_test::Mesh;
using gravity_test::tetrahedron;
using tubempc::gravity::Shape;
using tubempc::gravity::ShapeRepair;

namespace {

// Expects std::invalid_argument whose message contains `needle`.
void expect_error(const Mesh& m, const std::string& needle, ShapeRepair repair = ShapeRepair::None) {
  try {
    Shape s(m.v, m.f, repair);
    ADD_FAILURE() << "accepted a mesh that should fail with '" << needle << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(Shape, BoxMassPropertiesMatchClosedForm) {
  const double a = 3.0, b = 5.0, c = 7.0;
  const Shape s(box(1.0, 1.0 + a, -2.0, -2.0 + b, 10.0, 10.0 + c).v,
                box(1.0, 1.0 + a, -2.0, -2.0 + b, 10.0, 10.0 + c).f);
  const double V = a * b * c;
  EXPECT_NEAR(s.volume(), V, 1e-12 * V);
  EXPECT_LT((s.center_of_mass() - Eigen::Vector3d(1.0 + a / 2, -2.0 + b / 2, 10.0 + c / 2)).norm(), 1e-12);
  const Eigen::Matrix3d I =
      (Eigen::Vector3d(b * b + c * c, a * a + c * c, a * a + b * b) * V / 12.0).asDiagonal();
  EXPECT_LT((s.inertia_per_unit_density() - I).norm(), 1e-12 * I.norm());
  EXPECT_LT((s.inertia(2.0) - 2.0 * I).norm(), 1e-12 * I.norm());
  EXPECT_NEAR(s.mean_radius(), std::cbrt(3.0 * V / (4.0 * 3.14159265358979323846)), 1e-12);
  EXPECT_EQ(s.edges().size(), 18u);
  EXPECT_EQ(s.n_flipped_faces(), 0);
}

TEST(Shape, RightTetrahedronMassPropertiesMatchClosedForm) {
  // Tetrahedron (0, a e1, b e2, c e3): V = abc/6, centroid (a, b, c)/4, int x^2 = a^3 bc/60,
  // int xy = a^2 b^2 c/120 (and permutations).
  const double a = 2.0, b = 3.0, c = 5.0;
  const Eigen::Vector3d o(0.5, -1.0, 2.0);
  const Mesh m = tetrahedron(o, o + Eigen::Vector3d(a, 0, 0), o + Eigen::Vector3d(0, b, 0),
                             o + Eigen::Vector3d(0, 0, c));
  const Shape s(m.v, m.f);
  const double V = a * b * c / 6.0;
  EXPECT_NEAR(s.volume(), V, 1e-13);
  const Eigen::Vector3d cm = Eigen::Vector3d(a, b, c) / 4.0;
  EXPECT_LT((s.center_of_mass() - o - cm).norm(), 1e-13);
  Eigen::Matrix3d second;  // int x x^T about the right-angle corner
  second << a * a * a * b * c / 60, a * a * b * b * c / 120, a * a * b * c * c / 120,  //
      a * a * b * b * c / 120, a * b * b * b * c / 60, a * b * b * c * c / 120,        //
      a * a * b * c * c / 120, a * b * b * c * c / 120, a * b * c * c * c / 60;
  const Eigen::Matrix3d second_cm = second - V * cm * cm.transpose();
  const Eigen::Matrix3d I = second_cm.trace() * Eigen::Matrix3d::Identity() - second_cm;
  EXPECT_LT((s.inertia_per_unit_density() - I).norm(), 1e-12 * I.norm());
}

TEST(Shape, RejectsEachMalformedMeshNamingTheCulprit) {
  const Mesh good = box(0, 1, 0, 2, 0, 3);
  ASSERT_NO_THROW(Shape(good.v, good.f));

  Mesh m = good;
  m.v(5, 1) = std::numeric_limits<double>::quiet_NaN();
  expect_error(m, "vertex 5 has a non-finite coordinate y");

  m = good;
  m.f(7, 2) = 8;
  expect_error(m, "face 7 has vertex index 8 out of range");
  m.f(7, 2) = -1;
  expect_error(m, "face 7 has vertex index -1 out of range");

  m = good;
  m.f(4, 1) = m.f(4, 0);
  expect_error(m, "face 4 is degenerate (repeated vertex index)");

  m = good;
  m.v.row(3) = 0.5 * (m.v.row(1) + m.v.row(2));  // face (1, 2, 3) becomes a segment
  expect_error(m, "face 1 is degenerate (zero area)");

  m = good;
  m.f.conservativeResize(13, 3);
  m.f.row(12) = good.f.row(3);
  expect_error(m, "face 12 duplicates face 3");

  m = good;  // drop the last face: open mesh
  m.f.conservativeResize(11, 3);
  expect_error(m, "the mesh is not closed");

  m = good;  // add a fin on edge (1, 5) shared by three faces
  m.v.conservativeResize(9, 3);
  m.v.row(8) << 2.0, -1.0, 1.5;
  m.f.conservativeResize(13, 3);
  m.f.row(12) << 1, 5, 8;
  expect_error(m, "not a 2-manifold");

  m = good;  // one face reversed
  std::swap(m.f(9, 1), m.f(9, 2));
  expect_error(m, "face 9 is oriented inconsistently");

  m = good;  // all faces reversed: inward normals
  for (Eigen::Index j = 0; j < m.f.rows(); ++j) std::swap(m.f(j, 1), m.f(j, 2));
  expect_error(m, "oriented inward");

  m = good;
  m.f.conservativeResize(3, 3);
  expect_error(m, "needs at least 4 faces");
}

TEST(Shape, RejectsSelfIntersectionCoincidentVerticesAndNoVolume) {
  const Mesh good = box(0, 1, 0, 1, 0, 1);
  Mesh m = good;  // vertex 7 = (1, 1, 1) pushed through the body to (-0.5, -0.5, -0.5)
  m.v.row(7) << -0.5, -0.5, -0.5;
  expect_error(m, "intersects itself");

  // Two unit cubes overlapping in [0.5, 1] x [0, 1]^2: their overlap would be counted twice.
  const Mesh shifted = box(0.5, 1.5, 0, 1, 0, 1);
  Mesh two;
  two.v.resize(16, 3);
  two.v << good.v, shifted.v;
  two.f.resize(24, 3);
  two.f << good.f, (shifted.f.array() + 8).matrix();
  expect_error(two, "intersects itself");
  // Apart, they are a valid two-component body of volume 2.
  const Mesh apart = box(2, 3, 0, 1, 0, 1);
  two.v << good.v, apart.v;
  EXPECT_NEAR(Shape(two.v, two.f).volume(), 2.0, 1e-12);
  // Touching along a face through distinct vertices: coincident vertices.
  const Mesh touching = box(1, 2, 0, 1, 0, 1);
  two.v << good.v, touching.v;
  expect_error(two, "coincides with vertex");

  m = good;  // flattened to 1e-13 of its size: no volume to speak of
  m.v.col(2) *= 1e-13;
  expect_error(m, "encloses no volume");
}

TEST(Shape, OrientRepairRestoresOutwardFaces) {
  const Mesh good = box(0, 1, 0, 2, 0, 3);
  const Shape ref(good.v, good.f);
  Mesh m = good;
  std::swap(m.f(9, 1), m.f(9, 2));
  std::swap(m.f(2, 0), m.f(2, 1));
  const Shape fixed(m.v, m.f, ShapeRepair::Orient);
  EXPECT_EQ(fixed.n_flipped_faces(), 2);
  EXPECT_NEAR(fixed.volume(), ref.volume(), 1e-14);
  // Flipped back faces are the same cyclic triangles as the originals.
  for (Eigen::Index j = 0; j < m.f.rows(); ++j) {
    const Eigen::Vector3d a = fixed.vertices().row(fixed.faces()(j, 0)).transpose();
    const Eigen::Vector3d n = (fixed.vertices().row(fixed.faces()(j, 1)).transpose() - a)
                                  .cross(fixed.vertices().row(fixed.faces()(j, 2)).transpose() - a);
    const Eigen::Vector3d a0 = good.v.row(good.f(j, 0)).transpose();
    const Eigen::Vector3d n0 =
        (good.v.row(good.f(j, 1)).transpose() - a0).cross(good.v.row(good.f(j, 2)).transpose() - a0);
    EXPECT_GT(n.dot(n0), 0.0) << "face " << j;
  }
  for (Eigen::Index j = 0; j < m.f.rows(); ++j) std::swap(m.f(j, 1), m.f(j, 2));
  const Shape inverted(m.v, m.f, ShapeRepair::Orient);
  EXPECT_EQ(inverted.n_flipped_faces(), 10);  // faces 2 and 9 were already outward again
  EXPECT_NEAR(inverted.volume(), ref.volume(), 1e-14);
}

TEST(Shape, EdgesRecordTheirTwoFacesInTraversalOrder) {
  const Mesh g = gravity_test::lumpy_body(8, 12, 100.0);
  const Shape s(g.v, g.f);
  EXPECT_EQ(static_cast<Eigen::Index>(s.edges().size()) * 2, 3 * s.n_faces());
  auto traverses = [&](std::int64_t face, std::int64_t a, std::int64_t b) {
    for (int k = 0; k < 3; ++k) {
      if (s.faces()(face, k) == a && s.faces()(face, (k + 1) % 3) == b) return true;
    }
    return false;
  };
  for (const auto& e : s.edges()) {
    EXPECT_TRUE(traverses(e.face_a, e.v0, e.v1));
    EXPECT_TRUE(traverses(e.face_b, e.v1, e.v0));
  }
}
