// Bindings of the scenario file (tubempc::io, cpp/include/tubempc/io/scenario.hpp) as tubempc._core.io.
// The member types (ModelParams, PropagatorSettings, mpc::Settings, Reference, Tube, the nav and
// actuators settings) are bound by bind_dynamics, bind_mpc, bind_nav and bind_actuators, which must
// run first.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <string>

#include "bindings.hpp"
#include "tubempc/io/scenario.hpp"

namespace py = pybind11;

namespace tubempc::python {

void bind_io(py::module_& m) {
  auto s = m.def_submodule("io", "Scenario files (format 'tubempc-scenario 5'; see tubempc/io/scenario.hpp)");
  s.attr("FORMAT_VERSION") = io::kScenarioFormatVersion;

  py::class_<io::BodyModel> body(s, "BodyModel",
                                 "One 6-DOF model of a scenario: dynamics constants, density, shape file");
  body.def(py::init<>()).def_readwrite("params", &io::BodyModel::params, "dynamics.ModelParams (SI)");
  bind_fields(body);
  body.def("validate", &io::BodyModel::validate, "ValueError naming the first bad field.");

  py::class_<io::NavigationScenario>(s, "NavigationScenario",
                                     "The navigation of a scenario (records navigation.*, version 4)")
      .def(py::init<>())
      .def_readwrite("enabled", &io::NavigationScenario::enabled,
                     "whether the controller flies on the estimate")
      .def_readwrite("settings", &io::NavigationScenario::settings, "nav.NavigationSettings")
      .def_readwrite("landmarks", &io::NavigationScenario::landmarks, "list of nav.Landmark (frame A)")
      .def_readwrite("seed", &io::NavigationScenario::seed, "the navigation system's seed (<= 2^53)")
      .def_readwrite("error_set_scale", &io::NavigationScenario::error_set_scale,
                     "c of the estimation-error set {e : e^T (c P_x)^-1 e <= 1}");
  py::class_<io::ActuatorScenario>(s, "ActuatorScenario",
                                   "The actuators of a scenario (records actuators.*, version 4)")
      .def(py::init<>())
      .def_readwrite("enabled", &io::ActuatorScenario::enabled, "false: ideal actuators")
      .def_readwrite("thrusters", &io::ActuatorScenario::thrusters,
                     "list of actuators.ThrusterSpec: the truth's (nominal geometry, run errors, faults)")
      .def_readwrite("wheels", &io::ActuatorScenario::wheels, "list of actuators.ReactionWheelSpec")
      .def_readwrite("momentum_dump", &io::ActuatorScenario::momentum_dump, "actuators.MomentumDumpSettings")
      .def_readwrite("wheel_momentum", &io::ActuatorScenario::wheel_momentum,
                     "the wheels' initial momenta (N m s, one per wheel)")
      .def_readwrite("settings", &io::ActuatorScenario::settings, "actuators.ActuationSettings");

  py::class_<io::AbortScenario>(s, "AbortScenario",
                                "The safe abort of a scenario (records abort.*, version 6)")
      .def(py::init<>())
      .def_readwrite("enabled", &io::AbortScenario::enabled,
                     "whether the descent is supervised and may back away")
      .def_readwrite("settings", &io::AbortScenario::settings, "control.AbortSettings")
      .def_readwrite("hover", &io::AbortScenario::hover, "mpc.Reference of the hover (at least T + 1 nodes)")
      .def_readwrite("designs", &io::AbortScenario::designs,
                     "control.ControllerDesigns of the abort controller")
      .def_readwrite("command_step", &io::AbortScenario::command_step, "a commanded abort's step (-1: none)");

  py::class_<io::ScenarioFile>(s, "ScenarioFile", "Contents of a scenario file (see tubempc/io/scenario.hpp)")
      .def(py::init<>())
      .def_readwrite("directory", &io::ScenarioFile::directory, "folder of the file read")
      .def_readwrite("model", &io::ScenarioFile::model, "the controller's model (records model.*)")
      .def_readwrite("truth", &io::ScenarioFile::truth, "the simulated plant (records truth.*)")
      .def_readwrite("propagator", &io::ScenarioFile::propagator, "dynamics.PropagatorSettings of the truth")
      .def_readwrite("settings", &io::ScenarioFile::settings, "mpc.Settings")
      .def_readwrite("reference", &io::ScenarioFile::reference,
                     "mpc.Reference: z (12, T+1), u (6, T), t0 (s)")
      .def_readwrite("tube", &io::ScenarioFile::tube, "TBMPC's mpc.Tube: K (6, 12), Pe (12, 12)")
      .def_readwrite("has_controller", &io::ScenarioFile::has_controller,
                     "whether the file carries the whole controller (version 3)")
      .def_readwrite("controller", &io::ScenarioFile::controller, "control.ControllerSettings (version 3)")
      .def_readwrite("tbmpc_designs", &io::ScenarioFile::tbmpc_designs, "control.ControllerDesigns of TBMPC")
      .def_readwrite("ffa_designs", &io::ScenarioFile::ffa_designs, "control.ControllerDesigns of TBMPC-FFA")
      .def_readwrite("x0", &io::ScenarioFile::x0, "initial state (12): m, m/s, rad, rad/s")
      .def_readwrite("xf", &io::ScenarioFile::xf, "target state (12)")
      .def_readwrite("navigation", &io::ScenarioFile::navigation, "NavigationScenario (version 4)")
      .def_readwrite("actuators", &io::ScenarioFile::actuators, "ActuatorScenario (version 4)")
      .def_readwrite("abort", &io::ScenarioFile::abort, "AbortScenario (version 6)")
      .def_property_readonly("mission_steps", &io::ScenarioFile::mission_steps, "T (steps)")
      .def("resolve", &io::ScenarioFile::resolve, py::arg("path"),
           "path relative to directory (unless absolute)");

  s.def("read_scenario", &io::read_scenario, py::arg("path"),
        "Reads and validates a scenario file; ValueError '<path>:<line>: <record>: <what>'.");
  s.def("write_scenario", &io::write_scenario, py::arg("path"), py::arg("scenario"), py::arg("comment") = "",
        "Writes a scenario file with every record (the C++ writer).");
}

}  // namespace tubempc::python
