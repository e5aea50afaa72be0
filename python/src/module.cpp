#include "bindings.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "tubempc C++ core: gravity, dynamics, tube MPC, scenario files, navigation (SI units throughout)";
  m.attr("__version__") = TUBEMPC_PYTHON_MODULE_VERSION;
  tubempc::python::bind_core(m);
  tubempc::python::bind_so3(m);
  tubempc::python::bind_gravity(m);
  tubempc::python::bind_dynamics(m);  // after bind_gravity (it uses GravityModel)
  tubempc::python::bind_mpc(m);       // after bind_dynamics (it accepts its models)
  tubempc::python::bind_control(m);   // after bind_mpc (it holds its types)
  tubempc::python::bind_nav(m);       // after bind_gravity and bind_dynamics (it takes Shape, ProximityModel)
  tubempc::python::bind_actuators(m);
  tubempc::python::bind_io(
      m);  // after bind_dynamics, bind_mpc, bind_nav and bind_actuators (it holds their types)
}
