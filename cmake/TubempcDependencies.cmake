# Dependencies of tubempc::core: Eigen (system, or the cmeel-eigen wheel), PIQP (an installed one
# first; else its official source distribution from PyPI, downloaded by pip with its SHA-256 checked
# (--require-hashes) and installed into the build tree), and threads.
include(GNUInstallDirs)
find_package(Threads REQUIRED)

if(TUBEMPC_BUILD_PYTHON)
  find_package(Python 3.9 REQUIRED COMPONENTS Interpreter Development.Module)
else()
  find_package(Python 3.9 COMPONENTS Interpreter)
endif()

# Folders on the interpreter's sys.path that hold a cmeel prefix (pip install cmeel-eigen).
set(_tubempc_cmeel_prefixes "")
if(Python_EXECUTABLE)
  execute_process(
    COMMAND ${Python_EXECUTABLE} -c
      "import os, sys; print(';'.join(os.path.join(p, 'cmeel.prefix') for p in sys.path if os.path.isdir(os.path.join(p, 'cmeel.prefix'))))"
    OUTPUT_VARIABLE _tubempc_cmeel_prefixes OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
endif()

find_package(Eigen3 3.4 CONFIG QUIET)
if(NOT Eigen3_FOUND)
  find_package(Eigen3 3.4 CONFIG REQUIRED HINTS ${_tubempc_cmeel_prefixes})
endif()
message(STATUS "tubempc: Eigen ${Eigen3_VERSION} from ${Eigen3_DIR}")

find_package(piqp CONFIG QUIET)
if(NOT piqp_FOUND)
  if(NOT TUBEMPC_FETCH_PIQP)
    message(FATAL_ERROR "tubempc: PIQP not found; set piqp_DIR or turn TUBEMPC_FETCH_PIQP on")
  endif()
  if(NOT Python_EXECUTABLE)
    message(FATAL_ERROR "tubempc: TUBEMPC_FETCH_PIQP needs a Python interpreter with pip")
  endif()
  set(_piqp_root ${CMAKE_BINARY_DIR}/_deps/piqp-${TUBEMPC_PIQP_VERSION})
  set(_piqp_prefix ${_piqp_root}/install)
  if(NOT EXISTS ${_piqp_prefix}/.tubempc-complete)
    message(STATUS "tubempc: obtaining piqp==${TUBEMPC_PIQP_VERSION} (source distribution) from PyPI with pip")
    file(REMOVE_RECURSE ${_piqp_root})
    if(NOT TUBEMPC_PIQP_SHA256 MATCHES "^[0-9a-f]+$")
      message(FATAL_ERROR "tubempc: TUBEMPC_PIQP_SHA256 must be the sha256 of piqp-${TUBEMPC_PIQP_VERSION}.tar.gz")
    endif()
    file(WRITE ${_piqp_root}/requirement.txt
         "piqp==${TUBEMPC_PIQP_VERSION} --hash=sha256:${TUBEMPC_PIQP_SHA256}\n")
    execute_process(
      COMMAND ${Python_EXECUTABLE} -m pip download --no-deps --no-binary=:all: --no-build-isolation
              --require-hashes --disable-pip-version-check -q -d ${_piqp_root}/sdist
              -r ${_piqp_root}/requirement.txt
      RESULT_VARIABLE _rc)
    file(GLOB _piqp_sdist ${_piqp_root}/sdist/piqp-*.tar.gz)
    if(NOT _rc EQUAL 0 OR NOT _piqp_sdist)
      message(FATAL_ERROR "tubempc: pip could not download piqp==${TUBEMPC_PIQP_VERSION}'s source distribution "
                          "with sha256 ${TUBEMPC_PIQP_SHA256} (a different version needs its TUBEMPC_PIQP_SHA256)")
    endif()
    file(ARCHIVE_EXTRACT INPUT ${_piqp_sdist} DESTINATION ${_piqp_root}/src)
    file(GLOB _piqp_src LIST_DIRECTORIES true ${_piqp_root}/src/piqp-*)
    execute_process(
      COMMAND ${CMAKE_COMMAND} -S ${_piqp_src} -B ${_piqp_root}/build -DCMAKE_BUILD_TYPE=Release
              -DCMAKE_INSTALL_PREFIX=${_piqp_prefix} -DEigen3_DIR=${Eigen3_DIR}
              -DBUILD_WITH_TEMPLATE_INSTANTIATION=OFF -DBUILD_C_INTERFACE=OFF -DBUILD_PYTHON_INTERFACE=OFF
              -DBUILD_TESTS=OFF -DBUILD_EXAMPLES=OFF -DBUILD_BENCHMARKS=OFF -DENABLE_INSTALL=ON
      OUTPUT_QUIET RESULT_VARIABLE _rc)
    if(_rc EQUAL 0)
      execute_process(COMMAND ${CMAKE_COMMAND} --install ${_piqp_root}/build OUTPUT_QUIET RESULT_VARIABLE _rc)
    endif()
    if(NOT _rc EQUAL 0)
      message(FATAL_ERROR "tubempc: configuring or installing PIQP from ${_piqp_src} failed")
    endif()
    file(TOUCH ${_piqp_prefix}/.tubempc-complete)
  endif()
  find_package(piqp CONFIG REQUIRED PATHS ${_piqp_prefix} NO_DEFAULT_PATH)
  set(TUBEMPC_PIQP_PREFIX ${_piqp_prefix})
endif()
message(STATUS "tubempc: PIQP ${piqp_VERSION} from ${piqp_DIR}")
