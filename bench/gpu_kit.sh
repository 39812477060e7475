#!/usr/bin/env bash
# Prepares, on a machine with the build tools, what bench/gpu_run.sh needs on a GPU machine that
# has no Vulkan headers, GoogleTest or package registry:
#   .gpu/  a Release build with the Vulkan backend: libdpc.so.0, dpc_bench_vulkan, dpc_test_vulkan;
#   .gl/   the Vulkan loader (libvulkan1) and GLVND (libglvnd0 and its GL/EGL front ends, which the
#          NVIDIA driver's Vulkan library links against) as Debian packages, unpacked there by
#          gpu_run.sh.
# Both folders are git-ignored. Copy the checkout with .gpu/ and .gl/ to the GPU machine and run
# `bash bench/gpu_run.sh` there (as root: it unpacks .gl/ into /).
# Needs what tests/run_all.sh installs (GoogleTest, libvulkan-dev).
set -euo pipefail
cd "$(dirname "$0")/.."
build=build/gpu-kit
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDPC_VULKAN=ON -DDPC_BUILD_TESTS=ON \
      -DDPC_BUILD_BENCH=ON -DDPC_BUILD_PYTHON=OFF >/dev/null
cmake --build "$build" --target dpc_bench_vulkan dpc_test_vulkan >/dev/null
rm -rf .gpu && mkdir .gpu
cp -L "$build/libdpc/libdpc.so.0" "$build/bench/dpc_bench_vulkan" "$build/tests/c/dpc_test_vulkan" .gpu/
if ! ls .gl/libvulkan1_*.deb .gl/libglvnd0_*.deb >/dev/null 2>&1; then
  # Package lists of their own (amd64 only), so this machine's apt state is untouched.
  lists=$(mktemp -d)
  mkdir -p .gl "$lists/partial"
  o="-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=$lists"
  apt-get $o update >/dev/null
  (cd .gl && apt-get $o download libvulkan1 libglvnd0 libgl1 libglx0 libegl1 libopengl0 libgles2 >/dev/null)
  rm -rf "$lists"
fi
du -sh .gpu .gl
