#!/usr/bin/env bash
# tools/reset_stale_build.sh DIR...: the presets build with Ninja; a build folder configured
# earlier with another generator (Unix Makefiles, before the switch) cannot be reused by cmake, so
# it is removed (a full rebuild follows). Folders already on Ninja, or absent, are left alone.
set -euo pipefail
for dir in "$@"; do
  cache="$dir/CMakeCache.txt"
  [ -f "$cache" ] || continue
  if ! grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$cache"; then
    echo "reset_stale_build: $dir was configured with another generator; removing it"
    rm -rf "$dir"
  fi
done
