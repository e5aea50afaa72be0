/// @file build_info.hpp
/// Facts about how tubempc::core was built, for `tubempc info` and for benchmark reports.
#pragma once

#include <string>

namespace tubempc::core {

/// Build facts of the core library.
struct BuildInfo {
  std::string version;           ///< tubempc version (semantic version string)
  std::string compiler;          ///< compiler name and version
  std::string build_type;        ///< CMake build type
  std::string cxx_flags;         ///< compile flags of the build type
  std::string eigen_version;     ///< Eigen version the core was compiled against
  std::string eigen_simd;        ///< SIMD instruction sets Eigen uses
  std::string piqp_version;      ///< PIQP version (header-only C++ backend)
  unsigned hardware_threads{0};  ///< std::thread::hardware_concurrency() at run time
};

/// The build facts of this library.
/// @return version, compiler, flags, Eigen and PIQP versions of this build and the hardware threads now.
BuildInfo build_info();

}  // namespace tubempc::core
