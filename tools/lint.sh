#!/usr/bin/env bash
# The lint of the test command: fails on any finding. tools/format.sh applies the formatters.
#   ruff check and ruff format --check (pyproject.toml), mypy --strict (pyproject.toml),
#   clang-format --dry-run -Werror (.clang-format) on the C++ sources, headers, bindings, tests and examples,
#   tools/check_stubs.py: the stubs python/tubempc/_*.pyi declare what the built tubempc._core binds,
#   and cppcheck on cpp/ (tools/cpp_analysis.sh --cppcheck-only; its clang-tidy part is run by hand before a release).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${VENV_BIN:-.venv/bin}
"$BIN/ruff" check python tests/py tools docs
"$BIN/ruff" format --check python tests/py tools docs
"$BIN/mypy"
git ls-files 'cpp/*.hpp' 'cpp/*.cpp' 'python/src/*.hpp' 'python/src/*.cpp' 'tests/cpp/*.hpp' 'tests/cpp/*.cpp' \
  'examples/*.cpp' | xargs clang-format --dry-run -Werror
"$BIN/python" tools/check_stubs.py
bash tools/cpp_analysis.sh --cppcheck-only
echo "lint passed"
