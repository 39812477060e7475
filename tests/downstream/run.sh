#!/usr/bin/env bash
# Builds libdpc C-only (the C++ compiler is set to a path that does not exist, so configuring
# fails if anything needs C++), installs it into a fresh prefix, then builds and runs a
# separate downstream project against it:
# with find_package(dpc CONFIG) (dpc::dpc and dpc::dpc_static), with pkg-config (shared, and
# static), again after moving the whole prefix elsewhere, a static libdpc installed with
# --prefix elsewhere than configured, and with add_subdirectory of the checkout; last, the build line written in libdpc/examples/generate.c, exactly as written.
#   bash tests/downstream/run.sh            # about a minute on 2 cores
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
WORK=$(mktemp -d /tmp/dpc-downstream.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
GEN=(); command -v ninja >/dev/null && GEN=(-G Ninja)
step() { printf -- '-- %s\n' "$*"; }
quiet() { "$@" >"$WORK/log" 2>&1 || { cat "$WORK/log"; echo "failed: $*"; exit 1; }; }
check() { # expected-substring command...
  local want=$1; shift
  local out; out=$("$@")
  echo "   $out"
  [[ $out == *"$want"* ]] || { echo "expected '$want'"; exit 1; }
}

step "libdpc, C only (CMAKE_CXX_COMPILER=/nonexistent/c++), installed to a fresh prefix"
quiet cmake -S "$ROOT" -B "$WORK/build" "${GEN[@]}" -DCMAKE_BUILD_TYPE=Release -DDPC_BUILD_PYTHON=OFF \
      -DCMAKE_CXX_COMPILER=/nonexistent/c++ -DCMAKE_INSTALL_PREFIX="$WORK/prefix"
quiet cmake --build "$WORK/build" -j "$(nproc)"
quiet cmake --install "$WORK/build"
LIBDIR=$(ls -d "$WORK/prefix"/lib*/ | head -1); LIBDIR=${LIBDIR%/}
for f in include/dpc/dpc.h include/dpc/dpc_sampler.h include/dpc/dpc_mask.h include/dpc/dpc_layer.h share/dpc/models/bnot-2d.onnx share/dpc/models/bnot-2d-stratified.onnx; do
  [ -f "$WORK/prefix/$f" ] || { echo "missing $f"; exit 1; }
done
for f in libdpc.so libdpc.a pkgconfig/dpc.pc cmake/dpc/dpcConfig.cmake cmake/dpc/dpcConfigVersion.cmake \
         cmake/dpc/dpcTargets.cmake; do
  [ -e "$LIBDIR/$f" ] || { echo "missing $LIBDIR/$f"; exit 1; }
done
echo "   installed: $(cd "$WORK/prefix" && find . -type f | sort | sed 's|^\./||' | grep -v '\.onnx$' | tr '\n' ' ')"
echo "   models: $(ls "$WORK/prefix/share/dpc/models" | grep -c '\.onnx$') .onnx files in share/dpc/models"

step "downstream project, find_package(dpc CONFIG)"
quiet cmake -S "$ROOT/tests/downstream" -B "$WORK/fp" "${GEN[@]}" -DDPC_DOWNSTREAM_MODE=find_package \
      -DCMAKE_PREFIX_PATH="$WORK/prefix" -DCMAKE_CXX_COMPILER=/nonexistent/c++
grep '^-- dpc 0' "$WORK/log" | sed 's/^/   /'
quiet cmake --build "$WORK/fp"
check "bnot-2d: 1024 points in 2-D" "$WORK/fp/use_shared"
check "bnot-2d: 1024 points in 2-D" "$WORK/fp/use_static"
ldd "$WORK/fp/use_static" | grep -q libdpc && { echo "use_static links libdpc.so"; exit 1; }
ldd "$WORK/fp/use_shared" | grep -q "$LIBDIR/libdpc.so" || { echo "use_shared does not use the installed libdpc.so"; exit 1; }

step "downstream program, pkg-config"
export PKG_CONFIG_PATH="$LIBDIR/pkgconfig"
echo "   pkg-config --modversion dpc: $(pkg-config --modversion dpc); modeldir: $(pkg-config --variable=modeldir dpc)"
# shellcheck disable=SC2046
cc -std=c11 "$ROOT/tests/downstream/main.c" $(pkg-config --cflags dpc) $(pkg-config --libs dpc) \
   -Wl,-rpath,"$(pkg-config --variable=libdir dpc)" -o "$WORK/pc_shared"
check "bnot-2d: 1024 points in 2-D" "$WORK/pc_shared" bnot-2d
# shellcheck disable=SC2046
cc -std=c11 "$ROOT/tests/downstream/main.c" $(pkg-config --cflags dpc) -L"$(pkg-config --variable=libdir dpc)" \
   -Wl,-Bstatic -ldpc -Wl,-Bdynamic $(pkg-config --static --libs dpc | tr ' ' '\n' | grep -v -e '^-ldpc$' -e '^-L') \
   -o "$WORK/pc_static"
check "bnot-2d-stratified: 1024 points in 2-D" "$WORK/pc_static" bnot-2d-stratified
ldd "$WORK/pc_static" | grep -q libdpc && { echo "pc_static links libdpc.so"; exit 1; }
DPC_MODEL_PATH="$ROOT/tests/data" check "points in 3-D" "$WORK/pc_shared" model_3d_proj

step "the whole prefix moved elsewhere: pkg-config and (shared library) dpc_model_dir() follow it"
mv "$WORK/prefix" "$WORK/moved"
export PKG_CONFIG_PATH="$WORK/moved/${LIBDIR#"$WORK/prefix/"}/pkgconfig"
# shellcheck disable=SC2046
cc -std=c11 "$ROOT/tests/downstream/main.c" $(pkg-config --cflags --libs dpc) \
   -Wl,-rpath,"$(pkg-config --variable=libdir dpc)" -o "$WORK/pc_moved"
check "models in $(cd "$WORK/moved/share/dpc/models" && pwd -P)" "$WORK/pc_moved" bnot-2d
mv "$WORK/moved" "$WORK/prefix"

step "static libdpc: finds models by name under the prefix it was configured with, not one given to cmake --install"
# The static programs above were configured with -DCMAKE_INSTALL_PREFIX=the prefix they were
# installed to (use_static, pc_static: found by name). A second install of the same build with
# --prefix: its static programs look where the build was configured (dpc.h, dpc_model_dir), so
# with that folder gone they need DPC_MODEL_PATH, or the model by path from the CMake package's
# DPC_MODEL_DIR (README, "Linking statically").
quiet cmake --install "$WORK/build" --prefix "$WORK/other"
quiet cmake -S "$ROOT/tests/downstream" -B "$WORK/fp-other" "${GEN[@]}" -DDPC_DOWNSTREAM_MODE=find_package \
      -DCMAKE_PREFIX_PATH="$WORK/other" -DCMAKE_CXX_COMPILER=/nonexistent/c++ -DDPC_DOWNSTREAM_CHECK_MODEL_DIR=OFF
quiet cmake --build "$WORK/fp-other" --target use_static use_static_model_dir
mv "$WORK/prefix" "$WORK/moved"
if out=$("$WORK/fp-other/use_static" bnot-2d 2>&1); then
  echo "a static libdpc installed with --prefix found models without the configured prefix: $out"; exit 1
fi
echo "   by name, configured prefix gone: fails as documented: ${out:0:160}"
DPC_MODEL_PATH="$WORK/other/share/dpc/models" check "bnot-2d: 1024 points in 2-D" "$WORK/fp-other/use_static" bnot-2d
check "bnot-2d: 1024 points in 2-D" "$WORK/fp-other/use_static_model_dir" bnot-2d
mv "$WORK/moved" "$WORK/prefix"
check "bnot-2d: 1024 points in 2-D" "$WORK/fp-other/use_static" bnot-2d

step "downstream project, add_subdirectory(dpc checkout)"
quiet cmake -S "$ROOT/tests/downstream" -B "$WORK/sub" "${GEN[@]}" -DDPC_DOWNSTREAM_MODE=add_subdirectory \
      -DDPC_SOURCE_DIR="$ROOT" -DCMAKE_CXX_COMPILER=/nonexistent/c++
quiet cmake --build "$WORK/sub"
DPC_MODEL_PATH="$ROOT/models" check "bnot-2d: 1024 points in 2-D" "$WORK/sub/use_shared"
DPC_MODEL_PATH="$ROOT/models" check "bnot-2d: 1024 points in 2-D" "$WORK/sub/use_static"

step "the build line of libdpc/examples/generate.c, as written there"
line=$(sed -n 's/^ \*   \(cc .*\)$/\1/p' "$ROOT/libdpc/examples/generate.c")
[ -n "$line" ] || { echo "no build line in generate.c"; exit 1; }
mkdir -p "$WORK/example/build"
ln -s "$ROOT/libdpc" "$WORK/example/libdpc"
ln -s "$ROOT/models" "$WORK/example/models"
ln -s "$WORK/build/libdpc" "$WORK/example/build/libdpc"   # what `cmake --build build` made
echo "   \$ $line"
(cd "$WORK/example" && check "repulsion-2d: 1024 points in 2-D, 40 layers" bash -c "$line")

echo "downstream: all passed"
