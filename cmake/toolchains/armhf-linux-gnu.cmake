# Cross-compiling tubempc for armhf Linux with Debian's cross compiler (apt: g++-arm-linux-gnueabihf; running the
# programs: qemu-user's qemu-arm). Eigen and PIQP are header-only: their CMake packages are taken from
# the host (Eigen3_DIR, piqp_DIR or the build's PIQP from PyPI), the libraries from the cross sysroot.
#   cmake -S . -B build/armhf --toolchain cmake/toolchains/armhf-linux-gnu.cmake ...   (tools/cross_build.sh)
# -ffp-contract=off: no fused multiply-add contraction (GCC fuses a * b + c in its GNU modes, -std=gnu++17, and
# ARM has FMA; the core's -std=c++17 implies off, this keeps it so for any consumer), so that every product
# and sum rounds as on x86-64 (built without FMA) and the flights end in the same state.
# -Wno-psabi (armhf): silences GCC's notes that the ABI of passing some iterators changed in GCC 7.1 (the
# whole program is built by the one compiler).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR armhf)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_CXX_COMPILER arm-linux-gnueabihf-g++)
set(CMAKE_FIND_ROOT_PATH /usr/arm-linux-gnueabihf)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(CMAKE_CXX_FLAGS_INIT "-ffp-contract=off -Wno-psabi")
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm -L /usr/arm-linux-gnueabihf)
