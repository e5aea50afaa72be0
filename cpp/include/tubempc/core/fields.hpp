/// @file fields.hpp
/// One description per settings struct and one name table per option enum, from which the scenario
/// file, the Python binding and to_string/from_string are driven (docs/decisions.md "One field table").
///
/// An option enum E has its names in a specialisation of EnumNames<E> (next to the enum); a settings
/// struct lists its members once in a static `for_each_field(visitor)` that calls `visitor(FieldInfo, member
/// pointer)` per member. The kind of a field is its member's C++ type (int, double, bool, std::string,
/// a named enum, Eigen::MatrixXd, Eigen::VectorXd, a fixed-size Eigen matrix such as Eigen::Vector3d,
/// whose size the table gives with Dim::Three, or a nested settings struct with its own for_each_field,
/// whose fields are `<name>.<field>`); its default is the struct's in-class initialiser.
///
/// A status enum (the outcome of a step or a call) has a name table too: its to_string reads it and
/// the Python binding (bind_named_enum) binds its values and names from it.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace tubempc::core {

/// One value of an option enum and its two names.
template <typename E>
struct EnumName {
  E value;                 ///< the enumerator
  const char* identifier;  ///< the enumerator's identifier (C++ and Python, e.g. "ActiveSet")
  const char* name;        ///< its name in configuration and scenario files (e.g. "active_set")
};

/// Name table of an option enum E: each specialisation holds `static constexpr std::array<EnumName<E>, n>
/// values`, one entry per enumerator, in declaration order.
template <typename E>
struct EnumNames;

/// The file name of an enum value.
/// @param value the value.
/// @return its name in EnumNames<E>, or "unknown" for a value outside the table.
template <typename E>
constexpr const char* enum_name(E value) {
  for (const auto& entry : EnumNames<E>::values) {
    if (entry.value == value) return entry.name;
  }
  return "unknown";
}

/// Whether a value is one of the enum's named values (a cast integer may not be).
/// @param value the value.
/// @return true if EnumNames<E> lists it.
template <typename E>
constexpr bool is_named(E value) {
  for (const auto& entry : EnumNames<E>::values) {
    if (entry.value == value) return true;
  }
  return false;
}

/// The enum value of a file name.
/// @param name the name (e.g. "active_set").
/// @param[out] value set to the value if the name is known.
/// @return whether the name is known.
template <typename E>
bool enum_from_name(std::string_view name, E& value) {
  for (const auto& entry : EnumNames<E>::values) {
    if (name == entry.name) {
      value = entry.value;
      return true;
    }
  }
  return false;
}

/// The known names of an enum, quoted and comma-separated (for error messages).
/// @return e.g. "'piqp', 'active_set'".
template <typename E>
std::string enum_names_list() {
  std::string out;
  for (const auto& entry : EnumNames<E>::values)
    out += (out.empty() ? "'" : ", '") + std::string(entry.name) + "'";
  return out;
}

/// Symbolic size of a matrix field's dimension, resolved by the user of the table (n_x, n_u, n_c are
/// the plant's state, input and constraint counts).
enum class Dim {
  One,  ///< 1
  Nx,   ///< n_x, the state size
  Nu,   ///< n_u, the input size
  Nc,   ///< n_c, the number of state constraints
  Nw,   ///< n_w, a subsystem's state size (6: the identifiers' inputs)
  // The fixed sizes (fixed-size Eigen members: never empty, even when optional).
  Two,    ///< 2 (Eigen::Vector2d)
  Three,  ///< 3 (Eigen::Vector3d, Eigen::Matrix3d)
  Six,    ///< 6 (a wrench, Eigen::Matrix<double, 6, 1>)
  Nine,   ///< 9 (Eigen::Matrix<double, 9, 1>)
};

/// The size of a fixed dimension.
/// @param d the dimension.
/// @return 1, 2, 3, 6 or 9 for One, Two, Three, Six, Nine; -1 for a symbolic one (Nx, Nu, Nc, Nw).
constexpr int fixed_size(Dim d) {
  switch (d) {
    case Dim::One:
      return 1;
    case Dim::Two:
      return 2;
    case Dim::Three:
      return 3;
    case Dim::Six:
      return 6;
    case Dim::Nine:
      return 9;
    case Dim::Nx:
    case Dim::Nu:
    case Dim::Nc:
    case Dim::Nw:
      break;
  }
  return -1;
}

/// Description of one field of a settings struct. A nested settings struct (a member whose type has a
/// for_each_field) is a field too: its own fields are the records `<prefix><name>.<field>` (each
/// optional or not by its own FieldInfo); its FieldInfo has no unit, rows and cols One, and a doc.
struct FieldInfo {
  const char* name = "";  ///< member and record name (scenario files prefix it, e.g. "mpc.")
  const char* unit = "";  ///< SI unit ("" if dimensionless, an integer, a flag, an option or a nested struct)
  /// Whether a scenario file may omit it (then it keeps its default); an optional dynamic-size matrix
  /// may also be written empty (`0 0`).
  bool optional = false;
  bool allow_infinite = false;  ///< whether +-inf is a valid value (doubles only)
  Dim rows = Dim::One;          ///< rows of a matrix field (One for scalars)
  Dim cols = Dim::One;          ///< columns of a matrix field (One for scalars and vectors)
  const char* doc = "";         ///< the Python attribute's docstring ("" for none)
  bool in_file = true;  ///< whether scenario files have the record (false: a run-time or Python-only field)
};

/// A visitor that accepts every field (for has_fields).
struct AnyFieldVisitor {
  /// Does nothing.
  template <typename M>
  void operator()(const FieldInfo&, M) const {}
};

/// Whether S lists its fields (has a static `for_each_field(visitor)`): a member of such a type is a
/// nested settings struct.
template <typename S, typename = void>
struct has_fields : std::false_type {};
/// S has a for_each_field.
template <typename S>
struct has_fields<S, std::void_t<decltype(S::for_each_field(std::declval<AnyFieldVisitor&>()))>>
    : std::true_type {};

}  // namespace tubempc::core
