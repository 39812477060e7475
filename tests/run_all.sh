#!/usr/bin/env bash
# Runs every dpc test suite on a fresh Debian 12 machine, installing what it needs first.
#   bash tests/run_all.sh            # everything (about 20 minutes on 2 cores)
#   DPC_FUZZ_SECONDS=10 bash tests/run_all.sh   # shorter fuzzing
# Suites: the formatters' checks (clang-format over the C/C++ sources, ruff check and ruff
# format over the Python files; tests/format_files.sh lists them), C tests (GoogleTest via ctest)
# under ASan+UBSan in a build with the Vulkan backend (without a driver, then on lavapipe, Mesa's
# CPU Vulkan driver), its Vulkan tests under the Khronos validation layer (synchronization
# validation), the thread tests under TSan, a Release build's ctest (every ISA path the CPU has),
# the reader fuzzer (libFuzzer), libdpc as another project's dependency (tests/downstream/run.sh:
# install, find_package, pkg-config, add_subdirectory), the wheel in a clean virtual environment
# (with the train extra: dpc-train and dpc-export), and pytest against the pip-installed package
# (built with the Vulkan backend; all but the tests marked slow; it also runs the README's and the
# docs' code blocks: shell, Python, and C compiled by gcc and clang). Any
# failure, or a suite that runs no test, fails the script.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
JOBS=$(nproc)
FUZZ_SECONDS=${DPC_FUZZ_SECONDS:-30}

# Each step prints the seconds since the script began (CI must stay well under its 90 minutes).
step() { printf '\n==== [%d s] %s\n' "$SECONDS" "$*"; }

step "system packages"
# mesa-vulkan-drivers (lavapipe), libvulkan-dev (headers, loader), glslc, vulkan-validationlayers:
# the Vulkan backend's tests.
APT_PKGS="libgtest-dev clang libclang-rt-14-dev cmake ninja-build mesa-vulkan-drivers libvulkan-dev glslc vulkan-validationlayers"
# pkg-config, python3-venv: libdpc as a dependency of another project, the wheel in a clean venv.
APT_PKGS="$APT_PKGS pkg-config python3-venv unzip"
# clang-format (14 on Debian 12, the version the tree is formatted with): the format check.
APT_PKGS="$APT_PKGS clang-format"
missing=$(for p in $APT_PKGS; do dpkg -s "$p" >/dev/null 2>&1 || echo "$p"; done)
if [ -n "$missing" ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $missing >/dev/null
fi

step "python packages"
# torch first and pinned to the version the tests ran with, from pip's configured indexes: on
# this project's machines that is the CPU build of 2.13.0 (on the image's disk); from PyPI alone
# it is the CUDA build on Linux (several GB; it runs the tests on the CPU just the same). The CPU
# build elsewhere: README, "torch, CPU build". No other host is contacted.
TORCH=torch==2.13.0
install_torch() { # python
  "$1" -m pip install -q --disable-pip-version-check "$TORCH"
  "$1" -c "import torch; print('torch', torch.__version__, 'CUDA build' if torch.version.cuda else 'CPU build')"
}
install_torch python3
python3 -m pip install -q --disable-pip-version-check scikit-build-core pybind11 ninja cmake
# ruff pinned: another version may format differently (the format check below). lizard and
# pylint: the duplicate-code check of tests/python/test_repo_rules.py (pinned: another version
# may find other pairs); pytest runs that file before the package is built.
python3 -m pip install -q --disable-pip-version-check ruff==0.17.6 lizard==1.24.3 pylint==4.1.4 "pytest>=7"

step "formatting: clang-format (C/C++), ruff check and ruff format (Python), the repository's rules"
# Exactly the files tests/format_files.sh lists (C/C++: libdpc/, bindings/, tests/, python/,
# training/, bench/; Python: every file but generated ones). To fix: clang-format -i / ruff format.
mapfile -t C_FILES < <(bash tests/format_files.sh c)
mapfile -t PY_FILES < <(bash tests/format_files.sh py)
[ "${#C_FILES[@]}" -gt 40 ] && [ "${#PY_FILES[@]}" -gt 60 ] || { echo "tests/format_files.sh listed too few files"; exit 1; }
clang-format --version
clang-format --dry-run --Werror "${C_FILES[@]}"
python3 -m ruff --version
python3 -m ruff check --no-cache "${PY_FILES[@]}"
python3 -m ruff format --check --no-cache "${PY_FILES[@]}"
echo "${#C_FILES[@]} C/C++ files and ${#PY_FILES[@]} Python files are formatted"
# No import-path edits, ruff over every Python file, no tracker numbers, no duplicated code in the
# product (lizard and pylint; they must be there: DPC_TEST_REQUIRE_TOOLS), docs/architecture.md
# names the tree's folders. It imports nothing of dpc, so it runs before the package is built.
(cd /tmp && DPC_TEST_REQUIRE_TOOLS=1 python3 -m pytest -q -p no:cacheprovider "$ROOT/tests/python/test_repo_rules.py")

step "the dpc package (with the Vulkan backend; every extra: all)"
python3 -m pip install -q --disable-pip-version-check --no-build-isolation -C cmake.define.DPC_VULKAN=ON "$ROOT[all]"
# lavapipe is installed above: the Vulkan tests must find a device, not skip.
export DPC_TEST_REQUIRE_VULKAN=1

run_ctest() { # build dir, extra ctest args...
  local dir=$1; shift
  local log; log=$(mktemp)
  (cd "$dir" && ctest --output-on-failure -j "$JOBS" "$@") 2>&1 | tee "$log"
  grep -Eq '^100% tests passed(, 0 tests failed)? out of [1-9]' "$log" || { echo "ctest in $dir ran no test or failed"; exit 1; }
}

step "C tests, ASan + UBSan (a build with the Vulkan backend: the CPU tests without a driver, then lavapipe)"
cmake -S . -B build/test-vulkan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDPC_BUILD_TESTS=ON -DDPC_SANITIZE=address \
      -DDPC_VULKAN=ON >/dev/null
cmake --build build/test-vulkan -j "$JOBS"
# One sanitizer build serves both: the CPU tests run first with leak detection on (AUTO opens the
# Vulkan loader, finds no driver (VK_DRIVER_FILES names none) and runs on the CPU; a build without
# the backend is the Release stage's and the downstream C-only build's). lavapipe is kept
# out of this stage because the driver itself leaks (128 bytes per instance on AMD Zen 5, from
# code it has unloaded, so no suppression can name it); then the Vulkan tests, on lavapipe, with
# leak detection off.
VK_DRIVER_FILES=/nonexistent/dpc-no-driver.json VK_ICD_FILENAMES=/nonexistent/dpc-no-driver.json \
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 run_ctest build/test-vulkan -LE vulkan
ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 run_ctest build/test-vulkan -L vulkan

step "Vulkan tests under the Khronos validation layer (synchronization validation)"
# Every Vulkan call of the tests checked against the spec, and every shader's reads and writes
# against the barriers between them (a missing barrier is a SYNC-HAZARD error). lavapipe runs
# what a GPU driver might not forgive; any ERROR fails the stage.
VK_INSTANCE_LAYERS=VK_LAYER_KHRONOS_validation VK_LAYER_SETTINGS_PATH="$ROOT/tests/c/vk_layer_settings.txt" \
DPC_ISA= ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 build/test-vulkan/tests/c/dpc_test_vulkan 2>&1 \
  | tee build/vk-validation.log | grep -oE '^\[  (PASSED|FAILED) .*|^[A-Za-z0-9_-]+\((ERROR|WARN) / [A-Z]+\)' | sort | uniq -c
grep -q '^\[  PASSED  \] [1-9]' build/vk-validation.log || { echo "Vulkan tests under validation failed"; exit 1; }
! grep -q '(ERROR /' build/vk-validation.log || { echo "the validation layer reported errors (build/vk-validation.log)"; exit 1; }
grep -q 'BestPractices' build/vk-validation.log || { echo "the validation layer did not run"; exit 1; }

step "C thread tests, TSan"
cmake -S . -B build/test-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDPC_BUILD_TESTS=ON -DDPC_SANITIZE=thread >/dev/null
# Only the test programs that hold thread tests (the ctest filter below): TSan builds are slow.
cmake --build build/test-tsan -j "$JOBS" --target dpc_test_api dpc_test_generate dpc_test_input dpc_test_layer_train \
      dpc_test_sampler dpc_test_plan dpc_test_mask dpc_test_pbrt_map
# setarch -R: TSan's shadow memory needs a fixed layout on kernels with large mmap randomisation.
TSAN_OPTIONS=halt_on_error=1 setarch "$(uname -m)" -R bash -c "cd build/test-tsan && ctest --output-on-failure -R '[Tt]hread' 2>&1" | tee build/tsan.log
grep -Eq '^100% tests passed(, 0 tests failed)? out of [1-9]' build/tsan.log || { echo "TSan thread tests failed or ran none"; exit 1; }

step "C tests, Release (every ISA the CPU supports)"
cmake -S . -B build/test-release -G Ninja -DCMAKE_BUILD_TYPE=Release -DDPC_BUILD_TESTS=ON >/dev/null
cmake --build build/test-release -j "$JOBS"
run_ctest build/test-release

step "reader fuzzer, ${FUZZ_SECONDS} s"
cmake -S . -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDPC_BUILD_FUZZERS=ON \
      -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build build/fuzz -j "$JOBS"
bash tests/fuzz/run_fuzzer.sh build/fuzz "$FUZZ_SECONDS"

step "libdpc as a dependency: C-only build, cmake --install, find_package, pkg-config, add_subdirectory"
bash tests/downstream/run.sh

step "the wheel in a clean virtual environment (models inside; the train extra with the CPU torch)"
rm -rf build/wheel build/wheel-venv
python3 -m pip wheel -q --disable-pip-version-check --no-deps --no-build-isolation -w build/wheel "$ROOT"
WHEEL=$(ls build/wheel/deep_point_correlation-*.whl)
n_models=$(unzip -l "$WHEEL" | grep -c 'dpc/models/.*\.onnx$')
echo "$WHEEL: $n_models bundled models"
[ "$n_models" -ge 10 ] || { echo "the wheel lacks the bundled models"; exit 1; }
python3 -m venv build/wheel-venv
build/wheel-venv/bin/python -m pip install -q --disable-pip-version-check "$WHEEL"
(cd /tmp && "$ROOT/build/wheel-venv/bin/dpc" generate -m bnot-2d-stratified -n 512 -o "$ROOT/build/wheel-points.npy" \
   && "$ROOT/build/wheel-venv/bin/python" -c "
import numpy, dpc, sys
a = numpy.load(sys.argv[1])
assert a.shape == (512, 2) and a.dtype == numpy.float32, (a.shape, a.dtype)
assert 'bnot-2d' in dpc.available_models() and dpc.__file__.startswith(sys.prefix), dpc.__file__
print('clean venv:', dpc.__version__, len(dpc.available_models()), 'models,', a.shape, a.dtype)" "$ROOT/build/wheel-points.npy")
# the train extra, torch first as above (README, docs/training.md)
install_torch build/wheel-venv/bin/python
build/wheel-venv/bin/python -m pip install -q --disable-pip-version-check "$WHEEL[train]"
build/wheel-venv/bin/python -c "import torch, onnx; print('train extra: torch', torch.__version__, 'onnx', onnx.__version__)"
# the training commands of the train extra, from the wheel: a short run and its export
(cd /tmp && "$ROOT/build/wheel-venv/bin/dpc-train" --config "$ROOT/training/configs/tiny-test.toml" --steps 2 \
   --run-dir "$ROOT/build/wheel-train" --force --no-progress >/dev/null \
 && "$ROOT/build/wheel-venv/bin/dpc-export" "$ROOT/build/wheel-train/checkpoint.pt" -o "$ROOT/build/wheel-tiny.onnx" >/dev/null \
 && "$ROOT/build/wheel-venv/bin/python" -c "import dpc, sys; m = dpc.load(sys.argv[1]); print('dpc-train, dpc-export:', m.name, m.layers, 'layers')" "$ROOT/build/wheel-tiny.onnx")

step "Python tests (installed package)"
set +e
# -n: one pytest-xdist worker per CPU (about 40 % less wall time on 2 cores); no:benchmark: a
# pytest-benchmark that the image may carry warns under xdist, and warnings are errors here.
(cd /tmp && python3 -m pytest "$ROOT/tests/python" -q -p no:cacheprovider -p no:benchmark -n "$JOBS" -m "not slow")
rc=$?
set -e
if [ "$rc" -eq 5 ]; then echo "pytest collected no tests: failing"; exit 1; fi
[ "$rc" -eq 0 ] || exit "$rc"

step "all suites passed"
