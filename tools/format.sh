#!/usr/bin/env bash
# Applies the formatters the lint checks (tools/lint.sh): ruff (fixes and format) and clang-format.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${VENV_BIN:-.venv/bin}
"$BIN/ruff" check --fix python tests/py tools docs
"$BIN/ruff" format python tests/py tools docs
git ls-files 'cpp/*.hpp' 'cpp/*.cpp' 'python/src/*.hpp' 'python/src/*.cpp' 'tests/cpp/*.hpp' 'tests/cpp/*.cpp' \
  'examples/*.cpp' | xargs clang-format -i
