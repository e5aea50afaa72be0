// Declarations of the per-area binding functions that make up tubempc._core.
#pragma once

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "tubempc/core/fields.hpp"

namespace tubempc::python {

// Whether an enum has a name table (core::EnumNames<E> is specialised).
template <typename E, typename = void>
struct has_enum_names : std::false_type {};
template <typename E>
struct has_enum_names<E, std::void_t<decltype(core::EnumNames<E>::values)>> : std::true_type {};

// Binds an option enum from its name table (core::EnumNames): its values (an identifier that is a
// Python keyword gets a trailing underscore: `None_`), `to_string()` (the name in configuration and
// scenario files), `from_string(name)` (ValueError naming the known names) and `names()` (the file
// names, in declaration order).
template <typename E>
pybind11::enum_<E> bind_option_enum(pybind11::module_& m, const char* name, const char* doc = "") {
  pybind11::enum_<E> e(m, name, doc);
  const pybind11::object is_keyword = pybind11::module_::import("keyword").attr("iskeyword");
  for (const auto& entry : core::EnumNames<E>::values) {
    std::string identifier = entry.identifier;
    if (is_keyword(identifier).template cast<bool>()) identifier += "_";
    e.value(identifier.c_str(), entry.value);
  }
  e.def("to_string", [](E v) { return std::string(core::enum_name(v)); });
  e.def_static("from_string", [](const std::string& text) {
    E v{};
    if (!core::enum_from_name(text, v))
      throw std::invalid_argument("unknown value '" + text + "' (known: " + core::enum_names_list<E>() + ")");
    return v;
  });
  e.def_static("names", [] {
    std::vector<std::string> out;
    for (const auto& entry : core::EnumNames<E>::values) out.emplace_back(entry.name);
    return out;
  });
  return e;
}

// Binds a status enum (or any enum whose name is its `str()`): with a name table (core::EnumNames), as
// bind_option_enum, and `__str__` is the name; an enum without one gets `__str__` from its `to_string`
// and the caller adds its values.
template <typename E>
pybind11::enum_<E> bind_named_enum(pybind11::module_& m, const char* name, const char* doc) {
  if constexpr (has_enum_names<E>::value) {
    pybind11::enum_<E> e = bind_option_enum<E>(m, name, doc);
    e.def("__str__", [](E v) { return std::string(core::enum_name(v)); });
    return e;
  } else {
    pybind11::enum_<E> e(m, name, doc);
    e.def("__str__", [](E v) { return std::string(to_string(v)); });
    return e;
  }
}

// Binds the fields of a settings struct listed by its `S::for_each_field` as read-write attributes
// with the table's docstrings (a name that is a Python keyword gets a trailing underscore: `lambda_`),
// and `field_names()` (the attributes' names, in the table's order). A nested settings struct's
// attribute is its class (bound with its own bind_fields), returned by reference: assigning to its
// fields (`settings.camera.pixel_sigma = 0.3`) changes the outer struct.
template <typename S>
void bind_fields(pybind11::class_<S>& cls) {
  const pybind11::object is_keyword = pybind11::module_::import("keyword").attr("iskeyword");
  std::vector<std::string> names;
  S::for_each_field([&](const core::FieldInfo& f, auto member) {
    std::string name = f.name;
    if (is_keyword(name).template cast<bool>()) name += "_";
    if (*f.doc != '\0') {
      cls.def_readwrite(name.c_str(), member, f.doc);
    } else {
      cls.def_readwrite(name.c_str(), member);
    }
    names.push_back(name);
  });
  cls.def_static("field_names", [names] { return names; });
}

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
