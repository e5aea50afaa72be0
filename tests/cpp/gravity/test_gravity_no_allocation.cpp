// PolyhedronGravity::evaluate and laplacian must not allocate (the MPC calls them inside its
// allocation-free step): global operator new is replaced by a counting one in this test binary.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "gravity_test_meshes.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

TEST(PolyhedronGravity, EvaluateAndLaplacianDoNotAllocate) {
  const auto m = gravity_test::lumpy_body(16, 24, 250.0);
  const tubempc::gravity::PolyhedronGravity g(tubempc::gravity::Shape(m.v, m.f), 1260.0);
  tubempc::gravity::GravitySample s;
  const long before = g_allocations.load();
  double sum = 0.0;
  for (int i = 0; i < 20; ++i) {
    g.evaluate(Eigen::Vector3d(300.0 + i, -100.0, 50.0), s);
    sum += s.potential + g.laplacian(Eigen::Vector3d(10.0 * i, 0.0, 0.0));
  }
  EXPECT_EQ(g_allocations.load() - before, 0);
  EXPECT_TRUE(std::isfinite(sum));
  // The counter works: a vector allocates.
  std::vector<double> v(10);
  EXPECT_GT(g_allocations.load() - before, 0);
}
