// PolyhedronGravity::evaluate, acceleration and laplacian must not allocate (the MPC calls them inside its
// allocation-free step): global operator new is replaced by a counting one in this test binary.
#include <gtest/gtest.h>

#include <vector>

#include "gravity_test_meshes.hpp"
#include "tubempc/gravity/composite_gravity.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc_testing/allocation_counter.hpp"

namespace {
// Allocations (counted from the start of the test binary; the tests compare before and after).
long allocations() { return tubempc_testing::AllocationCounter::count; }
struct CountFromStart {
  CountFromStart() { tubempc_testing::AllocationCounter::counting = true; }
} count_from_start;
}  // namespace

TEST(PolyhedronGravity, EvaluateAccelerationAndLaplacianDoNotAllocate) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "counting needs glibc, no sanitizer";
  const auto m = gravity_test::lumpy_body(16, 24, 250.0);
  const tubempc::gravity::PolyhedronGravity g(tubempc::gravity::Shape(m.v, m.f), 1260.0);
  tubempc::gravity::GravitySample s;
  const long before = allocations();
  double sum = 0.0;
  for (int i = 0; i < 20; ++i) {
    g.evaluate(Eigen::Vector3d(300.0 + i, -100.0, 50.0), s);
    sum += s.potential + g.laplacian(Eigen::Vector3d(10.0 * i, 0.0, 0.0)) +
           g.acceleration(Eigen::Vector3d(0.0, 200.0 + i, 30.0)).norm();
  }
  EXPECT_EQ(allocations() - before, 0);
  EXPECT_TRUE(std::isfinite(sum));
  // The counter works: a vector allocates.
  std::vector<double> v(10);
  EXPECT_GT(allocations() - before, 0);
}

TEST(CompositeGravity, EvaluateAccelerationAndLaplacianDoNotAllocate) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "counting needs glibc, no sanitizer";
  using tubempc::gravity::CompositeGravity;
  using tubempc::gravity::Shape;
  const auto m = gravity_test::lumpy_body(16, 24, 250.0);
  const auto core = gravity_test::box(-50.0, 50.0, -50.0, 50.0, -50.0, 50.0);
  const CompositeGravity g(
      {CompositeGravity::part(Shape(m.v, m.f), 1260.0, Eigen::Vector3d::Zero()),
       CompositeGravity::part(Shape(core.v, core.f), -150.0, Eigen::Vector3d(20.0, 0.0, 0.0))});
  tubempc::gravity::GravitySample s;
  const long before = allocations();
  double sum = 0.0;
  for (int i = 0; i < 20; ++i) {
    g.evaluate(Eigen::Vector3d(300.0 + i, -100.0, 50.0), s);
    sum += s.potential + g.laplacian(Eigen::Vector3d(10.0 * i, 0.0, 0.0)) +
           g.acceleration(Eigen::Vector3d(0.0, 200.0 + i, 30.0)).norm();
  }
  EXPECT_EQ(allocations() - before, 0);
  EXPECT_TRUE(std::isfinite(sum));
}
