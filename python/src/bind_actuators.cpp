#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "bindings.hpp"
#include "tubempc/actuators/achievable_set.hpp"
#include "tubempc/actuators/system.hpp"

namespace py = pybind11;

namespace tubempc::python {

namespace {

using namespace tubempc::actuators;

}  // namespace

void bind_actuators(py::module_& m) {
  auto s = m.def_submodule(
      "actuators",
      "Thrusters, reaction wheels, allocation and the actuation sets (docs/model.md 'Actuators'); "
      "wrenches [F_B (N); T_B (N m)] in B, SI units");
  s.attr("MAX_THRUSTERS") = kMaxThrusters;
  s.attr("MAX_WHEELS") = kMaxWheels;
  s.attr("STANDARD_GRAVITY") = kStandardGravity;

  bind_named_enum<FaultKind>(s, "FaultKind", "A thruster's fault");
  bind_named_enum<PulseRounding>(s, "PulseRounding", "How the modulator rounds a commanded on-time");

  py::class_<ThrusterSpec> thruster(s, "ThrusterSpec",
                                    "One thruster (nominal geometry, truth errors and their bounds, fault)");
  thruster.def(py::init<>()).def("validate", &ThrusterSpec::validate, py::arg("what") = "thruster");
  bind_fields(thruster);

  py::class_<ThrusterCluster>(s, "ThrusterCluster",
                              "The thrusters of a spacecraft (a value: copies are independent)")
      .def(py::init<std::vector<ThrusterSpec>>(), py::arg("thrusters"))
      .def("__len__", &ThrusterCluster::size)
      .def_property_readonly("size", &ThrusterCluster::size)
      .def("thruster", &ThrusterCluster::thruster, py::arg("i"))
      .def_property_readonly("mapping", &ThrusterCluster::mapping, "Nominal D (6 x n): w_B = D f")
      .def_property_readonly("true_mapping", &ThrusterCluster::true_mapping, "Truth's mapping (6 x n)")
      .def_property_readonly("max_thrust", &ThrusterCluster::max_thrust)
      .def("set_fault", &ThrusterCluster::set_fault, py::arg("i"), py::arg("kind"), py::arg("t_start"))
      .def("fault_at", &ThrusterCluster::fault_at, py::arg("i"), py::arg("t"))
      .def("faults_at", &ThrusterCluster::faults_at, py::arg("t"))
      .def("copy", [](const ThrusterCluster& c) { return ThrusterCluster(c); });

  py::class_<ModulationSettings> modulation(s, "ModulationSettings", "Pulse modulation settings");
  modulation.def(py::init<>()).def("validate", &ModulationSettings::validate);
  bind_fields(modulation);

  py::class_<Firing>(s, "Firing", "One period's firing (a copy)")
      .def_readonly("on_time", &Firing::on_time)
      .def_readonly("impulse", &Firing::impulse)
      .def_readonly("commanded_B", &Firing::commanded_B)
      .def_readonly("delivered_B", &Firing::delivered_B)
      .def_readonly("propellant", &Firing::propellant)
      .def_readonly("pulses", &Firing::pulses);

  py::class_<PulseModulator>(s, "PulseModulator", "Pulse-width modulation with remainder carry-over")
      .def(py::init<const ThrusterCluster&, const ModulationSettings&>(), py::arg("cluster"),
           py::arg("settings"))
      .def(
          "modulate",
          [](PulseModulator& self, const ThrusterCluster& c, double t,
             const Eigen::Ref<const Eigen::VectorXd>& f) { return Firing(self.modulate(c, t, f)); },
          py::arg("cluster"), py::arg("t"), py::arg("thrust_cmd"))
      .def("reset", &PulseModulator::reset)
      .def_property_readonly("remainder", &PulseModulator::remainder)
      .def("remainder_bound", &PulseModulator::remainder_bound, py::arg("cluster"), py::arg("j"))
      .def("on_time_error_bound", &PulseModulator::on_time_error_bound, py::arg("cluster"), py::arg("j"))
      .def("on_time_excess_bound", &PulseModulator::on_time_excess_bound, py::arg("cluster"), py::arg("j"))
      .def("partner", &PulseModulator::partner, py::arg("j"))
      .def("effective_min_on_time", &PulseModulator::effective_min_on_time, py::arg("cluster"), py::arg("j"))
      .def_property_readonly("pulse_counts", &PulseModulator::pulse_counts)
      .def_property_readonly("propellant", &PulseModulator::propellant)
      .def_property_readonly("settings", &PulseModulator::settings);

  py::class_<ReactionWheelSpec> wheel(s, "ReactionWheelSpec", "One reaction wheel");
  wheel.def(py::init<>()).def("validate", &ReactionWheelSpec::validate, py::arg("what") = "wheel");
  bind_fields(wheel);

  py::class_<MomentumDumpSettings> dump(s, "MomentumDumpSettings",
                                        "When and how fast the wheels are unloaded");
  dump.def(py::init<>()).def("validate", &MomentumDumpSettings::validate);
  bind_fields(dump);

  py::class_<ReactionWheels>(s, "ReactionWheels",
                             "Reaction wheels and their momentum (a value: copies are independent)")
      .def(py::init<std::vector<ReactionWheelSpec>, const MomentumDumpSettings&>(), py::arg("wheels"),
           py::arg("dump") = MomentumDumpSettings{})
      .def("__len__", &ReactionWheels::size)
      .def_property_readonly("size", &ReactionWheels::size)
      .def("wheel", &ReactionWheels::wheel, py::arg("j"))
      .def_property_readonly("axes_B", &ReactionWheels::axes_B)
      .def_property_readonly("max_torque", &ReactionWheels::max_torque)
      .def_property_readonly("max_momentum", &ReactionWheels::max_momentum)
      .def_property_readonly("dump_settings", &ReactionWheels::dump_settings)
      .def_property_readonly("momentum", &ReactionWheels::momentum)
      .def_property_readonly("momentum_B", &ReactionWheels::momentum_B)
      .def("set_momentum", &ReactionWheels::set_momentum, py::arg("h"))
      .def("set_failure", &ReactionWheels::set_failure, py::arg("j"), py::arg("t_start"),
           "Fails wheel j from t_start (s) on: no torque, its momentum kept")
      .def("failure_time", &ReactionWheels::failure_time, py::arg("j"))
      .def("update_failures", &ReactionWheels::update_failures, py::arg("t"))
      .def_property_readonly("failed", &ReactionWheels::failed)
      .def(
          "torque_bounds",
          [](const ReactionWheels& w, double dt) {
            Eigen::VectorXd lo, hi;
            w.torque_bounds(dt, lo, hi);
            return std::make_tuple(lo, hi);
          },
          py::arg("dt"), "(lower, upper) wheel torques (N m) that keep |h| within its limit over dt")
      .def_property_readonly("dumping", &ReactionWheels::dumping)
      .def("preferred_torque",
           [](const ReactionWheels& w) {
             Eigen::VectorXd u;
             w.preferred_torque(u);
             return u;
           })
      .def("apply", &ReactionWheels::apply, py::arg("u"), py::arg("dt"))
      .def_property_readonly("applied_torque", &ReactionWheels::applied_torque)
      .def("copy", [](const ReactionWheels& w) { return ReactionWheels(w); });

  bind_named_enum<AllocationStatus>(s, "AllocationStatus", "Outcome of an allocation");

  py::class_<AllocationSettings> allocation(s, "AllocationSettings", "Allocation settings");
  allocation.def(py::init<>()).def("validate", &AllocationSettings::validate);
  bind_fields(allocation);

  py::class_<AllocationInfo>(s, "AllocationInfo", "Outcome and counters of an allocation")
      .def_readonly("status", &AllocationInfo::status)
      .def_readonly("iterations", &AllocationInfo::iterations)
      .def_readonly("failed_thrusters", &AllocationInfo::failed_thrusters)
      .def_readonly("resetup", &AllocationInfo::resetup)
      .def_readonly("dumping", &AllocationInfo::dumping)
      .def_readonly("remainder_norm", &AllocationInfo::remainder_norm)
      .def_readonly("solve_time", &AllocationInfo::solve_time);

  py::class_<AllocationResult>(s, "AllocationResult", "An allocation (a copy)")
      .def_readonly("thrust", &AllocationResult::thrust)
      .def_readonly("wheel_torque", &AllocationResult::wheel_torque)
      .def_readonly("wrench_B", &AllocationResult::wrench_B)
      .def_readonly("remainder_B", &AllocationResult::remainder_B)
      .def_readonly("info", &AllocationResult::info);

  py::class_<Allocator>(s, "Allocator",
                        "Bounded least-squares allocation of a wrench to thrusts and wheel torques")
      .def(py::init<const ThrusterCluster&, const ReactionWheels&, const AllocationSettings&>(),
           py::arg("cluster"), py::arg("wheels"), py::arg("settings") = AllocationSettings{})
      .def(
          "solve",
          [](Allocator& a, const ThrusterCluster& c, const ReactionWheels& w, double t, const Vector6& w_B) {
            return AllocationResult(a.solve(c, w, t, w_B));
          },
          py::arg("cluster"), py::arg("wheels"), py::arg("t"), py::arg("w_B"))
      .def(
          "last_problem",
          [](const Allocator& a) {
            Eigen::MatrixXd A;
            Eigen::VectorXd b, lo, hi;
            a.last_problem(A, b, lo, hi);
            return std::make_tuple(A, b, lo, hi);
          },
          "(A, b, lower, upper) of the last solve: min ||A x - b||^2, lower <= x <= upper")
      .def("set_extra_failures", &Allocator::set_extra_failures, py::arg("failed_off"))
      .def_property_readonly("thrusters", &Allocator::thrusters)
      .def_property_readonly("wheels", &Allocator::wheels)
      .def_property_readonly("mapping", &Allocator::mapping)
      .def_property_readonly("settings", &Allocator::settings);

  s.def("wrench_from_input", &wrench_from_input, py::arg("u"), py::arg("C_BL"), py::arg("mass"),
        "[m C_BL u_p; T] from the MPC input [u_p (m/s^2, L); T (N m, B)]");
  s.def("input_from_wrench", &input_from_wrench, py::arg("w_B"), py::arg("C_BL"), py::arg("mass"),
        "[C_BL^T F_B / m; T_B] from a wrench in B");

  py::class_<AchievableBox>(s, "AchievableBox", "An inner box of the achievable wrenches")
      .def_readonly("half_width_B", &AchievableBox::half_width_B)
      .def_readonly("input_half_width", &AchievableBox::input_half_width)
      .def_readonly("scale", &AchievableBox::scale)
      .def_readonly("limiting_failure", &AchievableBox::limiting_failure)
      .def_readonly("empty", &AchievableBox::empty)
      .def_readonly("vertices_checked", &AchievableBox::vertices_checked);
  py::class_<AchievableBoxSettings>(s, "AchievableBoxSettings", "Settings of the inner-box computation")
      .def(py::init<>())
      .def_readwrite("shape", &AchievableBoxSettings::shape)
      .def_readwrite("momentum_fraction", &AchievableBoxSettings::momentum_fraction)
      .def_readwrite("tolerate_one_failure", &AchievableBoxSettings::tolerate_one_failure)
      .def_readwrite("bisection_steps", &AchievableBoxSettings::bisection_steps)
      .def_readwrite("time", &AchievableBoxSettings::time)
      .def("validate", &AchievableBoxSettings::validate);
  s.def("achievable_box", &achievable_box, py::arg("cluster"), py::arg("wheels"), py::arg("allocation"),
        py::arg("mass"), py::arg("settings") = AchievableBoxSettings{});

  py::class_<ActuationErrorBound>(s, "ActuationErrorBound", "A box containing every actuation error")
      .def_readonly("modulation_B", &ActuationErrorBound::modulation_B)
      .def_readonly("misalignment_B", &ActuationErrorBound::misalignment_B)
      .def_readonly("thrust_norm", &ActuationErrorBound::thrust_norm)
      .def_readonly("wrench_B", &ActuationErrorBound::wrench_B)
      .def_readonly("input", &ActuationErrorBound::input)
      .def_readonly("shape_p", &ActuationErrorBound::shape_p)
      .def_readonly("shape_T", &ActuationErrorBound::shape_T);
  s.def("actuation_error_bound",
        py::overload_cast<const ThrusterCluster&, const PulseModulator&, double>(&actuation_error_bound),
        py::arg("cluster"), py::arg("modulator"), py::arg("mass"), "The actuation-error box for any command");
  s.def("actuation_error_bound",
        py::overload_cast<const ThrusterCluster&, const PulseModulator&, double, const ReactionWheels&,
                          const AllocationSettings&, const Vector6&, double, bool, double>(
            &actuation_error_bound),
        py::arg("cluster"), py::arg("modulator"), py::arg("mass"), py::arg("wheels"), py::arg("allocation"),
        py::arg("command_half_width_B"), py::arg("t") = 0.0, py::arg("tolerate_one_failure") = true,
        py::arg("command_force_norm") = std::numeric_limits<double>::infinity(),
        "The actuation-error box for commands inside a wrench box (the allocation's thrust norm bounded)");
  s.def("disturbance_with_actuation_error", &disturbance_with_actuation_error, py::arg("P_W"), py::arg("B"),
        py::arg("E"),
        "P of an ellipsoid containing W (+) B E (trace-minimal member of the outer family; M38)");

  py::class_<ActuationSettings> actuation(s, "ActuationSettings", "Settings of the actuation system");
  actuation.def(py::init<>()).def("validate", &ActuationSettings::validate);
  bind_fields(actuation);

  py::class_<ActuationStep>(s, "ActuationStep", "One period's actuation (a copy)")
      .def_readonly("status", &ActuationStep::status)
      .def_readonly("allocation", &ActuationStep::allocation)
      .def_readonly("u_commanded", &ActuationStep::u_commanded)
      .def_readonly("u_delivered", &ActuationStep::u_delivered)
      .def_readonly("commanded_B", &ActuationStep::commanded_B)
      .def_readonly("allocated_B", &ActuationStep::allocated_B)
      .def_readonly("delivered_B", &ActuationStep::delivered_B)
      .def_readonly("error_B", &ActuationStep::error_B)
      .def_readonly("remainder_B", &ActuationStep::remainder_B)
      .def_readonly("thrust", &ActuationStep::thrust)
      .def_readonly("on_time", &ActuationStep::on_time)
      .def_readonly("impulse", &ActuationStep::impulse)
      .def_readonly("wheel_torque", &ActuationStep::wheel_torque)
      .def_readonly("wheel_momentum", &ActuationStep::wheel_momentum)
      .def_readonly("impulse_total", &ActuationStep::impulse_total)
      .def_readonly("delta_v", &ActuationStep::delta_v)
      .def_readonly("propellant", &ActuationStep::propellant)
      .def_readonly("pulses", &ActuationStep::pulses)
      .def_readonly("failed_thrusters", &ActuationStep::failed_thrusters)
      .def_readonly("failed_wheels", &ActuationStep::failed_wheels)
      .def_readonly("step_time", &ActuationStep::step_time);

  py::class_<ActuationTotals>(s, "ActuationTotals", "A mission's actuation totals")
      .def_readonly("impulse", &ActuationTotals::impulse)
      .def_readonly("delta_v", &ActuationTotals::delta_v)
      .def_readonly("propellant", &ActuationTotals::propellant)
      .def_readonly("pulses", &ActuationTotals::pulses)
      .def_readonly("steps", &ActuationTotals::steps)
      .def_readonly("not_delivered", &ActuationTotals::not_delivered)
      .def_readonly("max_wheel_momentum_fraction", &ActuationTotals::max_wheel_momentum_fraction);

  py::class_<ActuationSystem>(s, "ActuationSystem",
                              "Thrusters, wheels, allocation and modulation as one call per control period")
      .def(py::init<const ThrusterCluster&, const ReactionWheels&, const ActuationSettings&>(),
           py::arg("cluster"), py::arg("wheels"), py::arg("settings"))
      .def(
          "step",
          [](ActuationSystem& self, double t, const Vector6& u, const Eigen::Matrix3d& C_BL) {
            return ActuationStep(self.step(t, u, C_BL));
          },
          py::arg("t"), py::arg("u"), py::arg("C_BL"),
          "Actuates one period: the command [u_p (m/s^2, L); T (N m, B)] to the delivered input (a copy)")
      .def("reset", &ActuationSystem::reset, py::arg("wheel_momentum"))
      .def_property_readonly("totals", &ActuationSystem::totals)
      .def_property_readonly("cluster", &ActuationSystem::cluster)
      .def_property_readonly("wheels", &ActuationSystem::wheels)
      .def(
          "last_problem",
          [](const ActuationSystem& self) {
            Eigen::MatrixXd A;
            Eigen::VectorXd b, lo, hi;
            self.allocator().last_problem(A, b, lo, hi);
            return std::make_tuple(A, b, lo, hi);
          },
          "(A, b, lower, upper) of the last allocation: min ||A x - b||^2, lower <= x <= upper")
      .def_property_readonly("remainder",
                             [](const ActuationSystem& self) { return self.modulator().remainder(); })
      .def_property_readonly("settings", &ActuationSystem::settings);
}

}  // namespace tubempc::python
