# Cross-compiling tubempc for aarch64 Linux with Debian's cross compiler (apt: g++-aarch64-linux-gnu; running the
# programs: qemu-user's qemu-aarch64). Eigen and PIQP are header-only: their CMake packages are taken from
# the host (Eigen3_DIR, piqp_DIR or the build's PIQP from PyPI), the libraries from the cross sysroot.
#   cmake -S . -B build/aarch64 --toolchain cmake/toolchains/aarch64-linux-gnu.cmake ...   (tools/cross_build.sh)
# -ffp-contract=off: no fused multiply-add contraction (GCC fuses a * b + c in its GNU modes, -std=gnu++17, and
# ARM has FMA; the core's -std=c++17 implies off, this keeps it so for any consumer), so that every product
# and sum rounds as on x86-64 (built without FMA) and the flights end in the same state.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(CMAKE_CXX_FLAGS_INIT "-ffp-contract=off")
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L /usr/aarch64-linux-gnu)
