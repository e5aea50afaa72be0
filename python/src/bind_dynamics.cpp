// Bindings of the 6-DOF proximity dynamics (tubempc::dynamics) as tubempc._core.dynamics. Gravity
// fields (GravityModel and its implementations) are bound by bind_gravity, which must run first.
#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>

#include "bindings.hpp"
#include "tubempc/dynamics/constraints.hpp"
#include "tubempc/dynamics/linearized_proximity.hpp"
#include "tubempc/dynamics/physical_environment.hpp"
#include "tubempc/dynamics/propagator.hpp"
#include "tubempc/dynamics/proximity_model.hpp"
#include "tubempc/gravity/gravity_model.hpp"

namespace py = pybind11;

namespace tubempc::python {
namespace {

using dynamics::InputMatrix;
using dynamics::InputVector;
using dynamics::kNu;
using dynamics::kNx;
using dynamics::ProximityModel;
using dynamics::StateMatrix;
using dynamics::StateVector;
using dynamics::TruthState;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

template <int N>
Eigen::Matrix<double, N, 1> vec(const Eigen::Ref<const Eigen::VectorXd>& v, const char* name) {
  if (v.size() != N) {
    throw std::invalid_argument(std::string(name) + " must have " + std::to_string(N) + " elements, got " +
                                std::to_string(v.size()));
  }
  return v;
}

py::tuple discretize_horizon(const std::shared_ptr<ProximityModel>& self, double t0, double dt,
                             const Eigen::Ref<const RowMatrix>& x_ref,
                             const Eigen::Ref<const RowMatrix>& u_ref) {
  if (x_ref.cols() != kNx || u_ref.cols() != kNu || x_ref.rows() != u_ref.rows() || x_ref.rows() < 1) {
    throw std::invalid_argument("discretize: x_ref must be (N, 12) and u_ref (N, 6) with N >= 1, got (" +
                                std::to_string(x_ref.rows()) + ", " + std::to_string(x_ref.cols()) +
                                ") and (" + std::to_string(u_ref.rows()) + ", " +
                                std::to_string(u_ref.cols()) + ")");
  }
  const int N = static_cast<int>(x_ref.rows());
  const Eigen::Matrix<double, kNx, Eigen::Dynamic> X = x_ref.transpose();
  const Eigen::Matrix<double, kNu, Eigen::Dynamic> U = u_ref.transpose();
  dynamics::DiscreteHorizon h(N);
  const dynamics::LinearizedProximityModel lin(self);
  dynamics::DiscretizationStatus st;
  {
    py::gil_scoped_release release;
    st = lin.discretize_horizon(t0, dt, X, U, h);
  }
  if (st != dynamics::DiscretizationStatus::Ok) {
    throw std::invalid_argument(std::string("discretize: ") + dynamics::to_string(st) + " at node " +
                                std::to_string(h.first_failed_node));
  }
  py::array_t<double> A({N, kNx, kNx});
  py::array_t<double> B({N, kNx, kNu});
  py::array_t<double> c({N, kNx});
  auto a = A.mutable_unchecked<3>();
  auto b = B.mutable_unchecked<3>();
  auto cc = c.mutable_unchecked<2>();
  for (int k = 0; k < N; ++k) {
    const auto ks = static_cast<std::size_t>(k);
    for (int i = 0; i < kNx; ++i) {
      for (int j = 0; j < kNx; ++j) a(k, i, j) = h.A[ks](i, j);
      for (int j = 0; j < kNu; ++j) b(k, i, j) = h.B[ks](i, j);
      cc(k, i) = h.c[ks](i);
    }
  }
  return py::make_tuple(A, B, c);
}

// Seconds per call of fn, the minimum over `batches` batches of `repeats` calls (one thread).
template <typename F>
double time_per_call(const F& fn, int repeats, int batches) {
  double best = 1e300;
  for (int b = 0; b < batches; ++b) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < repeats; ++i) fn(i);
    const std::chrono::duration<double> el = std::chrono::steady_clock::now() - t0;
    best = std::min(best, el.count() / repeats);
  }
  return best;
}

// Timing of the C++ kernels without Python overhead, for `tubempc bench dynamics`.
py::dict time_kernels(const std::shared_ptr<ProximityModel>& self, double t0, double dt,
                      const Eigen::Ref<const RowMatrix>& x_ref, const Eigen::Ref<const RowMatrix>& u_ref,
                      int repeats, int batches) {
  if (x_ref.cols() != kNx || u_ref.cols() != kNu || x_ref.rows() != u_ref.rows() || x_ref.rows() < 1 ||
      repeats < 1 || batches < 1) {
    throw std::invalid_argument("time_kernels: x_ref (N, 12), u_ref (N, 6), repeats >= 1, batches >= 1");
  }
  const int N = static_cast<int>(x_ref.rows());
  const Eigen::Matrix<double, kNx, Eigen::Dynamic> X = x_ref.transpose();
  const Eigen::Matrix<double, kNu, Eigen::Dynamic> U = u_ref.transpose();
  dynamics::DiscreteHorizon h(N);
  const dynamics::LinearizedProximityModel lin(self);
  const ProximityModel& m = *self;
  double sink = 0.0;
  double t_grav = 0.0, t_f = 0.0, t_lin = 0.0, t_disc = 0.0, t_hor = 0.0;
  {
    py::gil_scoped_release release;
    t_grav = time_per_call(
        [&](int i) {
          Eigen::Vector3d a;
          Eigen::Matrix3d G;
          m.gravity_L(t0, X.col(i % N).head<3>(), a, G);
          sink += a(0);
        },
        repeats, batches);
    t_f = time_per_call([&](int i) { sink += m.f(t0, X.col(i % N), U.col(i % N))(3); }, repeats, batches);
    t_lin = time_per_call(
        [&](int i) {
          StateVector fx;
          StateMatrix A;
          InputMatrix B;
          m.linearize(t0, X.col(i % N), U.col(i % N), fx, A, B);
          sink += A(3, 0);
        },
        repeats, batches);
    t_disc = time_per_call(
        [&](int i) {
          StateMatrix Ad;
          InputMatrix Bd;
          StateVector cd;
          m.discretize(t0, dt, X.col(i % N), U.col(i % N), Ad, Bd, cd);
          sink += Ad(0, 3);
        },
        repeats, batches);
    const int hr = std::max(1, repeats / N);
    t_hor = time_per_call(
        [&](int) {
          lin.discretize_horizon(t0, dt, X, U, h);
          sink += h.A[0](0, 0);
        },
        hr, batches);
  }
  py::dict out;
  out["gravity_s"] = t_grav;
  out["f_s"] = t_f;
  out["f_and_jacobians_s"] = t_lin;
  out["discretize_node_s"] = t_disc;
  out["horizon_s"] = t_hor;
  out["nodes"] = N;
  out["checksum"] = sink;
  return out;
}

// The physical environment (dynamics/physical_environment.hpp): its settings, flat plates and the per-run
// environment of the truth.
void bind_physical(py::module_& d) {
  d.attr("ASTRONOMICAL_UNIT") = dynamics::kAstronomicalUnit;
  py::class_<dynamics::FlatPlate> plate(d, "FlatPlate",
                                        "One flat plate of the spacecraft's surface, fixed in B");
  plate.def(py::init<>());
  bind_fields(plate);
  plate.def("validate", &dynamics::FlatPlate::validate, "ValueError naming the first bad field.")
      .def("__repr__", [](const dynamics::FlatPlate& p) {
        return "FlatPlate(area=" + py::repr(py::float_(p.area)).cast<std::string>() + ")";
      });

  py::class_<dynamics::PhysicalSettings> settings(
      d, "PhysicalSettings",
      "The [physical] settings of the truth's environment (SI); plates: the spacecraft's surface");
  settings.def(py::init<>());
  bind_fields(settings);
  settings
      .def_readwrite("plates", &dynamics::PhysicalSettings::plates, "the flat plates (a list of FlatPlate)")
      .def("validate", &dynamics::PhysicalSettings::validate, "ValueError naming the first bad field.")
      .def("true_mass", &dynamics::PhysicalSettings::true_mass, "(1 + mass_error) mass (kg)")
      .def("true_inertia", &dynamics::PhysicalSettings::true_inertia, py::arg("inertia_model_B"),
           "the truth's inertia (kg m^2) from the controller's; ValueError when it is no inertia tensor");

  py::class_<dynamics::PhysicalEnvironment, std::shared_ptr<dynamics::PhysicalEnvironment>>(
      d, "PhysicalEnvironment",
      "The truth's physical environment of one run: flat-plate SRP, gravity-gradient torque, the truth's "
      "mass "
      "and inertia and the actuator errors (docs/model.md \"Physical environment\")")
      .def(py::init<const dynamics::PhysicalSettings&, const Eigen::Matrix3d&, double, double,
                    const Eigen::Matrix3d&, const Eigen::Matrix3d&>(),
           py::arg("settings"), py::arg("inertia_model_B"), py::arg("gm"), py::arg("orbit_radius"),
           py::arg("thrust_error_B") = Eigen::Matrix3d::Identity().eval(),
           py::arg("torque_error_B") = Eigen::Matrix3d::Identity().eval())
      .def_property_readonly("settings", &dynamics::PhysicalEnvironment::settings)
      .def_property_readonly("true_mass", &dynamics::PhysicalEnvironment::true_mass, "m_true (kg)")
      .def_property_readonly("inertia_B", &dynamics::PhysicalEnvironment::inertia_B, "J_true in B (kg m^2)")
      .def_property_readonly("gm", &dynamics::PhysicalEnvironment::gm, "G M of the truth body (m^3/s^2)")
      .def_property_readonly("pressure", &dynamics::PhysicalEnvironment::pressure,
                             "solar radiation pressure at the asteroid (N/m^2)")
      .def_property_readonly("thrust_error_B", &dynamics::PhysicalEnvironment::thrust_error_B, "E_F")
      .def_property_readonly("torque_error_B", &dynamics::PhysicalEnvironment::torque_error_B, "E_T")
      .def("in_shadow", &dynamics::PhysicalEnvironment::in_shadow, py::arg("r_L"),
           "whether r_L (m) lies in the asteroid's cylindrical shadow")
      .def(
          "deliver",
          [](const dynamics::PhysicalEnvironment& e, const Eigen::Ref<const Eigen::VectorXd>& u,
             const Eigen::Ref<const Eigen::VectorXd>& q_BL) {
            return e.deliver(vec<kNu>(u, "u"), vec<4>(q_BL, "q_BL"));
          },
          py::arg("u"), py::arg("q_BL"),
          "the input the truth receives for the command u = [u_p (m/s^2, L); T (N m, B)] at the attitude "
          "q_BL")
      .def(
          "srp_wrench",
          [](const dynamics::PhysicalEnvironment& e, const Eigen::Vector3d& r_L,
             const Eigen::Matrix3d& C_BL) {
            Eigen::Vector3d F, T;
            e.srp_wrench(r_L, C_BL, F, T);
            return py::make_tuple(F, T);
          },
          py::arg("r_L"), py::arg("C_BL"), "(force (N, B), torque (N m, B)) of the flat-plate SRP")
      .def(
          "srp_acceleration_L",
          [](const dynamics::PhysicalEnvironment& e, const Eigen::Ref<const Eigen::VectorXd>& s) {
            return e.srp_acceleration_L(vec<dynamics::kNtruth>(s, "state"));
          },
          py::arg("state"), "the truth's SRP acceleration in L (m/s^2) at a 13-state")
      .def(
          "__call__",
          [](const dynamics::PhysicalEnvironment& e, double t, const Eigen::Ref<const Eigen::VectorXd>& s) {
            return e(t, vec<dynamics::kNtruth>(s, "state"));
          },
          py::arg("t"), py::arg("state"),
          "[acceleration in L (m/s^2); angular acceleration in B (rad/s^2)] the environment adds to the "
          "truth");

  d.def(
      "flat_plate_wrench",
      [](const dynamics::FlatPlate& p, const Eigen::Vector3d& sun_B, double pressure) {
        Eigen::Vector3d F, T;
        dynamics::flat_plate_wrench(p, sun_B, pressure, F, T);
        return py::make_tuple(F, T);
      },
      py::arg("plate"), py::arg("sun_B"), py::arg("pressure"),
      "(force (N, B), torque (N m, B)) of one plate for the unit Sun direction sun_B and the pressure "
      "(N/m^2)");
  d.def("gravity_gradient_torque", &dynamics::gravity_gradient_torque, py::arg("gm"), py::arg("r_B"),
        py::arg("inertia_B"), "3 mu / |r|^5 (r_B x J r_B) (N m, in B)");
}

}  // namespace

void bind_dynamics(py::module_& m) {
  auto d = m.def_submodule("dynamics", "6-DOF proximity dynamics in the orbital frame L (docs/model.md)");

  bind_option_enum<dynamics::Kinematics>(
      d, "Kinematics",
      "Rotation-vector kinematics of the model state: FirstOrder phi' = omega_BL_B, Exact phi' = "
      "Jr(phi)^-1 omega_BL_B");
  bind_option_enum<dynamics::Integrator>(d, "Integrator");
  bind_named_enum<dynamics::PropagationStatus>(d, "PropagationStatus", "Outcome of a propagation");

  py::class_<dynamics::ModelParams> model_params(d, "ModelParams",
                                                 "Model constants (SI); defaults: the paper's scenario");
  model_params.def(py::init<>());
  bind_fields(model_params);
  model_params.def("validate", &dynamics::ModelParams::validate, "ValueError naming the first bad field.")
      .def("mean_motion", &dynamics::ModelParams::mean_motion, "n = sqrt(mu_sun / R^3) (rad/s)");

  py::class_<dynamics::PropagatorSettings> propagator_settings(
      d, "PropagatorSettings", "Truth propagator settings (RK4 substeps or adaptive DOPRI5)");
  propagator_settings.def(py::init<>());
  bind_fields(propagator_settings);
  propagator_settings.def("validate", &dynamics::PropagatorSettings::validate,
                          "ValueError naming the first bad field.");

  py::class_<dynamics::PropagationResult>(d, "PropagationResult")
      .def_property_readonly("status", [](const dynamics::PropagationResult& r) { return r.status; })
      .def_property_readonly(
          "status_name",
          [](const dynamics::PropagationResult& r) { return std::string(to_string(r.status)); })
      .def_property_readonly(
          "state", [](const dynamics::PropagationResult& r) { return r.state; },
          "[r_L, v_L, q_B/L, omega_BL_B] (13) at t")
      .def_readonly("t", &dynamics::PropagationResult::t, "time reached (s)")
      .def_readonly("steps", &dynamics::PropagationResult::steps)
      .def_readonly("rejected_steps", &dynamics::PropagationResult::rejected_steps)
      .def_readonly("evaluations", &dynamics::PropagationResult::evaluations)
      .def("__repr__", [](const dynamics::PropagationResult& r) {
        return "PropagationResult(status=" + std::string(to_string(r.status)) + ", t=" + std::to_string(r.t) +
               ", steps=" + std::to_string(r.steps) + ")";
      });

  bind_physical(d);

  py::class_<ProximityModel, std::shared_ptr<ProximityModel>>(
      d, "ProximityModel", "6-DOF proximity model (C++); see tubempc.ProximityModel")
      .def(py::init([](std::shared_ptr<gravity::GravityModel> g, const dynamics::ModelParams& p) {
             return std::make_shared<ProximityModel>(std::move(g), p);
           }),
           py::arg("gravity"), py::arg("params") = dynamics::ModelParams{})
      .def_property_readonly("params", &ProximityModel::params)
      .def_property_readonly("mean_motion", &ProximityModel::mean_motion, "n (rad/s)")
      .def_property_readonly("rotation_rate_AL", &ProximityModel::rotation_rate_AL,
                             "omega_A - n (rad/s): the body's rotation rate relative to L, about z")
      .def_property_readonly("srp_acceleration_L", &ProximityModel::srp_acceleration_L,
                             "the SRP acceleration in L (m/s^2): beta_SRP / R^2 along +x_L, 0 when off")
      .def("spin_angle", &ProximityModel::spin_angle, py::arg("t"))
      .def(
          "glide_slope_cone_L",
          [](const ProximityModel& m, double t) {
            Eigen::Vector3d apex_L, axis_L;
            m.glide_slope_cone_L(t, apex_L, axis_L);
            return py::make_tuple(apex_L, axis_L);
          },
          py::arg("t"), "(apex_L (m), unit axis_L) of the glide-slope cone at time t (s)")
      .def("C_AL", &ProximityModel::C_AL, py::arg("t"))
      .def("q_AL", &ProximityModel::q_AL, py::arg("t"))
      .def(
          "gravity_L",
          [](const ProximityModel& s, double t, const Eigen::Ref<const Eigen::VectorXd>& r_L) {
            Eigen::Vector3d a;
            Eigen::Matrix3d G;
            s.gravity_L(t, vec<3>(r_L, "r_L"), a, G);
            return py::make_tuple(a, G);
          },
          py::arg("t"), py::arg("r_L"))
      .def(
          "f",
          [](const ProximityModel& s, double t, const Eigen::Ref<const Eigen::VectorXd>& x,
             const Eigen::Ref<const Eigen::VectorXd>& u) {
            return s.f(t, vec<kNx>(x, "x"), vec<kNu>(u, "u"));
          },
          py::arg("t"), py::arg("x"), py::arg("u"))
      .def(
          "linearize",
          [](const ProximityModel& s, double t, const Eigen::Ref<const Eigen::VectorXd>& x,
             const Eigen::Ref<const Eigen::VectorXd>& u) {
            StateVector fx;
            StateMatrix A;
            InputMatrix B;
            s.linearize(t, vec<kNx>(x, "x"), vec<kNu>(u, "u"), fx, A, B);
            return py::make_tuple(fx, A, B);
          },
          py::arg("t"), py::arg("x"), py::arg("u"))
      .def(
          "discretize",
          [](const ProximityModel& s, double t, double dt, const Eigen::Ref<const Eigen::VectorXd>& x,
             const Eigen::Ref<const Eigen::VectorXd>& u) {
            StateMatrix Ad;
            InputMatrix Bd;
            StateVector cd;
            const auto st = s.discretize(t, dt, vec<kNx>(x, "x_ref"), vec<kNu>(u, "u_ref"), Ad, Bd, cd);
            if (st != dynamics::DiscretizationStatus::Ok) {
              throw std::invalid_argument(std::string("discretize: ") + dynamics::to_string(st));
            }
            return py::make_tuple(Ad, Bd, cd);
          },
          py::arg("t"), py::arg("dt"), py::arg("x_ref"), py::arg("u_ref"))
      .def("discretize_horizon", &discretize_horizon, py::arg("t0"), py::arg("dt"), py::arg("x_ref"),
           py::arg("u_ref"),
           "Node k about (x_ref[k], u_ref[k]) at t0 + k dt; returns A (N,12,12), B (N,12,6), c (N,12).")
      .def(
          "constraints",
          [](const std::shared_ptr<ProximityModel>& self, double t,
             const Eigen::Ref<const Eigen::VectorXd>& x) {
            const dynamics::LinearizedProximityModel lin(self);
            Eigen::MatrixXd G(2, kNx);
            Eigen::VectorXd h(2);
            lin.constraints(t, vec<kNx>(x, "x"), G, h);
            return py::make_tuple(G, h);
          },
          py::arg("t"), py::arg("x"), "Linearised [glide slope; line of sight] rows G x <= h at x.")
      .def(
          "truth_derivative",
          [](const ProximityModel& s, double t, const Eigen::Ref<const Eigen::VectorXd>& state,
             const Eigen::Ref<const Eigen::VectorXd>& u, const Eigen::Ref<const Eigen::VectorXd>& w) {
            return s.truth_derivative(t, vec<dynamics::kNtruth>(state, "state"), vec<kNu>(u, "u"),
                                      vec<6>(w, "disturbance"));
          },
          py::arg("t"), py::arg("state"), py::arg("u"), py::arg("disturbance"))
      .def(
          "propagate",
          [](const ProximityModel& s, double t0, const Eigen::Ref<const Eigen::VectorXd>& state,
             const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
             const dynamics::PropagatorSettings& settings,
             const Eigen::Ref<const Eigen::VectorXd>& disturbance, const py::object& callback,
             gravity::ExpansionHold* gravity_hold) {
            dynamics::Disturbance dist;
            dist.constant = vec<6>(disturbance, "disturbance");
            if (!callback.is_none()) {
              dist.function = [callback](double t, const TruthState& y) {
                py::gil_scoped_acquire gil;
                const Eigen::VectorXd w = callback(t, y).cast<Eigen::VectorXd>();
                return vec<6>(w, "disturbance callback result");
              };
            }
            const TruthState y0 = vec<dynamics::kNtruth>(state, "state");
            const InputVector uu = vec<kNu>(u, "u");
            py::gil_scoped_release release;
            return dynamics::propagate(s, t0, y0, uu, dt, dist, settings, gravity_hold);
          },
          py::arg("t0"), py::arg("state"), py::arg("u"), py::arg("dt"), py::arg("settings"),
          py::arg("disturbance"), py::arg("callback"), py::arg("gravity_hold").none(true))
      .def(
          "propagate_physical",
          [](const ProximityModel& s, const std::shared_ptr<const dynamics::PhysicalEnvironment>& env,
             double t0, const Eigen::Ref<const Eigen::VectorXd>& state,
             const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
             const dynamics::PropagatorSettings& settings, gravity::ExpansionHold* gravity_hold) {
            if (!env) throw std::invalid_argument("propagate_physical: environment must not be None");
            const TruthState y0 = vec<dynamics::kNtruth>(state, "state");
            const InputVector uu = vec<kNu>(u, "u");
            py::gil_scoped_release release;
            return dynamics::propagate(s, *env, t0, y0, uu, dt, settings, gravity_hold);
          },
          py::arg("environment"), py::arg("t0"), py::arg("state"), py::arg("u"), py::arg("dt"),
          py::arg("settings"), py::arg("gravity_hold").none(true) = py::none(),
          "Propagates this truth model in a PhysicalEnvironment (its inertia must be the environment's, its "
          "SRP "
          "off) with the delivered input u (environment.deliver) held over dt (s); the GIL is released.");

  d.def("time_kernels", &time_kernels, py::arg("model"), py::arg("t0"), py::arg("dt"), py::arg("x_ref"),
        py::arg("u_ref"), py::arg("repeats"), py::arg("batches"),
        "Seconds per call (min over batches) of gravity_L, f, f + Jacobians, one-node discretisation and the "
        "horizon discretisation over x_ref (N, 12), u_ref (N, 6); C++ loops, one thread, GIL released.");
  d.def(
      "truth_to_state",
      [](const Eigen::Ref<const Eigen::VectorXd>& s, const Eigen::Ref<const Eigen::VectorXd>& phi_ref) {
        return dynamics::truth_to_state(vec<dynamics::kNtruth>(s, "state"), vec<3>(phi_ref, "phi_ref"));
      },
      py::arg("state"), py::arg("phi_ref"));
  d.def(
      "state_to_truth",
      [](const Eigen::Ref<const Eigen::VectorXd>& x) { return dynamics::state_to_truth(vec<kNx>(x, "x")); },
      py::arg("x"));
  d.def(
      "glide_slope_constraint",
      [](const Eigen::Ref<const Eigen::VectorXd>& x, double angle, const Eigen::Vector3d& apex_L,
         const Eigen::Vector3d& axis_L) {
        StateVector grad;
        const double g = dynamics::glide_slope_constraint(vec<kNx>(x, "x"), angle, apex_L, axis_L, &grad);
        return py::make_tuple(g, grad);
      },
      py::arg("x"), py::arg("glide_slope_angle"), py::arg("apex_L") = Eigen::Vector3d::Zero().eval(),
      py::arg("axis_L") = Eigen::Vector3d::UnitZ().eval(),
      "(g = |r - p| cos(phi_gs) - (r - p).a, dg/dx) for the cone with apex p (m) and unit axis a in L");
  d.def(
      "line_of_sight_constraint",
      [](const Eigen::Ref<const Eigen::VectorXd>& x, double angle, const Eigen::Vector3d& b) {
        StateVector grad;
        const double g = dynamics::line_of_sight_constraint(vec<kNx>(x, "x"), angle, b, &grad);
        return py::make_tuple(g, grad);
      },
      py::arg("x"), py::arg("los_angle"), py::arg("boresight_B"), "(g = |r| cos(theta) - r_B.b_B, dg/dx)");
}

}  // namespace tubempc::python
