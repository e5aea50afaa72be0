#include <pybind11/eigen.h>

#include "bindings.hpp"
#include "tubempc/math/so3.hpp"

namespace py = pybind11;

namespace tubempc::python {

void bind_so3(py::module_& m) {
  auto s = m.def_submodule("so3", "Quaternions [x, y, z, w] and SO(3) maps (paper conventions, Eq. 8)");
  using math::Quaternion;
  s.def("skew", &math::skew, py::arg("a"), "Cross-product matrix: skew(a) @ b = a x b.");
  s.def("quat_mul", &math::quat_mul, py::arg("q"), py::arg("p"), "The paper's q (x) p (Hamilton product).");
  s.def("quat_mul_odot", &math::quat_mul_odot, py::arg("q"), py::arg("p"), "The paper's q (.) p = p (x) q.");
  s.def("quat_conj", &math::quat_conj, py::arg("q"), "Conjugate [-v, w].");
  s.def("quat_normalize", &math::quat_normalize, py::arg("q"),
        "q / |q|; ValueError for a non-finite or zero quaternion.");
  s.def("quat_identity", &math::quat_identity, "Identity quaternion [0, 0, 0, 1].");
  s.def("rotation_matrix", &math::rotation_matrix, py::arg("q"),
        "R(q) with R v = vec(q (x) [v, 0] (x) q*); for q_B/L this is C_LB.");
  s.def("quat_from_rotation_matrix", &math::quat_from_rotation_matrix, py::arg("R"),
        "Unit quaternion (scalar part >= 0) of a rotation matrix.");
  s.def("exp_map", &math::exp_map, py::arg("phi"), "Rotation vector (rad) -> unit quaternion.");
  s.def("log_map", &math::log_map, py::arg("q"), "Unit quaternion -> rotation vector (rad), |phi| <= pi.");
  s.def("right_jacobian", &math::right_jacobian, py::arg("phi"), "Right Jacobian Jr(phi) of SO(3).");
  s.def("right_jacobian_inverse", &math::right_jacobian_inverse, py::arg("phi"),
        "Jr(phi)^-1; ValueError for |phi| >= 2 pi.");
}

}  // namespace tubempc::python
