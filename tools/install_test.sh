#!/usr/bin/env bash
# Install test: configure, build and install tubempc::core into a temporary prefix, then build
# examples/cpp/minimal and examples/cpp/closed_loop as separate CMake projects against that prefix
# (find_package(tubempc)) and run them. closed_loop flies the scenario that `tubempc export-scenario`
# writes with the Python given by --python (an interpreter with the tubempc package installed;
# tools/test.sh passes its .venv's); without --python it is built but not run.
#   PYTHON=<python with cmeel-eigen or a system Eigen> bash tools/install_test.sh [--python PY]
# Parallel build jobs: CMAKE_BUILD_PARALLEL_LEVEL (default: all cores).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-$(command -v python3)}
case "$PY" in /*) ;; *) PY="$PWD/$PY" ;; esac  # CMake needs an absolute path (a venv's python is a symlink)
SCENARIO_PY=""
while [ $# -gt 0 ]; do
  case "$1" in
    --python) SCENARIO_PY=${2:?--python needs an interpreter}; shift 2 ;;
    *) echo "usage: $0 [--python PY]" >&2; exit 2 ;;
  esac
done
jobs=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake -S . -B "$work/build" -DCMAKE_BUILD_TYPE=Release -DTUBEMPC_INSTALL=ON -DCMAKE_INSTALL_PREFIX="$work/prefix" \
      -DPython_EXECUTABLE="$PY"
cmake --build "$work/build" -j"$jobs"
cmake --install "$work/build"
for example in minimal closed_loop; do
  cmake -S "examples/cpp/$example" -B "$work/$example" -DCMAKE_PREFIX_PATH="$work/prefix"
  cmake --build "$work/$example" -j"$jobs"
done
"$work/minimal/minimal"
if [ -n "$SCENARIO_PY" ]; then
  "$SCENARIO_PY" -m tubempc export-scenario --out "$work/scenario"
  "$work/closed_loop/closed_loop" "$work/scenario/scenario.txt"
else
  echo "install test: closed_loop built but not run (pass --python PY, a Python with tubempc, to export a scenario)"
fi
echo "install test passed"
