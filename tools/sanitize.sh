#!/usr/bin/env bash
# ctest under AddressSanitizer and UndefinedBehaviorSanitizer (TUBEMPC_SANITIZE): the C++ core and its
# GoogleTest suites built into build/sanitize at -O1 -g (NDEBUG kept, as the release build the tests check),
# every test run; any sanitizer report fails the test that made it (-fno-sanitize-recover=all). The
# allocation-counting suites (tests/cpp/*_alloc) are left out, since they replace malloc as ASan does; the
# examples need the Python package and are not built. Run by hand before a release (README): it does
# not fit the test command's time (docs/decisions.md "Static analysis and sanitizers").
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
py=${PYTHON:-.venv/bin/python}
[ -x "$py" ] || py=$(command -v python3)
jobs=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc)}
cmake -S . -B build/sanitize -DTUBEMPC_SANITIZE=ON -DTUBEMPC_BUILD_TESTS=ON -DTUBEMPC_BUILD_PYTHON=OFF \
  -DTUBEMPC_BUILD_EXAMPLES=OFF -DTUBEMPC_INSTALL=OFF -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_FLAGS_RELEASE="-O1 -g -DNDEBUG" -DPython_EXECUTABLE="$py"
cmake --build build/sanitize -j "$jobs"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
ctest --test-dir build/sanitize --output-on-failure -j "$jobs" --exclude-regex doxygen_headers
echo "sanitizers: ctest clean under ASan and UBSan in $(( $(date +%s) - start )) s"
