#!/usr/bin/env bash
# The test command (README): installs tubempc with its C++ test suite into .venv, then runs ctest (GoogleTest,
# the C++ examples, the Doxygen check), the install test (tools/install_test.sh: the C++ package installed from
# the same build tree into a temporary prefix, both C++ examples built against it, closed_loop flying a scenario
# exported by the installed package), the documentation site (tools/docs.sh: Sphinx with the executed
# tutorials, the API and the Doxygen C++ reference) beside the lint (tools/lint.sh: ruff check, ruff format
# --check, mypy --strict, clang-format, the stubs check, cppcheck), and pytest. One build tree serves them all:
# build/test. Its duration goes to build/test/test_command.json (docs/benchmarks/ keeps the published one).
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
# Seconds of each phase, in order, for build/test/test_command.json.
phases=()
mark=$start
phase_done() { now=$(date +%s); phases+=("$1=$(( now - mark ))"); mark=$now; }

missing=()
[ -f /usr/include/gtest/gtest.h ] || missing+=(libgtest-dev)
command -v doxygen > /dev/null || missing+=(doxygen)
command -v clang-format > /dev/null || missing+=(clang-format)
command -v clang-tidy > /dev/null || missing+=(clang-tidy)
command -v cppcheck > /dev/null || missing+=(cppcheck)
command -v chromium > /dev/null || missing+=(chromium)
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing Debian's ${missing[*]} (GoogleTest for ctest, Doxygen for the header check and the C++ reference," \
    "clang-format, clang-tidy and cppcheck for the lint, Chromium for the report's 3D view test)"
  if [ "$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi
  $SUDO apt-get update -q && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q "${missing[@]}"
fi

PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
export CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc)}
# The build requirements go into .venv and the build runs there (no isolated environment): the C++
# package installed from build/test by the install test then finds Eigen where the build found it.
.venv/bin/python -c "import tomllib; print('\n'.join(tomllib.load(open('pyproject.toml', 'rb'))['build-system']['requires']))" \
  > .venv/build-requirements.txt
.venv/bin/python -m pip install -q -r .venv/build-requirements.txt
# The package's own dependencies (pyproject's, with the test, dev and docs extras) install beside the C++ build:
# pip's unpacking and byte-compiling fills the build's single-threaded stretches (configure, links, the last
# objects). Then tubempc itself, without dependencies, and pip's check that the two together are consistent.
.venv/bin/python -c "import tomllib; p = tomllib.load(open('pyproject.toml', 'rb'))['project']
print('\n'.join(p['dependencies'] + [d for e in ('test', 'dev', 'docs') for d in p['optional-dependencies'][e]]))" \
  > .venv/requirements.txt
mkdir -p build/test
.venv/bin/python -m pip install -q -r .venv/requirements.txt > build/test/dependencies.log 2>&1 &
deps_pid=$!
.venv/bin/python -m pip install --no-build-isolation --no-deps . \
  --config-settings=build-dir=build/test \
  --config-settings=cmake.define.TUBEMPC_BUILD_TESTS=ON \
  --config-settings=cmake.define.TUBEMPC_INSTALL=ON
deps_rc=0
wait "$deps_pid" || deps_rc=$?
cat build/test/dependencies.log
if [ "$deps_rc" != 0 ]; then echo "installing tubempc's dependencies failed (exit $deps_rc)" >&2; exit 1; fi
.venv/bin/python -m pip check
phase_done install

ctest --test-dir build/test --output-on-failure -j"$(nproc)"
phase_done ctest

bash tools/install_test.sh --build build/test --python .venv/bin/python
phase_done install_test

# The documentation site, warnings as errors; its three tutorials run in it (the third embeds the C++
# core installed from build/test). The lint runs beside it: both are mostly single-threaded, and on two
# cores the pair takes the longer one's time instead of the sum. The lint's output is printed when it ends.
lint_log=build/test/lint.log
TUBEMPC_BUILD_DIR=build/test bash tools/lint.sh > "$lint_log" 2>&1 &
lint_pid=$!
docs_rc=0
TUBEMPC_BUILD_DIR=build/test bash tools/docs.sh || docs_rc=$?
lint_rc=0
wait "$lint_pid" || lint_rc=$?
cat "$lint_log"
if [ "$docs_rc" != 0 ] || [ "$lint_rc" != 0 ]; then
  echo "the documentation site (exit $docs_rc) or the lint (exit $lint_rc) failed" >&2
  exit 1
fi
phase_done docs_and_lint

# pytest on every core (pytest-xdist; a test file stays on one worker, so its module fixtures are built
# once); exit code 5 means "no tests collected": a failure here.
set +e
.venv/bin/python -m pytest -n "$(nproc)" --dist loadfile "$@"
rc=$?
set -e
phase_done pytest
if [ "$rc" = 5 ]; then echo "pytest collected no tests" >&2; exit 1; fi
if [ "$rc" = 0 ]; then
  .venv/bin/python -c "import json, sys; from tubempc.results.machine import machine_info
machine = {**machine_info(), 'command': 'bash tools/test.sh'}
phases = {k: float(v) for k, v in (p.split('=') for p in sys.argv[2:])}
json.dump({'command': 'bash tools/test.sh', 'seconds': float(sys.argv[1]), 'phases_s': phases, 'machine': machine},
          open('build/test/test_command.json', 'w'), indent=1)" "$(( $(date +%s) - start ))" "${phases[@]}"
fi
exit "$rc"
