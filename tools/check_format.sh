#!/usr/bin/env bash
# Fails when a tracked C++ file differs from .clang-format (Debian's clang-format 14, installed by
# tools/install_deps.sh). Runs in seconds, before the builds. To fix: tools/check_format.sh --fix
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || tools/install_deps.sh
mapfile -t files < <(git ls-files '*.cc' '*.h')
if [ "${1:-}" = "--fix" ]; then
  clang-format -i "${files[@]}"
  exit 0
fi
if ! clang-format --dry-run --Werror "${files[@]}"; then
  echo "check_format: the files above differ from .clang-format; tools/check_format.sh --fix" >&2
  exit 1
fi
echo "check_format: ${#files[@]} files as .clang-format says"
