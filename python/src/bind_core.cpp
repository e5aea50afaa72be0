#include <pybind11/stl.h>

#include "bindings.hpp"
#include "tubempc/core/build_info.hpp"

namespace py = pybind11;

namespace tubempc::python {

void bind_core(py::module_& m) {
  m.def(
      "build_info",
      [] {
        const core::BuildInfo b = core::build_info();
        py::dict d;
        d["version"] = b.version;
        d["compiler"] = b.compiler;
        d["build_type"] = b.build_type;
        d["cxx_flags"] = b.cxx_flags;
        d["eigen_version"] = b.eigen_version;
        d["eigen_simd"] = b.eigen_simd;
        d["piqp_version"] = b.piqp_version;
        d["hardware_threads"] = b.hardware_threads;
        return d;
      },
      "Facts about how the C++ core was built (compiler, flags, Eigen, PIQP, threads).");
}

}  // namespace tubempc::python
