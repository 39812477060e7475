#!/usr/bin/env bash
# The files the formatters cover (.clang-format; [tool.ruff] in pyproject.toml), one per line:
#   bash tests/format_files.sh c    C and C++ sources and headers (clang-format)
#   bash tests/format_files.sh py   Python files (ruff check, ruff format)
# C/C++: libdpc/, bindings/, tests/, python/, training/, bench/, integrations/. Python: every
# Python file of the repository (tests/python/test_repo_rules.py checks that this list holds them
# all). Not covered:
# generated files (the SPIR-V header made by glslc, the sampler mask made by make_sampler_mask.py).
set -euo pipefail
cd "$(dirname "$0")/.."
GENERATED='^(libdpc/src/vulkan/vk_spirv\.h|libdpc/src/sampler/sampler_mask\.c)$'
case "${1:-}" in
  c) DIRS=(libdpc bindings tests python training bench integrations) PATTERN='\.(c|h|cpp|hpp)$' ;;
  py) DIRS=(.) PATTERN='\.py$' ;;
  *) echo "usage: $0 c|py" >&2; exit 2 ;;
esac
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  git ls-files -- "${DIRS[@]}"
else
  find "${DIRS[@]}" -type f -not -path './build/*' -not -path './.git/*' -not -path './runs/*' | sed 's#^\./##' | sort
fi | grep -E "$PATTERN" | grep -vE "$GENERATED" | while read -r f; do [ -f "$f" ] && echo "$f"; done
