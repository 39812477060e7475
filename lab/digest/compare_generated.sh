#!/usr/bin/env bash
# Proves a refactor changed no generated bit: builds libdpc at REV and at the working tree, runs
# generated_digest.c (every bundled model's sets at its trained count and at 3,000 points, twelve
# samplers' values, a mask design) against each, and diffs the digests.
#   bash lab/digest/compare_generated.sh 045e898
set -euo pipefail
cd "$(dirname "$0")/../.."
REV=${1:?usage: compare_generated.sh REV}
WORK=$(mktemp -d)
trap 'git worktree remove --force "$WORK/old" >/dev/null 2>&1 || true; rm -rf "$WORK"' EXIT
git worktree add -q --detach "$WORK/old" "$REV"
for side in old new; do
  src=$([ "$side" = old ] && echo "$WORK/old" || pwd)
  cmake -S "$src" -B "$WORK/build-$side" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$WORK/build-$side" -j "$(nproc)" --target dpc >/dev/null
done
# Compiled once against REV's header: the API it uses is older than or the same as the new one.
cc -O1 -I"$WORK/old/libdpc/include" lab/digest/generated_digest.c -o "$WORK/digest" -L"$WORK/build-old/libdpc" -ldpc
for side in old new; do
  LD_LIBRARY_PATH="$WORK/build-$side/libdpc" "$WORK/digest" models >"$WORK/$side.txt"
done
if diff "$WORK/old.txt" "$WORK/new.txt"; then
  echo "identical: $(wc -l <"$WORK/new.txt") digests ($(tail -1 "$WORK/new.txt"))"
else
  echo "generated bits differ from $REV"; exit 1
fi
