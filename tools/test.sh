#!/usr/bin/env bash
# The test command (README): installs tubempc with its C++ test suite into .venv, then runs ctest
# (GoogleTest and the C++ examples), the install test (tools/install_test.sh: the core installed into a
# temporary prefix, both C++ examples built against it, closed_loop flying a scenario exported by the
# installed package) and pytest. One build tree serves ctest and pytest: build/test.
set -euo pipefail
cd "$(dirname "$0")/.."

missing=()
[ -f /usr/include/gtest/gtest.h ] || missing+=(libgtest-dev)
command -v doxygen > /dev/null || missing+=(doxygen)
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing Debian's ${missing[*]} (GoogleTest for ctest, Doxygen for the header documentation check)"
  if [ "$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi
  $SUDO apt-get update -q && DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q "${missing[@]}"
fi

PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip
export CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-$(nproc)}
.venv/bin/python -m pip install ".[test]" \
  --config-settings=build-dir=build/test \
  --config-settings=cmake.define.TUBEMPC_BUILD_TESTS=ON

ctest --test-dir build/test --output-on-failure -j"$(nproc)"

# The install test configures the core outside pip's (by now removed) isolated build environment: it
# needs pyproject.toml's build requirements (Eigen from cmeel-eigen; scikit-build-core for PIQP's sdist).
.venv/bin/python -c "import tomllib; print('\n'.join(tomllib.load(open('pyproject.toml', 'rb'))['build-system']['requires']))" \
  > build/test/build-requirements.txt
.venv/bin/python -m pip install -q -r build/test/build-requirements.txt
PYTHON=.venv/bin/python bash tools/install_test.sh --python .venv/bin/python

# pytest exit code 5 means "no tests collected": a failure here.
set +e
.venv/bin/python -m pytest "$@"
rc=$?
set -e
if [ "$rc" = 5 ]; then echo "pytest collected no tests" >&2; exit 1; fi
exit "$rc"
