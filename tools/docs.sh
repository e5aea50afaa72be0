#!/usr/bin/env bash
# Builds the documentation site into build/docs/html with Sphinx, warnings as errors (docs/conf.py):
# the model (docs/model.md), the three tutorials (docs/tutorials, executed), the Python API from the
# docstrings, the Doxygen C++ reference, the design decisions and the benchmarks. Needs the docs extra
# (pip install ".[docs]"), Doxygen, and for the third tutorial a build tree with the C++ package
# (TUBEMPC_BUILD_DIR, default build/test: the test command's). PYTHON names another interpreter.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
rm -rf build/docs/html docs/auto_tutorials docs/sg_execution_times.rst
"$PY" -m sphinx -W --keep-going -q -b html docs build/docs/html
echo "documentation in build/docs/html/index.html"
