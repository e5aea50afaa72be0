// The sensors' measurements and the navigation filter's propagation and updates must not allocate
// after construction: every malloc-family call and operator new is counted around them
// (tests/cpp/support/tubempc_testing/allocation_counter.hpp, glibc only).
#include <gtest/gtest.h>

#include <cstdlib>

#include "../nav/nav_fixtures.hpp"
#include "tubempc/nav/system.hpp"
#include "tubempc_testing/allocation_counter.hpp"

using namespace tubempc;
using tubempc_testing::AllocationWindow;

TEST(NavAllocation, CounterSeesAllocations) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  AllocationWindow window;
  std::vector<nav::Landmark> v(3);
  EXPECT_GE(window.count(), 1);
}

// The bytes a window reports (the set-up memory of examples/cpp/closed_loop): a block's usable size is at
// least its request; what is freed is no longer retained, but stays in the peak; a reallocation moves the
// block's bytes.
TEST(NavAllocation, CounterMeasuresTheBytesAScopeKeeps) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  // through volatile pointers, which the compiler cannot elide
  void* (*volatile allocate)(std::size_t) = std::malloc;
  void* (*volatile reallocate)(void*, std::size_t) = std::realloc;
  void (*volatile release)(void*) = std::free;
  AllocationWindow window;
  void* a = allocate(8000);
  EXPECT_GE(window.retained_bytes(), 8000);
  EXPECT_LT(window.retained_bytes(), 8000 + 64);
  void* b = reallocate(allocate(16), 1 << 20);
  EXPECT_GE(window.retained_bytes(), 8000 + (1 << 20));
  EXPECT_LT(window.retained_bytes(), 8000 + (1 << 20) + 8192);  // the 16-byte block is not kept
  release(a);
  release(b);
  EXPECT_EQ(window.retained_bytes(), 0);
  EXPECT_GE(window.peak_bytes(), 8000 + (1 << 20));
  EXPECT_GE(window.allocated_bytes(), 8000 + 16 + (1 << 20));
  EXPECT_EQ(window.count(), 5);  // 2 mallocs, a realloc, 2 frees
}

TEST(NavAllocation, SensorsAndFilterDoNotAllocateAfterSetup) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  const nav_test::World w = nav_test::make_world();
  nav_test::RunSettings rs;
  rs.altimeter.dropout_probability = 0.2;
  rs.camera.dropout_probability = 0.2;
  nav::FilterSettings fs;
  fs.altimeter = rs.altimeter;
  fs.camera = rs.camera;
  nav::Altimeter altimeter(w.caster, rs.altimeter, 1);
  nav::NavCamera camera(w.caster, w.landmarks, rs.camera, 2);
  nav::Imu imu(rs.imu, 3);
  nav::StarTracker star(rs.star_tracker, 4);
  nav::NavigationFilter filter(w.model, w.caster, w.landmarks, fs);
  dynamics::TruthState s;
  s << rs.r0_L, rs.v0_L, nav_test::nadir_attitude(rs.r0_L), rs.omega0_BL_B;
  nav::NavState x0;
  x0.r_L = rs.r0_L + Eigen::Vector3d(1.0, -1.0, 0.5);
  x0.v_L = rs.v0_L;
  x0.q_BL = s.segment<4>(6);
  ASSERT_EQ(filter.initialize(x0, nav::NavCovariance::Identity() * 1e-2), nav::FilterStatus::Ok);
  nav::ImuSample sample;
  nav::AltimeterMeasurement alt;
  nav::CameraFrame frame;
  nav::StarTrackerMeasurement st;
  dynamics::PropagatorSettings ps;
  ps.substeps = 1;
  long allocations = 0;
  int camera_updates = 0, altimeter_updates = 0;
  double checksum = 0.0;
  for (int k = 0; k < 200; ++k) {
    const double t = 0.1 * k;
    const nav::SensorTruth truth = nav_test::sensor_truth(*w.model, t, s);
    {
      AllocationWindow window;
      if (k > 0 && k % 10 == 0) {
        star.measure(truth, st);
        filter.update_star_tracker(st);
        altimeter.measure(truth, alt);
        altimeter_updates += filter.update_altimeter(alt).status == nav::FilterStatus::Ok;
      }
      if (k > 0 && k % 20 == 0) {
        camera.measure(truth, frame);
        camera_updates += filter.update_camera(frame).status == nav::FilterStatus::Ok;
        const dynamics::StateVector x = filter.model_state(Eigen::Vector3d::Zero());
        const dynamics::StateMatrix C = filter.model_covariance(x.segment<3>(6));
        checksum += x(0) + C(0, 0) + nav::nees(filter.state(), filter.covariance(), filter.state());
      }
      imu.measure(truth, sample);
      filter.propagate(t + 0.1, sample);
      allocations += window.count();
    }
    s = dynamics::propagate(*w.model, t, s, dynamics::InputVector::Zero(), 0.1, {}, ps).state;
  }
  EXPECT_GT(camera_updates, 3);
  EXPECT_GT(altimeter_updates, 5);
  EXPECT_TRUE(std::isfinite(checksum));
  EXPECT_EQ(allocations, 0);
}

TEST(NavAllocation, NavigationSystemStepDoesNotAllocate) {
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  const nav_test::World w = nav_test::make_world();
  nav::NavigationSettings ns;
  ns.imu.period = 0.1;
  ns.camera.dropout_probability = 0.2;
  ns.star_tracker.dropout_probability = 0.2;
  ns.filter.camera = ns.camera;
  ns.period_noise_sigma.setConstant(1e-3);
  nav::NavigationSystem sys(w.model, w.caster, w.caster, w.landmarks, ns, 5);
  nav_test::RunSettings rs;
  dynamics::TruthState s;
  s << rs.r0_L, rs.v0_L, nav_test::nadir_attitude(rs.r0_L), rs.omega0_BL_B;
  const int n = 20;
  Eigen::VectorXd t(n);
  Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNtruth, Eigen::RowMajor> x(n, dynamics::kNtruth);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> a = decltype(a)::Zero(n, 3);
  dynamics::PropagatorSettings ps;
  ps.substeps = 1;
  long allocations = 0;
  {
    AllocationWindow window;
    sys.initialize(0.0, s, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    allocations += window.count();
  }
  int ok = 0;
  for (int k = 0; k < 10; ++k) {
    for (int j = 0; j < n; ++j) {
      s = dynamics::propagate(*w.model, 2.0 * k + 0.1 * j, s, dynamics::InputVector::Zero(), 0.1, {}, ps)
              .state;
      t(j) = 2.0 * k + 0.1 * (j + 1);
      x.row(j) = s.transpose();
    }
    AllocationWindow window;
    ok += sys.step(t, x, a, Eigen::Vector3d::Zero()).status == nav::NavigationStatus::Ok;
    allocations += window.count();
  }
  EXPECT_GT(ok, 5);
  EXPECT_EQ(allocations, 0);
}

TEST(NavAllocation, FaultInjectionAndDetectionDoNotAllocate) {
  // Every injected kind acting and the detection raising outage, sensor and covariance statuses.
  if (!tubempc_testing::kAllocationCounterEnabled) GTEST_SKIP() << "allocation counter needs glibc";
  const nav_test::World w = nav_test::make_world();
  nav::NavigationSettings ns;
  ns.imu.period = 0.1;
  ns.filter.camera = ns.camera;
  nav::NavigationSystem sys(w.model, w.caster, w.caster, w.landmarks, ns, 5);
  std::vector<nav::SensorFault> faults;
  for (nav::SensorFaultKind kind :
       {nav::SensorFaultKind::LandmarkOutlier, nav::SensorFaultKind::LandmarkMismatch,
        nav::SensorFaultKind::AltimeterSpike, nav::SensorFaultKind::GyroBiasStep,
        nav::SensorFaultKind::AccelScaleStep, nav::SensorFaultKind::GyroScaleStep,
        nav::SensorFaultKind::AccelBiasStep, nav::SensorFaultKind::CameraOutage}) {
    nav::SensorFault f;
    f.kind = kind;
    f.t_start = kind == nav::SensorFaultKind::CameraOutage ? 10.0 : 2.0;
    f.magnitude = 1e-3;
    faults.push_back(f);
  }
  nav::FaultDetectionSettings det;
  det.outage_time = 4.0;
  det.max_position_sigma = 1.0;
  sys.set_faults(faults, det);
  nav_test::RunSettings rs;
  dynamics::TruthState s;
  s << rs.r0_L, rs.v0_L, nav_test::nadir_attitude(rs.r0_L), rs.omega0_BL_B;
  const int n = 20;
  Eigen::VectorXd t(n);
  Eigen::Matrix<double, Eigen::Dynamic, dynamics::kNtruth, Eigen::RowMajor> x(n, dynamics::kNtruth);
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> a = decltype(a)::Zero(n, 3);
  dynamics::PropagatorSettings ps;
  ps.substeps = 1;
  long allocations = 0;
  {
    AllocationWindow window;
    sys.initialize(0.0, s, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    allocations += window.count();
  }
  bool detected = false;
  for (int k = 0; k < 10; ++k) {
    for (int j = 0; j < n; ++j) {
      s = dynamics::propagate(*w.model, 2.0 * k + 0.1 * j, s, dynamics::InputVector::Zero(), 0.1, {}, ps)
              .state;
      t(j) = 2.0 * k + 0.1 * (j + 1);
      x.row(j) = s.transpose();
    }
    AllocationWindow window;
    detected = sys.step(t, x, a, Eigen::Vector3d::Zero()).fault_detected;
    allocations += window.count();
  }
  EXPECT_TRUE(detected);
  EXPECT_FALSE(std::isnan(sys.last().detected_at[static_cast<int>(nav::NavFault::CameraOutage)]));
  EXPECT_EQ(allocations, 0);
}
