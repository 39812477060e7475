#!/usr/bin/env bash
# The files the formatters cover (.clang-format; [tool.ruff] in pyproject.toml), one per line:
#   bash tests/format_files.sh c    C and C++ sources and headers (clang-format)
#   bash tests/format_files.sh py   Python files (ruff check, ruff format)
# Covered: libdpc/, bindings/, tests/, python/, training/. Not covered: models/ and bench/ (their
# scripts follow the results they print), docs/, and generated files (the SPIR-V header made by
# glslc, the sampler mask made by make_sampler_mask.py).
set -euo pipefail
cd "$(dirname "$0")/.."
DIRS=(libdpc bindings tests python training)
GENERATED='^(libdpc/src/vulkan/vk_spirv\.h|libdpc/src/sampler/sampler_mask\.c)$'
case "${1:-}" in
  c) PATTERN='\.(c|h|cpp|hpp)$' ;;
  py) PATTERN='\.py$' ;;
  *) echo "usage: $0 c|py" >&2; exit 2 ;;
esac
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  git ls-files -- "${DIRS[@]}"
else
  find "${DIRS[@]}" -type f | sort
fi | grep -E "$PATTERN" | grep -vE "$GENERATED" | while read -r f; do [ -f "$f" ] && echo "$f"; done
