// The ray caster against independent computations: every face by brute force, an axis-aligned box
// (exact distances) and a sphere (bounds from the faceting).
#include <gtest/gtest.h>

#include <cmath>

#include "../gravity/gravity_test_meshes.hpp"
#include "tubempc/nav/random.hpp"
#include "tubempc/nav/ray_caster.hpp"

using namespace tubempc;

namespace {

nav::RayCaster make(const gravity_test::Mesh& m) { return nav::RayCaster(gravity::Shape(m.v, m.f)); }

Eigen::Vector3d random_unit(nav::Random& rng) {
  const Eigen::Vector3d v(rng.normal(), rng.normal(), rng.normal());
  return v.normalized();
}

}  // namespace

TEST(RayCaster, HierarchyMatchesBruteForce) {
  const nav::RayCaster caster = make(gravity_test::lumpy_body(20, 40, 250.0));
  ASSERT_EQ(caster.n_faces(), 2 * 40 * 19);
  EXPECT_LE(caster.depth(), 12);
  nav::Random rng(11);
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    // Origins outside and inside the body, random directions (many miss from outside).
    const Eigen::Vector3d o = (i % 3 == 0 ? 50.0 : 600.0) * random_unit(rng);
    const Eigen::Vector3d d = i % 2 == 0 ? Eigen::Vector3d(-o + 200.0 * random_unit(rng)) : random_unit(rng);
    const nav::RayHit a = caster.cast(o, d), b = caster.cast_all_faces(o, d);
    ASSERT_EQ(a.hit, b.hit) << i;
    if (!a.hit) continue;
    ++hits;
    EXPECT_NEAR(a.distance, b.distance, 1e-9 * a.distance) << i;
    EXPECT_EQ(a.face, b.face) << i;
    EXPECT_NEAR((a.point_A - (o + a.distance * d.normalized())).norm(), 0.0, 1e-9);
  }
  EXPECT_GT(hits, 1500);
}

TEST(RayCaster, BoxDistancesAreExact) {
  const nav::RayCaster caster = make(gravity_test::box(-10.0, 20.0, -5.0, 5.0, -3.0, 7.0));
  nav::Random rng(3);
  for (int i = 0; i < 500; ++i) {
    // A point on the face x = 20 and a ray towards it from outside through the +x half-space.
    const Eigen::Vector3d p(20.0, -5.0 + 10.0 * rng.uniform(), -3.0 + 10.0 * rng.uniform());
    Eigen::Vector3d u = random_unit(rng);
    u.x() = std::abs(u.x()) + 0.2;
    const double range = 1.0 + 100.0 * rng.uniform();
    const Eigen::Vector3d o = p + range * u.normalized();
    const nav::RayHit h = caster.cast(o, -u);
    ASSERT_TRUE(h.hit);
    EXPECT_NEAR(h.distance, range, 1e-10 * range);
    EXPECT_NEAR(h.normal_A.x(), 1.0, 1e-12);
  }
  // From inside: the exit distance along +z is 7 - z.
  const nav::RayHit in = caster.cast(Eigen::Vector3d(0.0, 0.0, 1.5), Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(in.hit);
  EXPECT_NEAR(in.distance, 5.5, 1e-12);
  // Range limit, pointing away, zero and non-finite directions.
  EXPECT_FALSE(caster.cast(Eigen::Vector3d(50.0, 0.0, 0.0), -Eigen::Vector3d::UnitX(), 29.0).hit);
  EXPECT_TRUE(caster.cast(Eigen::Vector3d(50.0, 0.0, 0.0), -Eigen::Vector3d::UnitX(), 31.0).hit);
  EXPECT_FALSE(caster.cast(Eigen::Vector3d(50.0, 0.0, 0.0), Eigen::Vector3d::UnitX()).hit);
  EXPECT_FALSE(caster.cast(Eigen::Vector3d(50.0, 0.0, 0.0), Eigen::Vector3d::Zero()).hit);
  EXPECT_FALSE(caster.cast(Eigen::Vector3d(50.0, 0.0, 0.0), Eigen::Vector3d::Constant(NAN)).hit);
}

TEST(RayCaster, SphereRangeWithinFacetingBounds) {
  // Vertices on a sphere of radius R: the mesh lies between R cos(delta) and R, delta the largest
  // angle from a face's centre direction to its corners; a radial ray from distance D meets it at a
  // range in [D - R, D - R cos(delta)].
  const double R = 100.0, D = 400.0;
  const gravity_test::Mesh m = gravity_test::lumpy_body(30, 60, R, 0.0);
  const nav::RayCaster caster = make(m);
  double delta = 0.0;
  for (Eigen::Index f = 0; f < m.f.rows(); ++f) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int j = 0; j < 3; ++j) c += m.v.row(m.f(f, j)).transpose();
    for (int j = 0; j < 3; ++j)
      delta = std::max(delta, std::acos(c.normalized().dot(m.v.row(m.f(f, j)).normalized())));
  }
  nav::Random rng(5);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d u = random_unit(rng);
    const nav::RayHit h = caster.cast(D * u, -u);
    ASSERT_TRUE(h.hit);
    EXPECT_GE(h.distance, D - R - 1e-9);
    EXPECT_LE(h.distance, D - R * std::cos(delta) + 1e-9);
  }
}

TEST(RayCaster, BlockedSegments) {
  const nav::RayCaster caster = make(gravity_test::box(-1.0, 1.0, -1.0, 1.0, -1.0, 1.0));
  EXPECT_TRUE(caster.blocked(Eigen::Vector3d(-5.0, 0.0, 0.0), Eigen::Vector3d(5.0, 0.0, 0.0), 1e-9));
  EXPECT_FALSE(caster.blocked(Eigen::Vector3d(-5.0, 2.0, 0.0), Eigen::Vector3d(5.0, 2.0, 0.0), 1e-9));
  // A point on the surface does not occlude itself; the far side does.
  EXPECT_FALSE(caster.blocked(Eigen::Vector3d(1.0, 0.2, 0.3), Eigen::Vector3d(9.0, 0.2, 0.3), 1e-9));
  EXPECT_TRUE(caster.blocked(Eigen::Vector3d(-1.0, 0.2, 0.3), Eigen::Vector3d(9.0, 0.2, 0.3), 1e-9));
  EXPECT_TRUE(caster.blocked(Eigen::Vector3d::Constant(NAN), Eigen::Vector3d::Zero(), 1e-9));
}

TEST(Random, StreamIsReproducibleAndNormal) {
  nav::Random a(42), b(42), c(43);
  for (int i = 0; i < 10; ++i) {
    const std::uint64_t x = a.next_u64();
    EXPECT_EQ(x, b.next_u64());
    EXPECT_NE(x, c.next_u64());
  }
  a.reseed(7);
  b.reseed(7);
  EXPECT_EQ(a.normal(), b.normal());
  // Moments of 2e5 normals within 5 standard errors.
  nav::Random r(1);
  const int n = 200000;
  double m1 = 0.0, m2 = 0.0, m4 = 0.0;
  double umin = 1.0, umax = 0.0;
  for (int i = 0; i < n; ++i) {
    const double x = r.normal();
    m1 += x;
    m2 += x * x;
    m4 += x * x * x * x;
    const double u = r.uniform();
    umin = std::min(umin, u);
    umax = std::max(umax, u);
  }
  m1 /= n;
  m2 /= n;
  m4 /= n;
  EXPECT_LT(std::abs(m1), 5.0 / std::sqrt(n));
  EXPECT_LT(std::abs(m2 - 1.0), 5.0 * std::sqrt(2.0 / n));
  EXPECT_LT(std::abs(m4 - 3.0), 5.0 * std::sqrt(96.0 / n));
  EXPECT_GE(umin, 0.0);
  EXPECT_LT(umax, 1.0);
}
