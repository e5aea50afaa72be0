// Declarations of the per-area binding functions that make up tubempc._core.
#pragma once

#include <pybind11/pybind11.h>

namespace tubempc::python {

void bind_core(pybind11::module_& m);
void bind_so3(pybind11::module_& m);
void bind_gravity(pybind11::module_& m);
void bind_dynamics(pybind11::module_& m);
void bind_mpc(pybind11::module_& m);
void bind_control(pybind11::module_& m);
void bind_io(pybind11::module_& m);
void bind_nav(pybind11::module_& m);
void bind_actuators(pybind11::module_& m);

}  // namespace tubempc::python
