#!/usr/bin/env bash
# The layering check (ARCHITECTURE "Layers"): every #include "module/..." in the project's C++ files
# must name the file's own module or one the module may use: those listed as its uses below and,
# through them, theirs. Tests (<module>/tests/) may also use vehicle/ and sim/core for fixtures
# (rendered frames, the lab track's file). tools/ may use everything; tlserver (what the real lab
# runs) only world/ and sim/mqtt. Exit 0 when every include goes downward; 1, listing each one
# that does not.
set -euo pipefail
cd "$(dirname "$0")/.."

declare -A uses=(
  [world]=""
  [vehicle]="world"
  [stack]="world"
  [sim/core]="world"
  [sim/mcap]=""  # MCAP recording: the writer and CDR encoder use no module of ours
  [sim/mqtt]="world"
  [sim/platform]="sim/core"
  [sim/car]="sim/platform stack vehicle"
  [sim/scenario]="sim/car sim/mqtt"
  [sim/v2i]="sim/scenario"
  [sim/loop]="sim/v2i"
  [sim/results]="sim/loop sim/mcap"
  [sim/study]="sim/results"
  [bench]="sim/study"
  [tools]="sim/study"
  [python]="sim/study"  # the Python module: over sim/, as the CLI
  [tools/tlserver]="world sim/mqtt"
)
test_fixtures="vehicle sim/core"

# allowed[m]: " m and every module m may use, directly or through others "
declare -A allowed
for m in "${!uses[@]}"; do
  set=" $m " todo="${uses[$m]}"
  while [[ -n ${todo// /} ]]; do
    read -r dep todo <<<"$todo"
    [[ $set == *" $dep "* ]] && continue
    set+="$dep "
    todo+=" ${uses[$dep]}"
  done
  allowed[$m]=$set
done
fixtures=""
for f in $test_fixtures; do fixtures+="${allowed[$f]}"; done

# module <path>: sets `module` to the module a path belongs to (its folder under sim/, tlserver's
# files, or its top-level folder).
module_of() {
  case $1 in
    tools/tlserver*|tools/tests/tlserver*) module=tools/tlserver ;;
    sim/*) local rest=${1#sim/}; module="sim/${rest%%/*}" ;;
    *) module=${1%%/*} ;;
  esac
}

violations=0
while IFS=: read -r file line target; do
  module_of "$file"
  from=$module
  ok="${allowed[$from]:-}"
  [[ -n $ok ]] || { echo "check_layers: $file: no layer for module '$from'" >&2; exit 2; }
  [[ $file == */tests/* ]] && ok+="$fixtures"
  module_of "$target"
  [[ $from == tools && $module == tools* ]] && continue  # the CLI's own files, tlserver's too
  if [[ $ok != *" $module "* ]]; then
    echo "$file:$line: includes \"$target\" ($module), above $from"
    violations=$((violations + 1))
  fi
done < <(git ls-files -co --exclude-standard -- '*.h' '*.cc' | grep -v '^build' |
           xargs grep -Hn '^#include "' | sed -E 's/^([^:]+):([0-9]+):#include "([^"]+)".*/\1:\2:\3/')

if ((violations > 0)); then
  echo "check_layers: $violations include(s) from a module above the file's own" \
       "(the table is in tools/check_layers.sh)" >&2
  exit 1
fi
echo "check_layers: every include goes downward"
