#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "tubempc/control/abort.hpp"
#include "tubempc/control/controller.hpp"

namespace py = pybind11;

namespace tubempc::python {

namespace {

using namespace tubempc::control;

// A step's result with its own copy of the MPC's (the controller's storage changes at the next step).
struct StepCopy : ControlStep {
  mpc::StepResult mpc_result;
};

// One step of `step` (a Controller's or a SafeAbort's) with the GIL released, returned as a copy.
template <typename Stepper>
StepCopy step_copy(Stepper& self, int k, const Eigen::VectorXd& x) {
  const ControlStep* out = nullptr;
  {
    py::gil_scoped_release release;
    out = &self.step(k, x);
  }
  StepCopy copy;
  static_cast<ControlStep&>(copy) = *out;
  copy.mpc = nullptr;
  copy.mpc_result = *out->mpc;
  return copy;
}

}  // namespace

void bind_control(py::module_& m) {
  auto s = m.def_submodule("control",
                           "The whole TBMPC / TBMPC-FFA control step: identification, certified tube update, "
                           "tube MPC (docs/model.md 'Closed loop'); SI units");

  bind_named_enum<Method>(s, "Method", "TBMPC (fixed tube) or TBMPC-FFA (identified tube)");
  bind_named_enum<MeasuredInput>(s, "MeasuredInput", "The identification's measured exogenous input");
  bind_named_enum<TubeStatus>(s, "TubeStatus", "How a step's tube came about");
  bind_named_enum<Certification>(s, "Certification", "Outcome of a Lyapunov certification");
  s.def(
      "certified", [](TubeStatus st) { return certified(st); }, py::arg("status"),
      "Whether a tube status means certified for the step's linearisation and identified P_W");
  s.attr("LYAPUNOV_MARGIN") = kLyapunovMargin;
  s.attr("EXCURSION_TOLERANCE") = kExcursionTolerance;
  s.attr("MAX_INPUT_NIS_WINDOW") = kMaxInputNisWindow;

  py::class_<IdentifierSettings> identifier(s, "IdentifierSettings",
                                            "One subsystem's forgetting-factor identifier");
  identifier.def(py::init<>());
  bind_fields(identifier);
  identifier.def("validate", &IdentifierSettings::validate, py::arg("what") = "identifier");

  py::class_<ForgettingFactorIdentifier>(s, "ForgettingFactorIdentifier",
                                         "Recursive mean and covariance of a subsystem's exogenous input")
      .def(py::init<const IdentifierSettings&>(), py::arg("settings"))
      .def("reset", &ForgettingFactorIdentifier::reset)
      .def(
          "update", [](ForgettingFactorIdentifier& self, const SubVector& w) { return self.update(w); },
          py::arg("w"), "Folds w in; False (and ignored) if w is not finite")
      .def_property_readonly("w_hat", &ForgettingFactorIdentifier::w_hat)
      .def_property_readonly("S_hat", &ForgettingFactorIdentifier::S_hat)
      .def_property_readonly("P_W", &ForgettingFactorIdentifier::P_W)
      .def_property_readonly("zeta", &ForgettingFactorIdentifier::zeta)
      .def_property_readonly("updates", &ForgettingFactorIdentifier::updates)
      .def_property_readonly("q", &ForgettingFactorIdentifier::q);

  py::class_<SubsystemDesign>(s, "SubsystemDesign", "An LMI design: K (3 x 6), alpha, P_W and Pe (6 x 6)")
      .def(py::init([](const SubGain& K, double alpha, const SubMatrix& P_W, const SubMatrix& Pe) {
             return SubsystemDesign{K, alpha, P_W, Pe};
           }),
           py::arg("K"), py::arg("alpha"), py::arg("P_W"), py::arg("Pe"))
      .def_readwrite("K", &SubsystemDesign::K)
      .def_readwrite("alpha", &SubsystemDesign::alpha)
      .def_readwrite("P_W", &SubsystemDesign::P_W)
      .def_readwrite("Pe", &SubsystemDesign::Pe)
      .def("validate", &SubsystemDesign::validate, py::arg("what") = "design");

  py::class_<SubsystemTube>(s, "SubsystemTube", "A certified tube: K, Pe, alpha, residual")
      .def_readonly("K", &SubsystemTube::K)
      .def_readonly("Pe", &SubsystemTube::Pe)
      .def_readonly("alpha", &SubsystemTube::alpha)
      .def_readonly("residual", &SubsystemTube::residual);

  s.def("lmi_residual", &lmi_residual, py::arg("A"), py::arg("B"), py::arg("K"), py::arg("Pe"),
        py::arg("P_W"), py::arg("alpha"),
        "Violation of the invariance condition relative to Pe (<= 0 iff it holds)");
  s.def(
      "lyapunov_tube",
      [](const SubMatrix& A, const SubInputMatrix& B, const SubGain& K, double alpha, const SubMatrix& P_W,
         double u_max) {
        SubsystemTube out;
        const Certification c = lyapunov_tube(A, B, K, alpha, P_W, u_max, out);
        return py::make_tuple(c, c == Certification::Certified ? py::cast(out) : py::none());
      },
      py::arg("A"), py::arg("B"), py::arg("K"), py::arg("alpha"), py::arg("P_W"), py::arg("u_max"),
      "(Certification, SubsystemTube or None): the certified Lyapunov update of a design's (K, alpha)");
  s.def("cover_ratio", &cover_ratio, py::arg("P"), py::arg("P_cover"),
        "lambda_max(P_cover^-1 P): <= 1 iff the ellipsoid of P lies in that of P_cover");
  s.def("input_error_with_feedforward", &input_error_with_feedforward, py::arg("E"), py::arg("rho"),
        "The input-error set E (+) the feed-forward's box |u_ff,i| <= rho_i (M43)");

  py::class_<TubePolicySettings> tube_policy_settings(s, "TubePolicySettings",
                                                      "The tube update policy's settings");
  tube_policy_settings.def(py::init<>());
  bind_fields(tube_policy_settings);
  tube_policy_settings.def("validate", &TubePolicySettings::validate);

  py::class_<TubePolicy>(s, "TubePolicy", "One subsystem's tube, step by step (no SDP inside)")
      .def(py::init<const TubePolicySettings&, double, const SubsystemDesign&, std::vector<SubsystemDesign>,
                    const std::string&>(),
           py::arg("settings"), py::arg("u_max"), py::arg("initial"), py::arg("library"),
           py::arg("what") = "tube")
      .def("reset", &TubePolicy::reset)
      .def("update", &TubePolicy::update, py::arg("k"), py::arg("A"), py::arg("B"), py::arg("P_W"),
           py::arg("design_due"))
      .def("adopt", &TubePolicy::adopt, py::arg("design"), py::arg("k_started"))
      .def_property_readonly("tube", &TubePolicy::tube)
      .def_property_readonly("design", &TubePolicy::design)
      .def_property_readonly("library", &TubePolicy::library);

  py::class_<ControllerSettings>(s, "ControllerSettings",
                                 "The controller's settings (the MPC's: mpc.Settings)")
      .def(py::init<>())
      .def_readwrite("method", &ControllerSettings::method)
      .def_readwrite("measured_input", &ControllerSettings::measured_input)
      .def_readwrite("identification_p", &ControllerSettings::identification_p)
      .def_readwrite("identification_r", &ControllerSettings::identification_r)
      .def_readwrite("tube", &ControllerSettings::tube)
      .def_readwrite(
          "actuation_error", &ControllerSettings::actuation_error,
          "[E_p ((m/s^2)^2), E_r ((N m)^2)]: certified input-error sets added to P_W (zero: ideal)")
      .def_readwrite("feedforward", &ControllerSettings::feedforward,
                     "TBMPC-FFA: cancel the identified mean input through the command (M43)")
      .def_readwrite("feedforward_limit", &ControllerSettings::feedforward_limit,
                     "largest feed-forward per component, a fraction of the MPC's input bound")
      .def("validate", &ControllerSettings::validate);

  py::class_<ControllerDesigns>(s, "ControllerDesigns", "Initial designs and libraries of both subsystems")
      .def(py::init<>())
      .def_readwrite("initial_p", &ControllerDesigns::initial_p)
      .def_readwrite("initial_r", &ControllerDesigns::initial_r)
      .def_readwrite("library_p", &ControllerDesigns::library_p)
      .def_readwrite("library_r", &ControllerDesigns::library_r);

  py::class_<ControlTimings>(s, "ControlTimings", "Wall-clock split of a control step (s)")
      .def_readonly("identify", &ControlTimings::identify)
      .def_readonly("tube", &ControlTimings::tube)
      .def_readonly("mpc", &ControlTimings::mpc)
      .def_readonly("predict", &ControlTimings::predict)
      .def_readonly("total", &ControlTimings::total);

  py::class_<StepCopy>(s, "ControlStep", "Result of one control step (a copy; `mpc` the MPC's StepResult)")
      .def_readonly("u", &ControlStep::u)
      .def_readonly("tube", &ControlStep::tube)
      .def_readonly("tube_status", &ControlStep::tube_status)
      .def_readonly("alpha", &ControlStep::alpha)
      .def_readonly("residual", &ControlStep::residual)
      .def_readonly("design_due", &ControlStep::design_due)
      .def_readonly("A", &ControlStep::A)
      .def_readonly("B", &ControlStep::B)
      .def_readonly("P_W", &ControlStep::P_W)
      .def_readonly("disturbance_ratio", &ControlStep::disturbance_ratio)
      .def_readonly("identified", &ControlStep::identified)
      .def_readonly("w_measured", &ControlStep::w_measured)
      .def_readonly("input_nis", &ControlStep::input_nis)
      .def_readonly("u_feedforward", &ControlStep::u_feedforward)
      .def_readonly("mpc", &StepCopy::mpc_result)
      .def_readonly("timings", &ControlStep::timings);

  py::class_<Controller>(s, "Controller",
                         "TBMPC / TBMPC-FFA: setup(reference, designs) once, then step(k, x_k) per period")
      .def(py::init([](std::shared_ptr<math::LinearizedModel> model, const mpc::Settings& mpc_settings,
                       const ControllerSettings& settings) {
             return std::make_unique<Controller>(std::move(model), mpc_settings, settings);
           }),
           py::arg("model"), py::arg("mpc_settings"), py::arg("settings"), py::keep_alive<1, 2>())
      .def("setup", &Controller::setup, py::arg("reference"), py::arg("designs"))
      .def("reset", &Controller::reset)
      .def("step", &step_copy<Controller>, py::arg("k"), py::arg("x"),
           "One control step; returns a ControlStep copy")
      .def("adopt", &Controller::adopt, py::arg("subsystem"), py::arg("design"), py::arg("k_started"))
      .def("set_estimation_error", &Controller::set_estimation_error, py::arg("P_est"),
           "Output feedback: the estimation-error set (12 x 12) the state constraints are also tightened by")
      .def(
          "identify", [](Controller& self, int k, const Eigen::VectorXd& x) { return self.identify(k, x); },
          py::arg("k"), py::arg("x"),
          "Folds in the input of the period ending at step k (after the last step)")
      .def("inherit_identification", &Controller::inherit_identification, py::arg("other"),
           "Takes over another controller's identified disturbance (both identifiers)")
      .def("excursion", &Controller::excursion, py::arg("x"),
           "Squared gauge (p, r) of a state at k + 1 in the tube of the last step k (> 1: outside)")
      .def_property_readonly("last_measured_input", &Controller::last_measured_input)
      .def("identifier", &Controller::identifier, py::arg("subsystem"),
           py::return_value_policy::reference_internal)
      .def("policy", &Controller::policy, py::arg("subsystem"), py::return_value_policy::reference_internal)
      .def_property_readonly("mpc", &Controller::mpc, py::return_value_policy::reference_internal)
      .def_property_readonly("settings", &Controller::settings);

  bind_named_enum<AbortMode>(s, "AbortMode", "Where the abort supervision stands (control/abort.hpp)");
  bind_named_enum<AbortCause>(s, "AbortCause", "What entered the abort, in the order of precedence");
  py::class_<AbortTriggers>(s, "AbortTriggers", "A step's detections, handed to SafeAbort.monitor")
      .def(py::init([](bool command, bool navigation_fault, bool tube_uncertified, bool allocation_infeasible,
                       std::array<double, 2> excursion, std::array<double, 2> disturbance_ratio,
                       std::array<double, 2> input_nis) {
             return AbortTriggers{command,   navigation_fault,  tube_uncertified, allocation_infeasible,
                                  excursion, disturbance_ratio, input_nis};
           }),
           py::arg("command") = false, py::arg("navigation_fault") = false,
           py::arg("tube_uncertified") = false, py::arg("allocation_infeasible") = false,
           py::arg("excursion") = std::array<double, 2>{},
           py::arg("disturbance_ratio") = std::array<double, 2>{},
           py::arg("input_nis") = std::array<double, 2>{})
      .def_readwrite("command", &AbortTriggers::command)
      .def_readwrite("navigation_fault", &AbortTriggers::navigation_fault)
      .def_readwrite("tube_uncertified", &AbortTriggers::tube_uncertified)
      .def_readwrite("allocation_infeasible", &AbortTriggers::allocation_infeasible)
      .def_readwrite("excursion", &AbortTriggers::excursion)
      .def_readwrite("disturbance_ratio", &AbortTriggers::disturbance_ratio)
      .def_readwrite("input_nis", &AbortTriggers::input_nis);
  py::class_<AbortSettings> abort_settings(s, "AbortSettings", "The abort supervision's settings");
  abort_settings.def(py::init<>());
  bind_fields(abort_settings);
  abort_settings.def("validate", &AbortSettings::validate);
  py::class_<AbortDecision>(s, "AbortDecision", "The supervision's latched decision")
      .def_readonly("mode", &AbortDecision::mode)
      .def_readonly("cause", &AbortDecision::cause)
      .def_readonly("entered_at", &AbortDecision::entered_at, "the step the abort was entered at (-1: not)")
      .def_readonly("refused_cause", &AbortDecision::refused_cause)
      .def_readonly("refused_at", &AbortDecision::refused_at,
                    "the step of the first refused trigger (-1: none)");
  py::class_<SafeAbort>(
      s, "SafeAbort",
      "The certified safe abort: setup(hover, designs), then monitor(k, triggers) every step "
      "and step(k, x_k) while aborting")
      .def(py::init([](std::shared_ptr<math::LinearizedModel> model, const mpc::Settings& mpc_settings,
                       const ControllerSettings& controller_settings, const AbortSettings& settings) {
             return std::make_unique<SafeAbort>(std::move(model), mpc_settings, controller_settings,
                                                settings);
           }),
           py::arg("model"), py::arg("mpc_settings"), py::arg("controller_settings"), py::arg("settings"),
           py::keep_alive<1, 2>())
      .def("setup", &SafeAbort::setup, py::arg("hover"), py::arg("designs"))
      .def("reset", &SafeAbort::reset)
      .def("monitor", &SafeAbort::monitor, py::arg("k"), py::arg("triggers"), py::arg("descent") = nullptr,
           py::return_value_policy::copy,
           "The decision for step k (latched); entering takes over the descent controller's identification")
      .def("step", &step_copy<SafeAbort>, py::arg("k"), py::arg("x"),
           "One step of the abort controller; returns a ControlStep copy")
      .def("set_estimation_error", &SafeAbort::set_estimation_error, py::arg("P_est"))
      .def_property_readonly("aborting", &SafeAbort::aborting)
      .def_property_readonly("decision", &SafeAbort::decision, py::return_value_policy::copy)
      .def_property_readonly("input_nis_mean", &SafeAbort::input_nis_mean)
      .def_property_readonly("controller", &SafeAbort::controller,
                             py::return_value_policy::reference_internal)
      .def_property_readonly("settings", &SafeAbort::settings);
}

}  // namespace tubempc::python
