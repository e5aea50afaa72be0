#!/usr/bin/env bash
# Static analysis of the C++ core (cpp/); fails on any finding. The lint (tools/lint.sh) runs its cppcheck part
# (--cppcheck-only, seconds); clang-tidy (11 CPU minutes cold) is run by hand before a release, like
# tools/sanitize.sh: with it the test command would not fit its 15 minutes.
#   clang-tidy with the checks of .clang-tidy (bugprone-*, performance-*, a named subset of
#     cppcoreguidelines-*; the disabled ones with their reasons there), on every source of cpp/src with the
#     flags of compile_commands.json, headers of cpp/ included (HeaderFilterRegex); a translation unit whose
#     inputs (its command, its file, every header of cpp/, .clang-tidy, clang-tidy's version) passed once is
#     not analysed again (a stamp in <build dir>/clang-tidy-passed/);
#   cppcheck (Debian's) on cpp/src and cpp/include, categories warning, performance and portability (and its
#     errors, always on); style is left out: its findings here are preferences (useStlAlgorithm,
#     shadowFunction) and false positives on Eigen outputs written through operator() (constParameter,
#     unreadVariable).
# The build directory: TUBEMPC_BUILD_DIR, else the newest build/*/ with compile_commands.json, else a
# configure-only build/lint (nothing is compiled).
set -euo pipefail
cd "$(dirname "$0")/.."
cppcheck_only=0
[ "${1:-}" = "--cppcheck-only" ] && cppcheck_only=1
for tool in clang-tidy cppcheck; do
  [ "$cppcheck_only" = 1 ] && [ "$tool" = clang-tidy ] && continue
  command -v "$tool" > /dev/null || { echo "cpp_analysis: $tool not found (Debian: apt-get install $tool)" >&2; exit 1; }
done

run_cppcheck() {
  cppcheck --std=c++17 --language=c++ -I cpp/include --enable=warning,performance,portability --inline-suppr \
    --suppress=missingIncludeSystem --error-exitcode=1 -q -j "$(nproc)" cpp/src cpp/include
}
if [ "$cppcheck_only" = 1 ]; then
  run_cppcheck
  echo "cpp_analysis: cppcheck found nothing"
  exit 0
fi

build=${TUBEMPC_BUILD_DIR:-}
if [ -z "$build" ]; then
  build=$(ls -td build/*/ 2> /dev/null | while read -r d; do [ -f "$d/compile_commands.json" ] && echo "${d%/}" && break; done || true)
fi
if [ -z "$build" ] || [ ! -f "$build/compile_commands.json" ]; then
  build=build/lint
  py=${PYTHON:-.venv/bin/python}
  cmake -S . -B "$build" -DTUBEMPC_BUILD_PYTHON=OFF -DTUBEMPC_BUILD_TESTS=OFF -DTUBEMPC_BUILD_EXAMPLES=OFF \
    -DPython_EXECUTABLE="$(command -v "$py" || command -v python3)" > "$build.configure.log" 2>&1 ||
    { cat "$build.configure.log" >&2; exit 1; }
fi
echo "cpp_analysis: compile commands of $build"

# ---- clang-tidy ------------------------------------------------------------------------------------
stamps="$build/clang-tidy-passed"
mkdir -p "$stamps"
common=$( (clang-tidy --version; cat .clang-tidy; git ls-files 'cpp/*.hpp' | xargs cat) | sha256sum | cut -c1-64)
todo=()
while IFS= read -r src; do
  cmd=$(python3 -c "import json, sys; print(next(e['command'] for e in json.load(open(sys.argv[1])) if e['file'].endswith('/' + sys.argv[2])))" \
    "$build/compile_commands.json" "$src")
  key=$( (echo "$common"; echo "$cmd"; cat "$src") | sha256sum | cut -c1-64)
  [ -f "$stamps/$key" ] || todo+=("$src:$key")
done < <(git ls-files 'cpp/src/*.cpp')
echo "cpp_analysis: clang-tidy on ${#todo[@]} translation unit(s) (the others passed with the same inputs)"
if [ ${#todo[@]} -gt 0 ]; then
  printf '%s\n' "${todo[@]}" | xargs -P "$(nproc)" -I{} bash -c '
    src=${1%%:*}; key=${1##*:}
    if out=$(clang-tidy -p "$2" --quiet "$src" 2>&1); then touch "$3/$key"; else echo "$out"; exit 1; fi' _ {} "$build" "$stamps"
fi

# ---- cppcheck --------------------------------------------------------------------------------------
run_cppcheck
echo "cpp_analysis: clang-tidy and cppcheck found nothing"
