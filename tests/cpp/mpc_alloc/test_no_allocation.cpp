// TubeMPC::step must not allocate after setup. Two independent checks, both switched on only
// around the steps:
//  1. counting allocator: global operator new/delete are replaced and malloc/calloc/realloc/
//     free/posix_memalign/aligned_alloc/memalign are interposed (forwarding to glibc's __libc_*),
//     so allocations by PIQP, Eigen, the standard library and C code are all seen;
//  2. Eigen's runtime guard: the implementation (and with it PIQP's header-only solver) is compiled
//     into this translation unit with EIGEN_RUNTIME_NO_MALLOC and an eigen_assert that counts, so
//     every Eigen allocation while the guard is on is recorded even in a release build.
#include "tubempc_testing/allocation_counter.hpp"

namespace alloc_test {
using tubempc_testing::AllocationCounter;
long eigen_failures = 0;
}  // namespace alloc_test

#define EIGEN_RUNTIME_NO_MALLOC
#define eigen_assert(x)                       \
  do {                                        \
    if (!(x)) ++::alloc_test::eigen_failures; \
  } while (false)

// The implementation under test (the MPC and its active-set QP solver), compiled here with the Eigen guard
// (its symbols take precedence over the static library's copy).
#include <gtest/gtest.h>

#include "../../../cpp/src/mpc/active_set_qp.cpp"
#include "../../../cpp/src/mpc/linearization_cache.cpp"
#include "../../../cpp/src/mpc/lti_model.cpp"
#include "../../../cpp/src/mpc/qp_backend.cpp"
#include "../../../cpp/src/mpc/qp_layout.cpp"
#include "../../../cpp/src/mpc/tube_mpc.cpp"
#include "tubempc_testing/control_fixtures.hpp"

using namespace tubempc::mpc;

namespace {

struct Guard {
  Guard() {
    alloc_test::AllocationCounter::count = 0;
    alloc_test::eigen_failures = 0;
    Eigen::internal::set_is_malloc_allowed(false);
    alloc_test::AllocationCounter::counting = true;
  }
  ~Guard() {
    alloc_test::AllocationCounter::counting = false;
    Eigen::internal::set_is_malloc_allowed(true);
  }
};

// The paper-sized 12-state, 6-input plant with four planar constraints per node (shared with the
// control tests).
using control_test::plant_12_6;

}  // namespace

TEST(TubeMPCAllocation, CounterSeesAllocations) {
  {
    Guard g;
    Eigen::VectorXd v(100);
    v.setZero();
    void* p = std::malloc(8);
    std::free(p);
  }
  EXPECT_GE(alloc_test::AllocationCounter::count, 4);  // new or malloc + free for the vector, malloc + free
  EXPECT_GE(alloc_test::eigen_failures, 1);
}

TEST(TubeMPCAllocation, StepDoesNotAllocateAfterSetup) {
  for (bool soft : {false, true}) {
    const double dt = 2.0;
    auto model = plant_12_6(dt);
    Settings s;
    s.horizon = 30;
    s.dt = dt;
    s.R = Eigen::VectorXd((Eigen::VectorXd(6) << 1e3, 1e3, 1e3, 1e4, 1e4, 1e4).finished()).asDiagonal();
    s.u_max = (Eigen::VectorXd(6) << 0.55, 0.55, 0.55, 3.0, 3.0, 3.0).finished();
    s.time_limit = 10.0;
    s.trust_region = 50.0;
    s.soft_state_constraints = soft;
    s.soft_terminal = soft;
    s.input_cost = soft ? InputCost::Deviation : InputCost::Absolute;
    s.qp_scale_cost = !soft;  // PIQP's cost scaling and 1e6 L1 penalties do not mix (Settings::qp_scale_cost)
    if (soft) {               // block-diagonal structure of the two subsystems (exercises the sparse masks)
      s.A_structure = Eigen::MatrixXd::Zero(12, 12);
      s.A_structure.topLeftCorner(6, 6).setOnes();
      s.A_structure.bottomRightCorner(6, 6).setOnes();
      s.B_structure = Eigen::MatrixXd::Zero(12, 6);
      s.B_structure.topLeftCorner(6, 3).setOnes();
      s.B_structure.bottomRightCorner(6, 3).setOnes();
    }
    TubeMPC mpc(model, s);
    const int T = 40;
    Reference ref;
    ref.z = Eigen::MatrixXd::Zero(12, T + 1);
    ref.u = Eigen::MatrixXd::Zero(6, T);
    for (int j = 0; j <= T; ++j) ref.z(0, j) = 50.0 * (1.0 - static_cast<double>(j) / T);
    ref.z.block(3, 0, 1, T).setConstant(-50.0 / (T * dt));
    mpc.setup(ref);
    Tube tube;
    tube.K = Eigen::MatrixXd::Zero(6, 12);
    tube.K.block(0, 0, 3, 3) = -0.01 * Eigen::MatrixXd::Identity(3, 3);
    tube.K.block(0, 3, 3, 3) = -0.1 * Eigen::MatrixXd::Identity(3, 3);
    tube.Pe = 1e-3 * Eigen::MatrixXd::Identity(12, 12);
    Eigen::VectorXd x = ref.z.col(0);
    x(0) += 0.01;
    Eigen::MatrixXd A(12, 12), B(12, 6);
    Eigen::VectorXd c(12), x_next(12);
    int solved = 0, fallbacks = 0;
    long total_allocs = 0, total_eigen = 0;
    for (int k = 0; k < T; ++k) {
      Status status;
      {
        Guard g;
        const StepResult& r = mpc.step(k, x, tube);
        status = r.status;
        model->discretize(0.0, dt, x, r.u, A, B, c);
        x_next.noalias() = A * x;
        x_next.noalias() += B * r.u;
        x = x_next + c;
      }
      total_allocs += alloc_test::AllocationCounter::count;
      total_eigen += alloc_test::eigen_failures;
      EXPECT_EQ(alloc_test::AllocationCounter::count, 0) << "step " << k << " (" << to_string(status) << ")";
      EXPECT_EQ(alloc_test::eigen_failures, 0) << "step " << k;
      if (status == Status::Solved) ++solved;
    }
    // A fallback path, too.
    {
      Tube fat = tube;
      fat.K(0, 0) = 1e3;
      Guard g;
      fallbacks += mpc.step(T - 1, x, fat).status == Status::FallbackShiftedPlan;
    }
    EXPECT_EQ(alloc_test::AllocationCounter::count, 0);
    EXPECT_EQ(solved, T) << "soft = " << soft;
    EXPECT_EQ(fallbacks, 1);
    EXPECT_EQ(total_allocs + total_eigen, 0);
  }
}
