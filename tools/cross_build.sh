#!/usr/bin/env bash
# ARM cross-builds: the core and examples/cpp/closed_loop built for aarch64 and armhf with Debian's cross
# compilers (cmake/toolchains/*.cmake; -ffp-contract=off), flown under qemu-user on the default scenario and
# bennu-tag-nav (both methods), each final state compared with the x86-64 build's: equal within 1e-9
# relative (of each component, against max(|x|, 1)), 0 heap allocations per step (the example exits 1
# otherwise). Debian packages: g++-aarch64-linux-gnu, g++-arm-linux-gnueabihf, qemu-user (installed when
# missing and root).
#   bash tools/cross_build.sh [--host-example PATH] [aarch64] [armhf]
# The host example defaults to the newest build/*/examples/cpp/closed_loop/closed_loop; the scenarios are
# exported by the package in .venv (or PYTHON).
set -euo pipefail
cd "$(dirname "$0")/.."
py=${PYTHON:-.venv/bin/python}
host=""
arches=()
while [ $# -gt 0 ]; do
  case "$1" in
    --host-example) host=$2; shift 2 ;;
    aarch64 | armhf) arches+=("$1"); shift ;;
    *) echo "usage: $0 [--host-example PATH] [aarch64] [armhf]" >&2; exit 2 ;;
  esac
done
[ ${#arches[@]} -gt 0 ] || arches=(aarch64 armhf)
[ -n "$host" ] || host=$(ls -t build/*/examples/cpp/closed_loop/closed_loop 2> /dev/null | grep -v -e build/aarch64 -e build/armhf | head -1)
[ -x "$host" ] || { echo "cross_build: no host closed_loop (build with TUBEMPC_BUILD_EXAMPLES=ON)" >&2; exit 2; }

declare -A triple=([aarch64]=aarch64-linux-gnu [armhf]=arm-linux-gnueabihf)
declare -A qemu=([aarch64]=qemu-aarch64 [armhf]=qemu-arm)
missing=()
for a in "${arches[@]}"; do
  command -v "${triple[$a]}-g++" > /dev/null || missing+=("g++-${triple[$a]}")
  command -v "${qemu[$a]}" > /dev/null || missing+=(qemu-user)
done
if [ ${#missing[@]} -gt 0 ]; then
  [ "$(id -u)" = 0 ] || { echo "cross_build: missing ${missing[*]}" >&2; exit 1; }
  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q $(printf '%s\n' "${missing[@]}" | sort -u)
fi

eigen_dir=$("$py" -c "import glob, sys, os; print(next(iter(glob.glob(os.path.join(sys.prefix, 'lib/python*/site-packages/cmeel.prefix/share/eigen3/cmake'))), ''))")
piqp_dir=$(dirname "$(find build -path '*/_deps/piqp-*/install/lib/cmake/piqp/piqpConfig.cmake' | head -1)")
out=build/cross
mkdir -p "$out"
for s in bennu-paper bennu-tag-nav; do
  [ -f "$out/$s/scenario.txt" ] || "$py" -m tubempc export-scenario --scenario "$s" --out "$out/$s" --cache-dir "$out/cache"
  "$host" "$out/$s/scenario.txt" --json "$out/$s/x86_64.json" > /dev/null
done
for a in "${arches[@]}"; do
  cmake -S . -B "build/$a" -G Ninja --toolchain "cmake/toolchains/$a-linux-gnu.cmake" -DTUBEMPC_BUILD_PYTHON=OFF \
    -DTUBEMPC_BUILD_TESTS=OFF -DTUBEMPC_BUILD_EXAMPLES=ON -DTUBEMPC_INSTALL=OFF ${eigen_dir:+-DEigen3_DIR="$eigen_dir"} \
    ${piqp_dir:+-Dpiqp_DIR="$piqp_dir"} > "$out/$a.configure.log"
  cmake --build "build/$a" --target closed_loop
  for s in bennu-paper bennu-tag-nav; do
    "${qemu[$a]}" -L "/usr/${triple[$a]}" "build/$a/examples/cpp/closed_loop/closed_loop" "$out/$s/scenario.txt" \
      --json "$out/$s/$a.json" > "$out/$s/$a.log"
    "$py" - "$out/$s/x86_64.json" "$out/$s/$a.json" "$a" "$s" << 'EOF'
import json, sys
ref, arm = (json.load(open(p))["methods"] for p in sys.argv[1:3])
worst = 0.0
for m in ref:
    for x, y in zip(ref[m]["final_state"], arm[m]["final_state"]):
        worst = max(worst, abs(x - y) / max(abs(x), 1.0))
    assert arm[m]["allocations_controller"] == arm[m]["allocations_navigation"] == arm[m]["allocations_actuation"] == 0
print(f"{sys.argv[3]} {sys.argv[4]}: final states within {worst:.1e} relative of x86-64's, 0 allocations per step")
sys.exit(0 if worst <= 1e-9 else 1)
EOF
  done
done
