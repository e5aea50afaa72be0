#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "bindings.hpp"
#include "tubempc/gravity/composite_gravity.hpp"
#include "tubempc/gravity/expansion_hold.hpp"
#include "tubempc/gravity/gravity_model.hpp"
#include "tubempc/gravity/polyhedron_gravity.hpp"
#include "tubempc/gravity/shape.hpp"
#include "tubempc/gravity/shape_io.hpp"

namespace py = pybind11;

namespace tubempc::python {

namespace {

using gravity::CompositeGravity;
using gravity::Faces;
using gravity::PolyhedronGravity;
using gravity::Shape;
using gravity::ShapeRepair;
using gravity::Vertices;
using PointArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

int thread_count(std::optional<int> threads) {
  if (threads && *threads < 0) throw py::value_error("threads must be None, 0 (all hardware threads) or > 0");
  return threads ? *threads : 0;
}

// Points as an (n, 3) view; `single` tells whether a (3,) input was given.
Eigen::Map<const gravity::Points> as_points(const PointArray& a, bool& single) {
  single = a.ndim() == 1;
  if (!((a.ndim() == 1 && a.shape(0) == 3) || (a.ndim() == 2 && a.shape(1) == 3))) {
    throw py::value_error("points must have shape (3,) or (n, 3)");
  }
  const Eigen::Index n = single ? 1 : a.shape(0);
  return {a.data(), n, 3};
}

py::tuple evaluate(const PolyhedronGravity& g, const PointArray& points, std::optional<int> threads) {
  bool single = false;
  const auto r = as_points(points, single);
  const Eigen::Index n = r.rows();
  py::array_t<double> pot(n);
  py::array_t<double> acc({n, Eigen::Index{3}});
  py::array_t<double> grad({n, Eigen::Index{3}, Eigen::Index{3}});
  {
    Eigen::Map<Eigen::VectorXd> p(pot.mutable_data(), n);
    Eigen::Map<gravity::Points> a(acc.mutable_data(), n, 3);
    Eigen::Map<gravity::Gradients> G(grad.mutable_data(), n, 9);
    const int t = thread_count(threads);
    py::gil_scoped_release release;
    g.evaluate_batch(r, p, a, G, t);
  }
  if (single) {
    return py::make_tuple(pot.at(0), acc.attr("reshape")(3), grad.attr("reshape")(3, 3));
  }
  return py::make_tuple(pot, acc, grad);
}

py::object laplacian(const PolyhedronGravity& g, const PointArray& points, std::optional<int> threads) {
  bool single = false;
  const auto r = as_points(points, single);
  py::array_t<double> out(r.rows());
  {
    Eigen::Map<Eigen::VectorXd> l(out.mutable_data(), r.rows());
    const int t = thread_count(threads);
    py::gil_scoped_release release;
    g.laplacian_batch(r, l, t);
  }
  if (single) return py::float_(out.at(0));
  return std::move(out);
}

Eigen::Matrix<std::int64_t, Eigen::Dynamic, 4, Eigen::RowMajor> edge_table(const Shape& s) {
  Eigen::Matrix<std::int64_t, Eigen::Dynamic, 4, Eigen::RowMajor> t(
      static_cast<Eigen::Index>(s.edges().size()), 4);
  for (size_t i = 0; i < s.edges().size(); ++i) {
    const auto& e = s.edges()[i];
    t.row(static_cast<Eigen::Index>(i)) << e.v0, e.v1, e.face_a, e.face_b;
  }
  return t;
}

// A composite's part as Python sees it: (shape, density (kg/m^3), offset_A (m)).
using PartTuple = std::tuple<Shape, double, Eigen::Vector3d>;

CompositeGravity composite_from(const std::vector<PartTuple>& parts) {
  std::vector<gravity::GravityPart> out;
  out.reserve(parts.size());
  for (const auto& [shape, density, offset] : parts)
    out.push_back(CompositeGravity::part(shape, density, offset));
  return CompositeGravity(std::move(out));
}

std::vector<PartTuple> composite_parts(const CompositeGravity& g) {
  std::vector<PartTuple> out;
  for (const auto& p : g.parts()) out.emplace_back(p.polyhedron->shape(), p.density, p.offset_A);
  return out;
}

py::tuple evaluate_composite(const CompositeGravity& g, const PointArray& points) {
  bool single = false;
  const auto r = as_points(points, single);
  const Eigen::Index n = r.rows();
  py::array_t<double> pot(n);
  py::array_t<double> acc({n, Eigen::Index{3}});
  py::array_t<double> grad({n, Eigen::Index{3}, Eigen::Index{3}});
  {
    Eigen::Map<Eigen::VectorXd> p(pot.mutable_data(), n);
    Eigen::Map<gravity::Points> a(acc.mutable_data(), n, 3);
    Eigen::Map<gravity::Gradients> G(grad.mutable_data(), n, 9);
    py::gil_scoped_release release;
    gravity::GravitySample s;
    for (Eigen::Index i = 0; i < n; ++i) {
      g.evaluate(r.row(i).transpose(), s);
      p(i) = s.potential;
      a.row(i) = s.acceleration.transpose();
      for (int j = 0; j < 9; ++j) G(i, j) = s.gradient(j / 3, j % 3);
    }
  }
  if (single) {
    return py::make_tuple(pot.at(0), acc.attr("reshape")(3), grad.attr("reshape")(3, 3));
  }
  return py::make_tuple(pot, acc, grad);
}

py::object laplacian_composite(const CompositeGravity& g, const PointArray& points) {
  bool single = false;
  const auto r = as_points(points, single);
  py::array_t<double> out(r.rows());
  {
    Eigen::Map<Eigen::VectorXd> l(out.mutable_data(), r.rows());
    py::gil_scoped_release release;
    for (Eigen::Index i = 0; i < r.rows(); ++i) l(i) = g.laplacian(r.row(i).transpose());
  }
  if (single) return py::float_(out.at(0));
  return std::move(out);
}

}  // namespace

void bind_gravity(py::module_& m) {
  auto g = m.def_submodule("gravity", "Constant-density polyhedron gravity and validated shapes (SI units)");
  g.attr("GRAVITATIONAL_CONSTANT") = gravity::kGravitationalConstant;

  // Every field is a GravityModel held by std::shared_ptr, so the dynamics can share it.
  py::class_<gravity::GravityModel, std::shared_ptr<gravity::GravityModel>>(
      g, "GravityModel", "Gravity field in the asteroid frame A (interface).")
      .def(
          "evaluate_point",
          [](const gravity::GravityModel& self, const Eigen::Vector3d& r_A) {
            gravity::GravitySample s;
            self.evaluate(r_A, s);
            return py::make_tuple(s.potential, s.acceleration, s.gradient);
          },
          py::arg("r_A"), "(U (m^2/s^2), a = grad U (m/s^2), Hess U (1/s^2)) at one point r_A (3,) m in A.")
      .def_property_readonly("gm", &gravity::GravityModel::gm, "G M (m^3/s^2).");

  py::class_<gravity::PointMassGravity, gravity::GravityModel, std::shared_ptr<gravity::PointMassGravity>>(
      g, "PointMassGravity", "Point mass at the origin of A: U = GM / |r|.")
      .def(py::init<double>(), py::arg("gm"), "gm: gravitational parameter (m^3/s^2), > 0.")
      .def("__repr__",
           [](const gravity::PointMassGravity& self) {
             return "PointMassGravity(gm=" + py::repr(py::float_(self.gm())).cast<std::string>() + ")";
           })
      .def(py::pickle([](const gravity::PointMassGravity& self) { return py::make_tuple(self.gm()); },
                      [](const py::tuple& t) {
                        if (t.size() != 1) throw std::invalid_argument("PointMassGravity: bad pickle state");
                        return std::make_shared<gravity::PointMassGravity>(t[0].cast<double>());
                      }));

  py::class_<gravity::ExpansionHold>(g, "ExpansionHold", R"doc(
A gravity field's first-order expansion held over a distance (docs/model.md M42): the state of one
trajectory (a run's truth with PropagatorSettings.gravity_expansion_tolerance, a navigation filter).
)doc")
      .def(py::init<double, double>(), py::arg("min_distance") = 0.0, py::arg("tolerance") = 0.0,
           "min_distance: d_min (m), >= 0; tolerance: the expansion's error tolerance (m/s^2), >= 0.")
      .def(
          "hold",
          [](gravity::ExpansionHold& self, const gravity::GravityModel& field, const Eigen::Vector3d& r_A) {
            return self.hold(field, r_A);
          },
          py::arg("field"), py::arg("r_A"),
          "Makes r_A (m, frame A) the expansion's point unless it is within the hold distance of the current "
          "one; False when the field cannot be evaluated there (the expansion unchanged).")
      .def(
          "acceleration",
          [](const gravity::ExpansionHold& self, const Eigen::Vector3d& r_A) {
            if (!self.valid())
              throw std::invalid_argument("ExpansionHold.acceleration: no expansion held yet");
            return Eigen::Vector3d(self.acceleration(r_A));
          },
          py::arg("r_A"), "a(r0) + G(r0) (r_A - r0) (m/s^2, frame A).")
      .def_property_readonly("valid", &gravity::ExpansionHold::valid)
      .def_property_readonly("point_A", &gravity::ExpansionHold::point_A, "The expansion's point r0 (m, A).")
      .def_property_readonly("gradient_A", &gravity::ExpansionHold::gradient_A, "G(r0) (1/s^2, A).")
      .def_property_readonly("distance", &gravity::ExpansionHold::distance, "The current hold distance (m).")
      .def_property_readonly("evaluations", &gravity::ExpansionHold::evaluations, "The field's evaluations.")
      .def_property_readonly("largest_error", &gravity::ExpansionHold::largest_error,
                             "The largest error found at a re-evaluation (m/s^2).")
      .def_property_readonly("min_distance", &gravity::ExpansionHold::min_distance, "d_min (m).")
      .def_property_readonly("tolerance", &gravity::ExpansionHold::tolerance, "tol (m/s^2).")
      .def("reset", &gravity::ExpansionHold::reset, "Forgets the expansion and the counts.");

  py::enum_<ShapeRepair>(g, "ShapeRepair", "What Shape may change in the mesh it is given.")
      .value("NONE", ShapeRepair::None, "reject orientation errors")
      .value("ORIENT", ShapeRepair::Orient, "flip faces to a consistent outward orientation");

  py::class_<Shape>(g, "Shape", R"doc(
A closed, consistently outward-oriented triangle mesh (metres), validated on construction.

Shape(vertices (n, 3) m, faces (m, 3) 0-based, repair=ShapeRepair.NONE). ValueError names the
offending vertex, face or edge for: non-finite coordinates, index out of range, degenerate or
duplicate face, open or non-manifold mesh, inconsistent or inward orientation (the latter two are
repaired with repair=ShapeRepair.ORIENT).)doc")
      .def(
          py::init([](const Vertices& v, const Faces& f, ShapeRepair repair) { return Shape(v, f, repair); }),
          py::arg("vertices"), py::arg("faces"), py::arg("repair") = ShapeRepair::None)
      .def_property_readonly("vertices", &Shape::vertices, "Vertices (n, 3) in m.")
      .def_property_readonly("faces", &Shape::faces, "Faces (m, 3), 0-based, outward (counter-clockwise).")
      .def_property_readonly("n_vertices", &Shape::n_vertices)
      .def_property_readonly("n_faces", &Shape::n_faces)
      .def_property_readonly("n_edges", [](const Shape& s) { return s.edges().size(); })
      .def_property_readonly("edges", &edge_table,
                             "Unique edges (k, 4): v0, v1, face_a (runs v0 -> v1), face_b (runs v1 -> v0).")
      .def_property_readonly("n_flipped_faces", &Shape::n_flipped_faces,
                             "Faces flipped by ShapeRepair.ORIENT.")
      .def_property_readonly("volume", &Shape::volume, "Volume (m^3).")
      .def_property_readonly("center_of_mass", &Shape::center_of_mass,
                             "Centre of mass (m), constant density.")
      .def_property_readonly("inertia_per_unit_density", &Shape::inertia_per_unit_density,
                             "Inertia tensor about the centre of mass per unit density (m^5).")
      .def("inertia", &Shape::inertia, py::arg("density"),
           "Inertia tensor about the centre of mass (kg m^2) for a density (kg/m^3).")
      .def_property_readonly("mean_radius", &Shape::mean_radius, "Radius of the equal-volume sphere (m).")
      .def(py::pickle([](const Shape& s) { return py::make_tuple(s.vertices(), s.faces()); },
                      [](const py::tuple& t) {
                        if (t.size() != 2) throw std::runtime_error("Shape: bad pickle state");
                        return Shape(t[0].cast<Vertices>(), t[1].cast<Faces>());
                      }));

  g.def("load_shape", &gravity::load_shape, py::arg("path"), py::arg("unit_scale"),
        py::arg("repair") = ShapeRepair::None,
        "The C++ shape loader (gravity/shape_io.hpp): OBJ or PDS v/f table (.tab) -> Shape in m; unit_scale "
        "is metres per file unit. ValueError '<path>:<line>: <what>'.");
  g.def("save_obj", &gravity::save_obj, py::arg("path"), py::arg("shape"), py::arg("unit_scale") = 1.0,
        "Writes a Shape as OBJ with coordinates divided by unit_scale (17 significant digits).");

  py::class_<PolyhedronGravity, gravity::GravityModel, std::shared_ptr<PolyhedronGravity>>(
      g, "PolyhedronGravity", R"doc(
Gravity of a constant-density polyhedron (Werner and Scheeres 1997; docs/model.md "Gravity").

PolyhedronGravity(vertices (n, 3) m, faces (m, 3) 0-based, density kg/m^3, repair=ShapeRepair.NONE)
or PolyhedronGravity(shape, density). G = 6.67430e-11.

Sign convention: the potential U is positive (U -> GM/|r| far away) and the acceleration is its
gradient, a = grad U (pointing towards the body); the gradient tensor is Hess U = d a / d r.
On a face the Hessian returned is the mean of its inside and outside limits; on an edge or vertex
it is singular and the value returned is finite but not a limit. Beyond 400 times the largest vertex
distance from the centre of mass the degree-2 exterior expansion (point mass + quadrupole) replaces
the polyhedron sums, whose cancellation grows like |r|^2 (see polyhedron_gravity.hpp).)doc")
      .def(py::init([](const Vertices& v, const Faces& f, double density, ShapeRepair repair) {
             return PolyhedronGravity(Shape(v, f, repair), density);
           }),
           py::arg("vertices"), py::arg("faces"), py::arg("density"), py::arg("repair") = ShapeRepair::None)
      .def(py::init<Shape, double>(), py::arg("shape"), py::arg("density"))
      .def("evaluate", &evaluate, py::arg("points"), py::arg("threads") = py::none(),
           R"doc(U (n,) m^2/s^2, a = grad U (n, 3) m/s^2 and Hess U (n, 3, 3) 1/s^2 at points (n, 3) m.

A (3,) point gives (float, (3,), (3, 3)). threads: None or 0 = all hardware threads. The GIL is
released; results do not depend on the number of threads.)doc")
      .def("laplacian", &laplacian, py::arg("points"), py::arg("threads") = py::none(),
           "Laplacian of U (1/s^2) at points (n, 3) or (3,) m: -G rho sum_f w_f (0 outside, -4 pi G rho "
           "inside).")
      .def_property_readonly("density", &PolyhedronGravity::density, "kg/m^3")
      .def_property_readonly("mass", &PolyhedronGravity::mass, "kg")
      .def_property_readonly("gm", &PolyhedronGravity::gm, "G M (m^3/s^2)")
      .def_property_readonly(
          "volume", [](const PolyhedronGravity& s) { return s.shape().volume(); }, "m^3")
      .def_property_readonly(
          "center_of_mass", [](const PolyhedronGravity& s) { return s.shape().center_of_mass(); }, "m")
      .def_property_readonly(
          "inertia", [](const PolyhedronGravity& s) { return s.shape().inertia(s.density()); },
          "Inertia tensor about the centre of mass (kg m^2).")
      .def_property_readonly(
          "mean_radius", [](const PolyhedronGravity& s) { return s.shape().mean_radius(); }, "m")
      .def_property_readonly("n_faces", [](const PolyhedronGravity& s) { return s.shape().n_faces(); })
      .def_property_readonly("n_vertices", [](const PolyhedronGravity& s) { return s.shape().n_vertices(); })
      .def_property_readonly(
          "vertices", [](const PolyhedronGravity& s) { return s.shape().vertices(); }, "m")
      .def_property_readonly("faces", [](const PolyhedronGravity& s) { return s.shape().faces(); })
      .def_property_readonly("shape", &PolyhedronGravity::shape, py::return_value_policy::reference_internal)
      .def(py::pickle(
          [](const PolyhedronGravity& s) {
            return py::make_tuple(s.shape().vertices(), s.shape().faces(), s.density());
          },
          [](const py::tuple& t) {
            if (t.size() != 3) throw std::runtime_error("PolyhedronGravity: bad pickle state");
            return PolyhedronGravity(Shape(t[0].cast<Vertices>(), t[1].cast<Faces>()), t[2].cast<double>());
          }));

  py::class_<CompositeGravity, gravity::GravityModel, std::shared_ptr<CompositeGravity>>(
      g, "CompositeGravity", R"doc(
A heterogeneous body as a sum of homogeneous polyhedra of signed densities (gravity/composite_gravity.hpp;
docs/model.md "Physical environment").

CompositeGravity(parts): parts is a list of (shape, density kg/m^3, offset_A (3,) m); part i's mesh
point p lies at p + offset_A in A and its density may be negative (a deficit inside another part).
U, grad U and Hess U are the sums of the parts'; inside a region the Laplacian is -4 pi G times the
sum of the densities of the parts containing it.)doc")
      .def(py::init(&composite_from), py::arg("parts"))
      .def("evaluate", &evaluate_composite, py::arg("points"),
           "U (n,) m^2/s^2, a = grad U (n, 3) m/s^2 and Hess U (n, 3, 3) 1/s^2 at points (n, 3) m; a (3,) "
           "point "
           "gives (float, (3,), (3, 3)). The GIL is released.")
      .def("laplacian", &laplacian_composite, py::arg("points"),
           "Laplacian of U (1/s^2) at points (n, 3) or (3,) m: -4 pi G times the density there.")
      .def("translated", &CompositeGravity::translated, py::arg("d_A"),
           "The same body moved by d_A (m): every part's offset plus d_A (the meshes are shared).")
      .def_property_readonly("gm", &CompositeGravity::gm, "G M (m^3/s^2)")
      .def_property_readonly("mass", &CompositeGravity::mass, "M = sum_i rho_i V_i (kg)")
      .def_property_readonly("center_of_mass", &CompositeGravity::center_of_mass, "centre of mass in A (m)")
      .def_property_readonly("inertia", &CompositeGravity::inertia,
                             "inertia tensor about the centre of mass (kg m^2)")
      .def_property_readonly(
          "n_parts", [](const CompositeGravity& c) { return c.parts().size(); }, "number of parts")
      .def_property_readonly("parts", &composite_parts, "[(shape, density (kg/m^3), offset_A (m)), ...]")
      .def("__repr__",
           [](const CompositeGravity& c) {
             return "CompositeGravity(n_parts=" + std::to_string(c.parts().size()) +
                    ", gm=" + py::repr(py::float_(c.gm())).cast<std::string>() + ")";
           })
      .def(py::pickle(
          [](const CompositeGravity& c) {
            py::list parts;
            for (const auto& p : c.parts()) {
              parts.append(py::make_tuple(p.polyhedron->shape().vertices(), p.polyhedron->shape().faces(),
                                          p.density, p.offset_A));
            }
            return py::make_tuple(parts);
          },
          [](const py::tuple& t) {
            if (t.size() != 1) throw std::runtime_error("CompositeGravity: bad pickle state");
            std::vector<PartTuple> parts;
            for (const auto& item : t[0].cast<py::list>()) {
              const auto p = item.cast<py::tuple>();
              parts.emplace_back(Shape(p[0].cast<Vertices>(), p[1].cast<Faces>()), p[2].cast<double>(),
                                 p[3].cast<Eigen::Vector3d>());
            }
            return composite_from(parts);
          }));
}

}  // namespace tubempc::python
