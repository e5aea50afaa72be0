#!/usr/bin/env bash
# Install test: configure, build and install tubempc::core into a temporary prefix, then build and
# run examples/cpp/minimal as a separate CMake project against that prefix.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-$(command -v python3)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake -S . -B "$work/build" -DCMAKE_BUILD_TYPE=Release -DTUBEMPC_INSTALL=ON -DCMAKE_INSTALL_PREFIX="$work/prefix" \
      -DPython_EXECUTABLE="$PY"
cmake --build "$work/build" -j"$(nproc)"
cmake --install "$work/build"
cmake -S examples/cpp/minimal -B "$work/example" -DCMAKE_PREFIX_PATH="$work/prefix"
cmake --build "$work/example"
"$work/example/minimal"
