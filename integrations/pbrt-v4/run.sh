#!/usr/bin/env bash
# dpc's sampler in pbrt-v4, end to end (README.md beside this file):
#   bash integrations/pbrt-v4/run.sh PBRT_SRC [BUILD_DIR]
# PBRT_SRC: a pbrt-v4 source tree with its submodules (it is patched in place by apply.py).
# BUILD_DIR (default PBRT_SRC-dpc): dpc-build/ and dpc-prefix/ (libdpc built and installed),
# build/ (pbrt with -DPBRT_DPC=ON: pbrt, imgtool, pbrt_test) and smoke/ (the renders).
# Steps: libdpc; apply.py; configure and build pbrt; the smoke scene (scenes/) with "dpc" at
# --nthreads 1 and 2, also with --wavefront (each pair the same pixels, byte for byte), and with
# "independent" (check_smoke.py: dpc's mean within noise of a 1024-spp reference); an unknown
# model (pbrt's error, libdpc's message); pbrt_test's sampler tests and its analytic-scene tests
# of dpc. Any failure exits nonzero. JOBS (default 2) sets the build's parallelism.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
if [ $# -lt 1 ] || [ ! -f "$1/src/pbrt/samplers.cpp" ]; then
  echo "usage: bash $0 PBRT_SRC [BUILD_DIR]  (PBRT_SRC: a pbrt-v4 source tree)" >&2
  exit 2
fi
PBRT_SRC=$(cd "$1" && pwd)
BUILD_DIR=${2:-$PBRT_SRC-dpc}
mkdir -p "$BUILD_DIR"
BUILD_DIR=$(cd "$BUILD_DIR" && pwd)
JOBS=${JOBS:-2}
NICE="nice -n 10"
GEN=()
if command -v ninja >/dev/null; then GEN=(-G Ninja); fi
step() { printf '\n==== [%d s] %s\n' "$SECONDS" "$*"; }
python3 -c "import numpy" 2>/dev/null || { echo "the smoke check needs numpy (pip install numpy)" >&2; exit 2; }

step "libdpc: build, install to $BUILD_DIR/dpc-prefix"
cmake -S "$ROOT" -B "$BUILD_DIR/dpc-build" "${GEN[@]}" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_INSTALL_PREFIX="$BUILD_DIR/dpc-prefix" >/dev/null
$NICE cmake --build "$BUILD_DIR/dpc-build" -j "$JOBS"
cmake --install "$BUILD_DIR/dpc-build" >/dev/null

step "apply the integration to $PBRT_SRC"
python3 "$HERE/apply.py" "$PBRT_SRC"

step "pbrt-v4 with -DPBRT_DPC=ON: configure, build pbrt, imgtool, pbrt_test in $BUILD_DIR/build"
cmake -S "$PBRT_SRC" -B "$BUILD_DIR/build" "${GEN[@]}" -DCMAKE_BUILD_TYPE=Release -DPBRT_DPC=ON \
      -DCMAKE_PREFIX_PATH="$BUILD_DIR/dpc-prefix" -DCMAKE_POLICY_VERSION_MINIMUM=3.5 -DBUILD_TESTING=OFF \
      -DGLFW_BUILD_WAYLAND=OFF >"$BUILD_DIR/pbrt-configure.log" \
  || { tail -30 "$BUILD_DIR/pbrt-configure.log"; exit 1; }
grep 'Sampler "dpc" enabled' "$BUILD_DIR/pbrt-configure.log"
$NICE cmake --build "$BUILD_DIR/build" -j "$JOBS" --target pbrt_exe imgtool pbrt_test
PBRT=$BUILD_DIR/build/pbrt
IMGTOOL=$BUILD_DIR/build/imgtool

step "smoke scene: dpc (1 and 2 threads, also --wavefront), independent (two seeds), reference (independent, 1024 spp)"
OUT=$BUILD_DIR/smoke
mkdir -p "$OUT"
render() { # name, then pbrt's arguments
  local name=$1; shift
  local t0; t0=$(date +%s.%N)
  $NICE "$PBRT" --quiet --outfile "$OUT/$name.exr" "$@"
  awk -v a="$t0" -v b="$(date +%s.%N)" -v n="$name" 'BEGIN { printf "%s: %.1f s\n", n, b - a }'
  "$IMGTOOL" convert --outfile "$OUT/$name.pfm" "$OUT/$name.exr"
}
render dpc --nthreads 2 "$HERE/scenes/smoke-dpc.pbrt"
render dpc-1thread --nthreads 1 "$HERE/scenes/smoke-dpc.pbrt"
render dpc-wavefront --wavefront --nthreads 2 "$HERE/scenes/smoke-dpc.pbrt"
render dpc-wavefront-1thread --wavefront --nthreads 1 "$HERE/scenes/smoke-dpc.pbrt"
render independent-0 --nthreads 2 --seed 0 "$HERE/scenes/smoke-independent.pbrt"
render independent-1 --nthreads 2 --seed 1 "$HERE/scenes/smoke-independent.pbrt"
render reference --nthreads 2 --seed 2 --spp 1024 "$HERE/scenes/smoke-independent.pbrt"
# the EXR's header holds the render time, so the pixels are compared (PFM: nothing but pixels)
for mode in dpc dpc-wavefront; do
  if cmp "$OUT/$mode.pfm" "$OUT/$mode-1thread.pfm"; then
    echo "$mode, --nthreads 1 and --nthreads 2: the same pixels ($(stat -c %s "$OUT/$mode.pfm") bytes of PFM)"
  else
    echo "$mode: the image differs between --nthreads 1 and --nthreads 2"; exit 1
  fi
done
python3 "$HERE/check_smoke.py" "$OUT"
# a bad model is pbrt's ErrorExit with libdpc's message
sed -e 's/"bnot-2d-stratified"/"no-such-model"/' -e "s#Include \"smoke.pbrt\"#Include \"$HERE/scenes/smoke.pbrt\"#" \
  "$HERE/scenes/smoke-dpc.pbrt" >"$OUT/bad.pbrt"
if "$PBRT" --quiet --outfile "$OUT/bad.exr" "$OUT/bad.pbrt" >"$OUT/bad.log" 2>&1; then
  echo "pbrt accepted an unknown model"; exit 1
fi
grep 'dpc sampler: model "no-such-model"' "$OUT/bad.log"

step "pbrt_test: the sampler tests (dpc in Sampler.ConsistentValues, DPCSampler.ElementaryIntervals)"
cd "$BUILD_DIR/build"
./pbrt_test --test-filter='Sampler.*:*ElementaryIntervals*' 2>&1 | tee "$BUILD_DIR/pbrt_test-samplers.log" | tail -5
grep -q '^\[  PASSED  \] [1-9]' "$BUILD_DIR/pbrt_test-samplers.log" && ! grep -q FAILED "$BUILD_DIR/pbrt_test-samplers.log" \
  || { echo "pbrt_test's sampler tests failed"; exit 1; }
grep -q '^\[       OK \] DPCSampler.ElementaryIntervals' "$BUILD_DIR/pbrt_test-samplers.log" \
  || { echo "DPCSampler.ElementaryIntervals did not run"; exit 1; }

step "pbrt_test: the analytic scenes rendered with dpc (AnalyticTestScenes, the dpc entries)"
DPC_CASES=$(./pbrt_test --list-tests --test-filter='AnalyticTestScenes/*' \
  | awk '/RadianceMatches\/[0-9]+ .*, dpc, / {print "AnalyticTestScenes/RenderTest." $1}' | paste -sd: -)
[ -n "$DPC_CASES" ] || { echo "no analytic-scene test uses dpc"; exit 1; }
$NICE ./pbrt_test --nthreads "$JOBS" --test-filter="$DPC_CASES" 2>&1 | tee "$BUILD_DIR/pbrt_test-analytic.log" | tail -5
grep -q '^\[  PASSED  \] [1-9]' "$BUILD_DIR/pbrt_test-analytic.log" && ! grep -q FAILED "$BUILD_DIR/pbrt_test-analytic.log" \
  || { echo "pbrt_test's analytic scenes with dpc failed"; exit 1; }

step "done: $PBRT"
