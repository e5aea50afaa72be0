#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <tuple>

#include "bindings.hpp"
#include "tubempc/dynamics/linearized_proximity.hpp"
#include "tubempc/mpc/lti_model.hpp"
#include "tubempc/mpc/tube_mpc.hpp"

namespace py = pybind11;

namespace tubempc::python {

namespace {

using math::LinearizedModel;

// Python subclasses implement nx(), nu(), n_constraints(), discretize(t, dt, x_lin, u_lin) -> (A, B, c)
// and constraints(t, x_lin) -> (G, h); the C++ virtuals call them with the GIL held.
class PyLinearizedModel : public LinearizedModel, public py::trampoline_self_life_support {
 public:
  int nx() const override { PYBIND11_OVERRIDE_PURE(int, LinearizedModel, nx, ); }
  int nu() const override { PYBIND11_OVERRIDE_PURE(int, LinearizedModel, nu, ); }
  int n_constraints() const override { PYBIND11_OVERRIDE_PURE(int, LinearizedModel, n_constraints, ); }

  void discretize(double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x_lin,
                  const Eigen::Ref<const Eigen::VectorXd>& u_lin, Eigen::Ref<Eigen::MatrixXd> A,
                  Eigen::Ref<Eigen::MatrixXd> B, Eigen::Ref<Eigen::VectorXd> c) const override {
    py::gil_scoped_acquire gil;
    py::function f = py::get_override(static_cast<const LinearizedModel*>(this), "discretize");
    if (!f)
      throw std::runtime_error("LinearizedModel subclass must implement discretize(t, dt, x_lin, u_lin)");
    auto out = f(t, dt, Eigen::VectorXd(x_lin), Eigen::VectorXd(u_lin))
                   .cast<std::tuple<Eigen::MatrixXd, Eigen::MatrixXd, Eigen::VectorXd>>();
    copy_checked(std::get<0>(out), A, "discretize: A");
    copy_checked(std::get<1>(out), B, "discretize: B");
    copy_checked(std::get<2>(out), c, "discretize: c");
  }

  void constraints(double t, const Eigen::Ref<const Eigen::VectorXd>& x_lin, Eigen::Ref<Eigen::MatrixXd> G,
                   Eigen::Ref<Eigen::VectorXd> h) const override {
    py::gil_scoped_acquire gil;
    py::function f = py::get_override(static_cast<const LinearizedModel*>(this), "constraints");
    if (!f) throw std::runtime_error("LinearizedModel subclass must implement constraints(t, x_lin)");
    auto out = f(t, Eigen::VectorXd(x_lin)).cast<std::tuple<Eigen::MatrixXd, Eigen::VectorXd>>();
    copy_checked(std::get<0>(out), G, "constraints: G");
    copy_checked(std::get<1>(out), h, "constraints: h");
  }

 private:
  template <typename Src, typename Dst>
  static void copy_checked(const Src& src, Dst& dst, const char* what) {
    if (src.rows() != dst.rows() || src.cols() != dst.cols())
      throw std::invalid_argument(std::string(what) + " has shape (" + std::to_string(src.rows()) + ", " +
                                  std::to_string(src.cols()) + "), expected (" + std::to_string(dst.rows()) +
                                  ", " + std::to_string(dst.cols()) + ")");
    dst = src;
  }
};

py::tuple discretize_tuple(const LinearizedModel& m, double t, double dt, const Eigen::VectorXd& x,
                           const Eigen::VectorXd& u) {
  Eigen::MatrixXd A(m.nx(), m.nx()), B(m.nx(), m.nu());
  Eigen::VectorXd c(m.nx());
  m.discretize(t, dt, x, u, A, B, c);
  return py::make_tuple(A, B, c);
}

py::tuple constraints_tuple(const LinearizedModel& m, double t, const Eigen::VectorXd& x) {
  Eigen::MatrixXd G(m.n_constraints(), m.nx());
  Eigen::VectorXd h(m.n_constraints());
  m.constraints(t, x, G, h);
  return py::make_tuple(G, h);
}

}  // namespace

void bind_mpc(py::module_& m) {
  auto s = m.def_submodule("mpc", "Tube MPC nominal problem (docs/model.md 'Tube MPC'); SI units");

  bind_named_enum<mpc::Status>(s, "Status", "Outcome of a step and cause of a fallback");
  s.def(
      "is_fallback", [](mpc::Status st) { return mpc::is_fallback(st); }, py::arg("status"),
      "Whether a status is a fallback (FallbackShiftedPlan or FallbackSafeInput)");
  bind_option_enum<mpc::InitialCondition>(s, "InitialCondition");
  bind_option_enum<mpc::InputCost>(s, "InputCost");
  bind_option_enum<mpc::QpSolver>(s, "QpSolver");
  bind_option_enum<mpc::Linearization>(s, "Linearization");
  bind_option_enum<mpc::ScpMode>(s, "ScpMode");
  bind_option_enum<mpc::KktSolver>(s, "KktSolver");

  py::class_<mpc::Settings> settings(s, "Settings",
                                     "Tube MPC settings (see tube_mpc.hpp); validate() names the bad field");
  settings.def(py::init<>());
  bind_fields(settings);
  settings.def("validate", &mpc::Settings::validate, py::arg("nx"), py::arg("nu"));

  py::class_<mpc::Reference>(s, "Reference", "Mission reference: z (n_x x (T+1)), u (n_u x T), t0 (s)")
      .def(py::init([](Eigen::MatrixXd z, Eigen::MatrixXd u, double t0) {
             return mpc::Reference{z, u, t0};
           }),
           py::arg("z"), py::arg("u"), py::arg("t0") = 0.0)
      .def_readwrite("z", &mpc::Reference::z)
      .def_readwrite("u", &mpc::Reference::u)
      .def_readwrite("t0", &mpc::Reference::t0);

  py::class_<mpc::Tube>(s, "Tube", "Tube: ancillary gain K (n_u x n_x) and shape Pe (n_x x n_x)")
      .def(py::init([](Eigen::MatrixXd K, Eigen::MatrixXd Pe) {
             return mpc::Tube{K, Pe};
           }),
           py::arg("K"), py::arg("Pe"))
      .def_readwrite("K", &mpc::Tube::K)
      .def_readwrite("Pe", &mpc::Tube::Pe)
      .def_readwrite("P_est", &mpc::Tube::P_est);

  py::class_<mpc::Timings>(s, "Timings", "Wall-clock split of a step (s)")
      .def_readonly("linearize", &mpc::Timings::linearize)
      .def_readonly("build", &mpc::Timings::build)
      .def_readonly("solve", &mpc::Timings::solve)
      .def_readonly("total", &mpc::Timings::total);

  py::class_<mpc::StepResult>(s, "StepResult", "Result of one step (a copy)")
      .def_readonly("u", &mpc::StepResult::u)
      .def_readonly("z", &mpc::StepResult::z)
      .def_readonly("v", &mpc::StepResult::v)
      .def_readonly("status", &mpc::StepResult::status)
      .def_readonly("failure", &mpc::StepResult::failure)
      .def_readonly("horizon", &mpc::StepResult::horizon)
      .def_readonly("scp_iterations", &mpc::StepResult::scp_iterations)
      .def_readonly("qp_iterations", &mpc::StepResult::qp_iterations)
      .def_readonly("active_set_solves", &mpc::StepResult::active_set_solves)
      .def_readonly("active_set_iterations", &mpc::StepResult::active_set_iterations)
      .def_readonly("active_set_failures", &mpc::StepResult::active_set_failures)
      .def_readonly("active_set_refinements", &mpc::StepResult::active_set_refinements)
      .def_readonly("model_evaluations", &mpc::StepResult::model_evaluations)
      .def_readonly("scp_residual", &mpc::StepResult::scp_residual)
      .def_readonly("objective", &mpc::StepResult::objective)
      .def_readonly("timings", &mpc::StepResult::timings);

  py::class_<mpc::QpData>(s, "QpData",
                          "min 1/2 w'Pw + q'w s.t. A w = b, h_l <= G w <= h_u, x_l <= w <= x_u "
                          "(P full symmetric, scipy.sparse CSC); cost = QP objective + constant")
      .def_readonly("P", &mpc::QpData::P)
      .def_readonly("q", &mpc::QpData::q)
      .def_readonly("A", &mpc::QpData::A)
      .def_readonly("b", &mpc::QpData::b)
      .def_readonly("G", &mpc::QpData::G)
      .def_readonly("h_l", &mpc::QpData::h_l)
      .def_readonly("h_u", &mpc::QpData::h_u)
      .def_readonly("x_l", &mpc::QpData::x_l)
      .def_readonly("x_u", &mpc::QpData::x_u)
      .def_readonly("constant", &mpc::QpData::constant);

  py::class_<mpc::QpSolution>(
      s, "QpSolution",
      "The primal-dual solution (PIQP's sign convention): P w + q + A'y + G'(z_u - z_l) + z_bu - z_bl = 0")
      .def_readonly("w", &mpc::QpSolution::w)
      .def_readonly("y", &mpc::QpSolution::y)
      .def_readonly("z_l", &mpc::QpSolution::z_l)
      .def_readonly("z_u", &mpc::QpSolution::z_u)
      .def_readonly("z_bl", &mpc::QpSolution::z_bl)
      .def_readonly("z_bu", &mpc::QpSolution::z_bu);

  py::class_<LinearizedModel, PyLinearizedModel, py::smart_holder>(
      s, "LinearizedModel",
      "Plant interface. Python subclasses implement nx(), nu(), n_constraints(), "
      "discretize(t, dt, x_lin, u_lin) -> (A, B, c) and constraints(t, x_lin) -> (G, h) (slow; for tests)")
      .def(py::init<>())
      .def("nx", &LinearizedModel::nx)
      .def("nu", &LinearizedModel::nu)
      .def("n_constraints", &LinearizedModel::n_constraints)
      .def("discretize", &discretize_tuple, py::arg("t"), py::arg("dt"), py::arg("x_lin"), py::arg("u_lin"),
           "(A, B, c) of x+ = A x + B u + c over [t, t + dt] (s)")
      .def("constraints", &constraints_tuple, py::arg("t"), py::arg("x_lin"), "(G, h) of G x <= h at t (s)");

  py::class_<mpc::LtiModel, LinearizedModel, py::smart_holder>(
      s, "LtiModel", "Linear time-invariant plant (ZOH over dt) with constant constraints G x <= h (C++)")
      .def(py::init<const Eigen::MatrixXd&, const Eigen::MatrixXd&, const Eigen::VectorXd&, double,
                    const Eigen::MatrixXd&, const Eigen::VectorXd&>(),
           py::arg("A_c"), py::arg("B_c"), py::arg("c_c"), py::arg("dt"), py::arg("G"), py::arg("h"));

  py::class_<dynamics::LinearizedProximityModel, LinearizedModel, py::smart_holder>(
      s, "LinearizedProximityModel",
      "The 6-DOF proximity model as the MPC's plant (C++): exact ZOH discretisation and the linearised "
      "[glide slope; line of sight] constraints")
      .def(py::init([](std::shared_ptr<dynamics::ProximityModel> model, double position_tolerance) {
             return std::make_shared<dynamics::LinearizedProximityModel>(std::move(model),
                                                                         position_tolerance);
           }),
           py::arg("model"), py::arg("position_tolerance") = dynamics::kDefaultPositionTolerance)
      .def_property_readonly(
          "position_tolerance", &dynamics::LinearizedProximityModel::position_tolerance,
          "Largest change of r_L (m) for which a later SCP iteration keeps the translational "
          "blocks (gravity) and re-discretises the attitude only");

  s.def("solve_dare", &mpc::solve_dare, py::arg("A"), py::arg("B"), py::arg("Q"), py::arg("R"),
        py::arg("tol") = 1e-10, py::arg("max_iterations") = 100,
        "Stabilising DARE solution by structured doubling; RuntimeError if it does not converge");

  py::class_<mpc::TubeMPC>(s, "TubeMPC", "Tube MPC: setup(reference) once, then step(k, x, tube) per period")
      .def(py::init([](std::shared_ptr<LinearizedModel> model, const mpc::Settings& settings) {
             return std::make_unique<mpc::TubeMPC>(std::move(model), settings);
           }),
           py::arg("model"), py::arg("settings"), py::keep_alive<1, 2>())
      .def("setup", py::overload_cast<const mpc::Reference&>(&mpc::TubeMPC::setup), py::arg("reference"))
      .def("setup",
           py::overload_cast<const mpc::Reference&, const Eigen::MatrixXd&, const Eigen::MatrixXd&>(
               &mpc::TubeMPC::setup),
           py::arg("reference"), py::arg("A_terminal"), py::arg("B_terminal"))
      .def(
          "step",
          [](mpc::TubeMPC& self, int k, const Eigen::VectorXd& x, const mpc::Tube& tube) {
            // The GIL is released for the whole step; a Python model's methods take it back.
            py::gil_scoped_release release;
            return mpc::StepResult(self.step(k, x, tube));
          },
          py::arg("k"), py::arg("x"), py::arg("tube"), "One control step; returns a StepResult copy")
      .def("reset", &mpc::TubeMPC::reset)
      .def("qp_data", &mpc::TubeMPC::qp_data, "The last QP built")
      .def("qp_solution", &mpc::TubeMPC::qp_solution,
           "The last QP's primal-dual solution (from the active set or PIQP, whichever solved it)")
      .def_property_readonly("settings", &mpc::TubeMPC::settings)
      .def_property_readonly("terminal_weight", &mpc::TubeMPC::terminal_weight)
      .def_property_readonly("mission_steps", &mpc::TubeMPC::mission_steps)
      .def_property_readonly("qp_dimensions", &mpc::TubeMPC::qp_dimensions);
}

}  // namespace tubempc::python
