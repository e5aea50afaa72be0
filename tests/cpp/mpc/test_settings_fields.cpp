// The field table of mpc::Settings and the name tables of the option enums (core/fields.hpp).
#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <string>
#include <type_traits>
#include <utility>

#include "tubempc/actuators/system.hpp"
#include "tubempc/control/controller.hpp"
#include "tubempc/dynamics/propagator.hpp"
#include "tubempc/io/scenario.hpp"
#include "tubempc/mpc/active_set_qp.hpp"
#include "tubempc/mpc/results.hpp"
#include "tubempc/mpc/settings.hpp"
#include "tubempc/nav/system.hpp"

using namespace tubempc;

namespace {

// Every enumerator 0..n-1 has exactly one entry; names and identifiers are distinct; the name maps back.
template <typename E>
void expect_complete_table(std::size_t enumerators) {
  const auto& values = core::EnumNames<E>::values;
  ASSERT_EQ(values.size(), enumerators);
  std::set<std::string> names, identifiers;
  for (std::size_t i = 0; i < enumerators; ++i) {
    const E v = static_cast<E>(i);
    EXPECT_TRUE(core::is_named(v)) << i;
    E back{};
    ASSERT_TRUE(core::enum_from_name(core::enum_name(v), back)) << core::enum_name(v);
    EXPECT_EQ(back, v);
    names.insert(core::enum_name(v));
    identifiers.insert(values[i].identifier);
  }
  EXPECT_EQ(names.size(), enumerators);
  EXPECT_EQ(identifiers.size(), enumerators);
  EXPECT_FALSE(core::is_named(static_cast<E>(enumerators)));
  EXPECT_STREQ(core::enum_name(static_cast<E>(enumerators)), "unknown");
  E untouched = static_cast<E>(0);
  EXPECT_FALSE(core::enum_from_name("no_such_name", untouched));
}

}  // namespace

TEST(SettingsFields, EnumTablesAreCompleteAndInvertible) {
  expect_complete_table<mpc::InitialCondition>(2);
  expect_complete_table<mpc::InputCost>(2);
  expect_complete_table<mpc::QpSolver>(2);
  expect_complete_table<mpc::Linearization>(2);
  expect_complete_table<mpc::ScpMode>(2);
  expect_complete_table<mpc::KktSolver>(2);
  expect_complete_table<dynamics::Kinematics>(2);
  expect_complete_table<dynamics::Integrator>(2);
  expect_complete_table<control::MeasuredInput>(2);
}

TEST(SettingsFields, StatusTablesAreCompleteAndInvertible) {
  expect_complete_table<mpc::Status>(11);
  expect_complete_table<mpc::ActiveSetQp::Status>(5);
  expect_complete_table<actuators::FaultKind>(3);
  expect_complete_table<actuators::AllocationStatus>(6);
  expect_complete_table<nav::SensorStatus>(6);
  expect_complete_table<nav::SensorFaultKind>(10);
  expect_complete_table<nav::NavFault>(9);
  expect_complete_table<nav::FilterStatus>(9);
  expect_complete_table<nav::Sensor>(4);
  expect_complete_table<nav::NavigationStatus>(5);
  expect_complete_table<dynamics::DiscretizationStatus>(3);
  expect_complete_table<dynamics::PropagationStatus>(4);
  expect_complete_table<control::Method>(2);
  expect_complete_table<control::Certification>(4);
  expect_complete_table<control::TubeStatus>(7);
}

// The status names are the results files' format (per-step statuses in <method>.h5 and summary.json).
TEST(SettingsFields, StatusNamesAreTheResultsFormat) {
  EXPECT_EQ(mpc::to_string(mpc::Status::FallbackShiftedPlan), "fallback_shifted_plan");
  EXPECT_EQ(mpc::to_string(mpc::Status::SolvedInaccurate), "solved_inaccurate");
  EXPECT_STREQ(dynamics::to_string(dynamics::PropagationStatus::MaxStepsReached), "max_steps_reached");
  EXPECT_STREQ(dynamics::to_string(dynamics::DiscretizationStatus::NonFiniteResult), "non_finite_result");
  EXPECT_STREQ(control::to_string(control::Method::Tbmpc), "tbmpc");
  EXPECT_STREQ(control::to_string(control::TubeStatus::LyapunovNoMargin), "lyapunov_no_margin");
  EXPECT_STREQ(control::to_string(control::Certification::InvarianceViolated), "invariance_violated");
  int fallbacks = 0;
  for (const auto& entry : core::EnumNames<mpc::Status>::values) {
    EXPECT_EQ(mpc::is_fallback(entry.value), std::string(entry.name).rfind("fallback_", 0) == 0)
        << entry.name;
    fallbacks += mpc::is_fallback(entry.value) ? 1 : 0;
  }
  EXPECT_EQ(fallbacks, 2);
}

// The names are the scenario and configuration files' format: files written before must still read.
TEST(SettingsFields, NamesAreTheFileFormatsAndToStringUsesThem) {
  EXPECT_STREQ(mpc::to_string(mpc::QpSolver::ActiveSet), "active_set");
  EXPECT_STREQ(mpc::to_string(mpc::QpSolver::Piqp), "piqp");
  EXPECT_STREQ(mpc::to_string(mpc::Linearization::EveryIteration), "every_iteration");
  EXPECT_STREQ(mpc::to_string(mpc::ScpMode::RealTime), "real_time");
  EXPECT_STREQ(mpc::to_string(mpc::InputCost::Deviation), "deviation");
  EXPECT_STREQ(core::enum_name(mpc::InitialCondition::WhitenedBox), "whitened_box");
  EXPECT_STREQ(core::enum_name(mpc::KktSolver::SparseMultistage), "sparse_multistage");
  EXPECT_EQ(core::enum_names_list<mpc::QpSolver>(), "'piqp', 'active_set'");
  EXPECT_STREQ(dynamics::to_string(dynamics::Kinematics::FirstOrder), "first_order");
  EXPECT_STREQ(dynamics::to_string(dynamics::Integrator::DOPRI5), "dopri5");
  EXPECT_STREQ(control::to_string(control::MeasuredInput::ReferenceDeviation), "reference_deviation");
}

namespace {

// Each field once: distinct names and distinct members; matrices have a size (a fixed-size one its
// own: a fixed Dim or Nw, 6), scalars and nested structs none; a nested struct's fields are listed once too.
template <typename S>
std::set<std::string> expect_fields_listed_once() {
  S s;
  std::set<std::string> names;
  std::set<std::uintptr_t> addresses;
  int n = 0;
  S::for_each_field([&](const core::FieldInfo& f, auto member) {
    ++n;
    names.insert(f.name);
    addresses.insert(reinterpret_cast<std::uintptr_t>(&(s.*member)));
    using T = std::decay_t<decltype(s.*member)>;
    if constexpr (core::has_fields<T>::value) {
      EXPECT_EQ(f.rows, core::Dim::One) << f.name;
      EXPECT_EQ(f.cols, core::Dim::One) << f.name;
      EXPECT_STREQ(f.unit, "") << f.name;
      expect_fields_listed_once<T>();
    } else {
      constexpr bool matrix =
          !std::is_arithmetic_v<T> && !std::is_enum_v<T> && !std::is_same_v<T, std::string>;
      EXPECT_EQ(matrix, f.rows != core::Dim::One) << f.name;
      if constexpr (matrix) {
        if constexpr (T::SizeAtCompileTime != Eigen::Dynamic) {  // a fixed dimension is its own (Nw is 6)
          for (const auto& [dim, size] :
               {std::pair{f.rows, T::RowsAtCompileTime}, {f.cols, T::ColsAtCompileTime}})
            EXPECT_EQ(core::fixed_size(dim) < 0 ? 6 : core::fixed_size(dim), size) << f.name;
        }
      }
    }
    if (!std::is_same_v<T, double>) EXPECT_FALSE(f.allow_infinite) << f.name;
  });
  EXPECT_EQ(static_cast<int>(names.size()), n);
  EXPECT_EQ(static_cast<int>(addresses.size()), n);
  return names;
}

}  // namespace

TEST(SettingsFields, EveryFieldIsListedOnceWithItsMember) {
  const std::set<std::string> names = expect_fields_listed_once<mpc::Settings>();
  for (const char* required : {"horizon", "dt", "Q", "R", "u_max", "input_cost", "scp_eps"})
    EXPECT_EQ(names.count(required), 1u) << required;
  EXPECT_EQ(expect_fields_listed_once<control::IdentifierSettings>().size(), 6u);
  EXPECT_EQ(expect_fields_listed_once<dynamics::ModelParams>().size(), 13u);
  EXPECT_EQ(expect_fields_listed_once<io::BodyModel>().size(), 3u);
}

// The navigation and actuator settings: every member listed (the count of the struct's data members).
TEST(SettingsFields, NavigationAndActuatorFieldsAreListedOnce) {
  EXPECT_EQ(expect_fields_listed_once<nav::AltimeterSettings>().size(), 7u);
  EXPECT_EQ(expect_fields_listed_once<nav::CameraSettings>().size(), 13u);
  EXPECT_EQ(expect_fields_listed_once<nav::ImuSettings>().size(), 8u);
  EXPECT_EQ(expect_fields_listed_once<nav::StarTrackerSettings>().size(), 4u);
  EXPECT_EQ(expect_fields_listed_once<nav::FilterSettings>().size(), 13u);
  EXPECT_EQ(expect_fields_listed_once<nav::NavigationSettings>().size(), 8u);
  EXPECT_EQ(expect_fields_listed_once<actuators::ThrusterSpec>().size(), 11u);
  EXPECT_EQ(expect_fields_listed_once<actuators::ReactionWheelSpec>().size(), 3u);
  EXPECT_EQ(expect_fields_listed_once<actuators::MomentumDumpSettings>().size(), 4u);
  EXPECT_EQ(expect_fields_listed_once<actuators::ModulationSettings>().size(), 4u);
  EXPECT_EQ(expect_fields_listed_once<actuators::AllocationSettings>().size(), 9u);
  EXPECT_EQ(expect_fields_listed_once<actuators::ActuationSettings>().size(), 3u);
  static_assert(core::has_fields<nav::CameraSettings>::value);
  static_assert(!core::has_fields<Eigen::Vector3d>::value);
}
