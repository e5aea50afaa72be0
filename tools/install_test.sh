#!/usr/bin/env bash
# Install test: install tubempc::core (CMake component tubempc_cpp) into a temporary prefix, then build
# examples/cpp/minimal and examples/cpp/closed_loop as separate CMake projects against that prefix
# (find_package(tubempc)) and run them. closed_loop flies the scenario that `tubempc export-scenario`
# writes with the Python given by --python (an interpreter with the tubempc package installed);
# without --python it is built but not run.
#   bash tools/install_test.sh [--build DIR] [--python PY]
# --build DIR: install from that existing, built tree (configured with -DTUBEMPC_INSTALL=ON; the test
# command passes build/test, so nothing is configured, built or downloaded twice). Without it the core
# is configured and built in a temporary folder (PYTHON=<python with pyproject.toml's build requirements>).
# Parallel build jobs: CMAKE_BUILD_PARALLEL_LEVEL (default: all cores).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-$(command -v python3)}
case "$PY" in /*) ;; *) PY="$PWD/$PY" ;; esac  # CMake needs an absolute path (a venv's python is a symlink)
SCENARIO_PY=""
BUILD=""
while [ $# -gt 0 ]; do
  case "$1" in
    --python) SCENARIO_PY=${2:?--python needs an interpreter}; shift 2 ;;
    --build) BUILD=${2:?--build needs a build folder}; shift 2 ;;
    *) echo "usage: $0 [--build DIR] [--python PY]" >&2; exit 2 ;;
  esac
done
jobs=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ -z "$BUILD" ]; then
  BUILD="$work/build"
  cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Release -DTUBEMPC_INSTALL=ON -DPython_EXECUTABLE="$PY"
  cmake --build "$BUILD" -j"$jobs"
fi
cmake --install "$BUILD" --component tubempc_cpp --prefix "$work/prefix"
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
