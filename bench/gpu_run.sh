#!/usr/bin/env bash
# Runs on a GPU machine lent through the device tool, after bench/gpu_kit.sh here:
#   run(command="bash bench/gpu_run.sh", carry=[".gpu", ".gl"], timeout_s=600)
# 1. the Vulkan C tests (parity with the CPU on every test model, errors, threads) on the GPU;
# 2. bench/bench_vulkan.py with the prebuilt benchmark, which judges issue 6's goals.
# DPC_BENCH_ARGS=--quick skips the 1,048,576-point cases. Logs, the test report and the updated docs/performance.md come back in $OUT.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${OUT:-build/gpu-out}  # $OUT: the device tool's folder that comes back
mkdir -p "$out"
for f in .gl/*.deb; do dpkg -x "$f" /; done
ldconfig
icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
if [ -f "$icd" ] && ! grep -qls nvidia /usr/share/vulkan/icd.d/* /etc/vulkan/icd.d/* 2>/dev/null; then
  export VK_DRIVER_FILES=$icd  # the driver's manifest is outside the loader's search path
fi
{ nvidia-smi -L; echo "Vulkan driver manifests:"; ls /usr/share/vulkan/icd.d /etc/vulkan/icd.d \
    /usr/local/nvidia/share/vulkan/icd.d; echo "VK_DRIVER_FILES=${VK_DRIVER_FILES:-}"; } 2>&1 | tee "$out/gpu.txt"
export LD_LIBRARY_PATH=$PWD/.gpu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export DPC_TEST_DATA_DIR=$PWD/tests/data PYTHONUNBUFFERED=1
DPC_ISA= .gpu/dpc_test_vulkan --gtest_output=xml:"$out/test_vulkan.xml" 2>&1 | tee "$out/test_vulkan.log"
tests=${PIPESTATUS[0]}
# A machine without the loader, simulated (the one test the run above skips).
DPC_ISA= DPC_VULKAN_LOADER=/nonexistent/libvulkan.so.1 .gpu/dpc_test_vulkan --gtest_filter='NoVulkanLoader.*' \
  2>&1 | tee -a "$out/test_vulkan.log"
[ "${PIPESTATUS[0]}" -eq 0 ] || tests=1
python3 bench/bench_vulkan.py --exe .gpu ${DPC_BENCH_ARGS:-} 2>&1 | tee "$out/bench_vulkan.log"
bench=${PIPESTATUS[0]}
cp docs/performance.md "$out/"
echo "dpc_test_vulkan exit $tests, bench_vulkan.py exit $bench"
[ "$tests" -eq 0 ] && [ "$bench" -eq 0 ]
