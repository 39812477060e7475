#!/usr/bin/env bash
# Run the reader fuzzer for a while and fail on any crash, timeout, leak or sanitizer report.
#   bash tests/fuzz/run_fuzzer.sh BUILD_DIR SECONDS
# BUILD_DIR was configured with -DDPC_BUILD_FUZZERS=ON and clang. Seeds: every committed model
# file of tests/data (valid models, variants, malformed files). New inputs go to
# tests/fuzz/corpus-work/ (git-ignored); crash inputs to tests/fuzz/corpus-work/artifacts/.
set -euo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 BUILD_DIR SECONDS" >&2
  exit 2
fi
BUILD=$(cd "$1" && pwd)
SECONDS_TO_RUN=$2
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BIN="$BUILD/tests/fuzz/fuzz_reader"
if [ ! -x "$BIN" ]; then
  echo "no fuzzer at $BIN: configure with -DDPC_BUILD_FUZZERS=ON and build first" >&2
  exit 2
fi

WORK="$ROOT/tests/fuzz/corpus-work"
mkdir -p "$WORK/corpus" "$WORK/artifacts"
SEEDS=$(mktemp -d)
trap 'rm -rf "$SEEDS"' EXIT
for dir in "$ROOT/tests/data" "$ROOT/tests/data/variants" "$ROOT/tests/data/malformed"; do
  for f in "$dir"/*.onnx; do
    [ -e "$f" ] || continue
    cp "$f" "$SEEDS/$(basename "$dir")-$(basename "$f")"
  done
done
n_seeds=$(ls "$SEEDS" | wc -l)
if [ "$n_seeds" -lt 5 ]; then
  echo "found only $n_seeds seed files under tests/data" >&2
  exit 1
fi

# Per-input timeout: the target bounds each input's work (MAX_WORK in fuzz_reader.c, the
# relaxation's steps included) to well under a second under ASan (the relaxation's worst cases
# measure about 0.2 s unloaded); 60 s leaves room for a machine loaded by other jobs (a 10 s
# timeout was tripped there) while a real hang still stops the run within a minute.
INPUT_TIMEOUT=60
LOG="$WORK/fuzz.log"
echo "fuzzing $BIN for $SECONDS_TO_RUN s from $n_seeds seeds (log: $LOG)"
set +e
ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
  "$BIN" -max_total_time="$SECONDS_TO_RUN" -max_len=65536 -timeout="$INPUT_TIMEOUT" -rss_limit_mb=2048 \
         -print_final_stats=1 -artifact_prefix="$WORK/artifacts/" \
         "$WORK/corpus" "$SEEDS" > "$LOG" 2>&1
status=$?
set -e
tail -n 25 "$LOG"
execs=$(grep -Eo 'stat::number_of_executed_units: *[0-9]+' "$LOG" | grep -Eo '[0-9]+$' || true)
if [ "$status" -ne 0 ] || grep -Eq 'ERROR: (libFuzzer|AddressSanitizer|LeakSanitizer)|runtime error:' "$LOG"; then
  echo "FUZZER FAILED (exit $status); crash inputs in $WORK/artifacts:" >&2
  ls -la "$WORK/artifacts" >&2
  exit 1
fi
if [ -z "$execs" ] || [ "$execs" -eq 0 ]; then
  echo "the fuzzer executed no input" >&2
  exit 1
fi
echo "fuzzer ok: $execs inputs in $SECONDS_TO_RUN s, no crash"
