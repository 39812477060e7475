#!/usr/bin/env bash
# Runs on a GPU machine (NVIDIA driver, as root), in a copy of the checkout with the .gpu/ and
# .gl/ folders that bench/gpu_kit.sh made: bash bench/gpu_run.sh
# 1. the Vulkan C tests (parity with the CPU on every test model, errors, threads) on the GPU;
# 2. bench/bench_vulkan.py with the prebuilt benchmark, which judges the Vulkan backend's goals;
# 3. python3 -m lab.gpu.vulkan_quality dump: every bundled model's sets on both backends (compare
#    them where the package is installed: python -m lab.gpu.vulkan_quality compare).
# DPC_BENCH_ARGS=--quick skips the 1,048,576-point cases. Logs, the test report, the sets and the
# updated docs/performance.md go to $OUT (default build/gpu-out).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-build/gpu-out}
mkdir -p "$out"
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
# The mounted driver's own manifest names the library that this driver version ships; a copy
# elsewhere in the image can name one that is absent (vkCreateInstance: VK_ERROR_INCOMPATIBLE_DRIVER).
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[ -f "$icd" ] && export VK_DRIVER_FILES=${VK_DRIVER_FILES:-$icd}
egl=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
[ -f "$egl" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=${__EGL_VENDOR_LIBRARY_FILENAMES:-$egl}
export LD_LIBRARY_PATH=$PWD/.gpu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export DPC_TEST_DATA_DIR=$PWD/tests/data PYTHONUNBUFFERED=1
{ nvidia-smi -L; echo "Vulkan driver manifests:"
  for f in /usr/share/vulkan/icd.d/* /etc/vulkan/icd.d/* /usr/local/nvidia/share/vulkan/icd.d/*; do
    [ -f "$f" ] && { echo "$f:"; cat "$f"; }; done
  echo "VK_DRIVER_FILES=${VK_DRIVER_FILES:-}"; ldconfig -p | grep -E "libvulkan|libGLX_nvidia|libGLdispatch"
  # The loader's own account of which drivers it found and why one failed, on the smallest model.
  VK_LOADER_DEBUG=error,warn,driver .gpu/dpc_bench_vulkan tests/data/model_2d.onnx vulkan 1 64 2>&1 \
    | grep -iE "error|fail|driver|icd|nvidia|median" | head -40
} 2>&1 | head -c 20000 | tee "$out/gpu.txt"
DPC_ISA= .gpu/dpc_test_vulkan --gtest_output=xml:"$out/test_vulkan.xml" 2>&1 | tee "$out/test_vulkan.log"
tests=${PIPESTATUS[0]}
# The two tests the run above skips, each in a process of its own with the environment that
# simulates a machine without the loader, then one with the loader but no driver (libdpc reads
# the driver choice once per process).
alone() { # gtest filter, then VAR=value ...
  local filter=$1; shift
  env DPC_ISA= "$@" .gpu/dpc_test_vulkan --gtest_filter="$filter" 2>&1 | tee -a "$out/test_vulkan.log"
  [ "${PIPESTATUS[0]}" -eq 0 ] || tests=1
}
alone 'NoVulkanLoader.*' DPC_VULKAN_LOADER=/nonexistent/libvulkan.so.1
alone 'NoVulkanDriver.*' VK_DRIVER_FILES=/nonexistent/no_icd.json VK_ICD_FILENAMES=/nonexistent/no_icd.json
python3 bench/bench_vulkan.py --exe .gpu ${DPC_BENCH_ARGS:-} 2>&1 | tee "$out/bench_vulkan.log"
bench=${PIPESTATUS[0]}
# Every bundled model's sets on both backends, for `python -m lab.gpu.vulkan_quality compare` here.
python3 -m lab.gpu.vulkan_quality dump --lib .gpu/libdpc.so.0 --out "$out/vulkan_sets.npz" 2>&1 | tee "$out/vulkan_quality.log"
[ "${PIPESTATUS[0]}" -eq 0 ] || bench=1
cp docs/performance.md "$out/"
echo "dpc_test_vulkan exit $tests, bench_vulkan.py exit $bench"
[ "$tests" -eq 0 ] && [ "$bench" -eq 0 ]
