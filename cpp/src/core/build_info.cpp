#include "tubempc/core/build_info.hpp"

#include <Eigen/Core>
#include <thread>

#include "tubempc/core/build_config.hpp"

namespace tubempc::core {
namespace {

std::string compiler_string() {
#if defined(__clang__)
  return "Clang " __clang_version__;
#elif defined(__GNUC__)
  return "GCC " __VERSION__;
#elif defined(_MSC_VER)
  return "MSVC " + std::to_string(_MSC_VER);
#else
  return "unknown";
#endif
}

}  // namespace

BuildInfo build_info() {
  BuildInfo info;
  info.version = TUBEMPC_VERSION_STRING;
  info.compiler = compiler_string();
  info.build_type = TUBEMPC_BUILD_TYPE;
  info.cxx_flags = TUBEMPC_CXX_FLAGS;
  info.eigen_version = std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) + "." +
                       std::to_string(EIGEN_MINOR_VERSION);
  info.eigen_simd = Eigen::SimdInstructionSetsInUse();
  info.piqp_version = TUBEMPC_PIQP_VERSION_STRING;
  info.hardware_threads = std::thread::hardware_concurrency();
  return info;
}

}  // namespace tubempc::core
