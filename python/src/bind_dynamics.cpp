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
             const Eigen::Ref<const Eigen::VectorXd>& u, double dt, dynamics::Integrator method, int substeps,
             double rtol, double atol, int max_steps, double initial_step,
             const Eigen::Ref<const Eigen::VectorXd>& disturbance, const py::object& callback) {
            dynamics::PropagatorSettings set;
            set.method = method;
            set.substeps = substeps;
            set.rtol = rtol;
            set.atol = atol;
            set.max_steps = max_steps;
            set.initial_step = initial_step;
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
            return dynamics::propagate(s, t0, y0, uu, dt, dist, set);
          },
          py::arg("t0"), py::arg("state"), py::arg("u"), py::arg("dt"), py::arg("method"),
          py::arg("substeps"), py::arg("rtol"), py::arg("atol"), py::arg("max_steps"),
          py::arg("initial_step"), py::arg("disturbance"), py::arg("callback"));

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
