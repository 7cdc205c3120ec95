#!/usr/bin/env bash
# tools/fuzz.sh [SECONDS_PER_TARGET [TARGET...]] (default 60 s, every target): builds the libFuzzer
# targets (preset fuzz: clang, AddressSanitizer + UndefinedBehaviorSanitizer, build-fuzz/), seeds
# their corpora from the shipped files, and runs each for SECONDS_PER_TARGET, as many at once as
# there are cores. Prints the executions per target; exits 1 when any target finds something (a
# crash, a sanitizer report, a hang: an input over the target's TIMEOUT, 10 s unless its
# autonomsim_fuzzer call says; over 2 GB of memory in all or in one allocation; or an error
# message that does not say where), with its input in build-fuzz/artifacts/. Corpora grow in
# build-fuzz/corpus/<target>/ from run to run. Naming targets builds and runs only those.
# docs/fuzzing.md says more.
set -euo pipefail
cd "$(dirname "$0")/.."
usage="usage: tools/fuzz.sh [SECONDS_PER_TARGET [TARGET...]]"
seconds="${1:-60}"
[[ $seconds =~ ^[1-9][0-9]*$ ]] || { echo "$usage" >&2; exit 2; }
shift $(($# > 0 ? 1 : 0))
wanted=("$@")

tools/install_deps.sh
tools/reset_stale_build.sh build-fuzz
# AUTONOMSIM_DEBUG_LINES_ONLY=1 (set by CI): line tables instead of full debug info, as in test.sh.
# AUTONOMSIM_FUZZ_OPT=0: the targets and libraries at -O0, not the preset's -O1: the build in about
# half the time, for fewer executions a second (a short pass that mostly replays the seeds).
opt="${AUTONOMSIM_FUZZ_OPT:-1}"
[[ $opt =~ ^[0-3]$ ]] || { echo "tools/fuzz.sh: AUTONOMSIM_FUZZ_OPT must be 0-3" >&2; exit 2; }
cmake --preset fuzz -DAUTONOMSIM_DEBUG_LINES_ONLY="${AUTONOMSIM_DEBUG_LINES_ONLY:-0}" \
  -DCMAKE_CXX_FLAGS_DEBUG="-g -O$opt" >/dev/null

build=build-fuzz
artifacts=$build/artifacts
mkdir -p "$artifacts" "$build/tmp" "$build/logs"
# The file-reading targets write their input into a folder of their own under $TMPDIR.
export TMPDIR=$PWD/$build/tmp
export UBSAN_OPTIONS=print_stacktrace=1
# As CMakePresets.json's asan test preset says: the runtime's __tls_get_addr guess can crash
# LeakSanitizer's exit check by chance (google/sanitizers#1322).
export ASAN_OPTIONS=intercept_tls_get_addr=0

# Every key a config struct lists in its Describe (the scenario, track and profile schema).
dict=$build/config_keys.dict
git ls-files -- '*.h' | xargs grep -ohE '\bv\("[a-z_0-9]+"' | sed -E 's/^v\((.*)/\1/' |
  sort -u >"$dict"

# seed_lines FILE DIR: one seed file in DIR per line of FILE (# lines are comments).
seed_lines() {
  local n=0 line
  while IFS= read -r line; do
    [[ -z $line || $line == '#'* ]] && continue
    n=$((n + 1))
    printf '%s' "$line" >"$2/seed-$n"
  done <"$1"
}

# target|seeds|dictionary|timeout, one a line, from the autonomsim_fuzzer calls
# (cmake/autonomsim.cmake): seeds are a .seeds file (one a line) or a glob of shipped files;
# CONFIG_KEYS is $dict; timeout is the seconds one input may take.
mapfile -t targets < <(grep -v '^$' "$build/fuzz_targets.txt" | sed "s#|CONFIG_KEYS|#|$dict|#")

# the targets asked for, or all
selected=()
if ((${#wanted[@]} == 0)); then selected=("${targets[@]}"); fi
for name in "${wanted[@]}"; do
  found=""
  for entry in "${targets[@]}"; do [[ ${entry%%|*} == "$name" ]] && found=$entry; done
  [[ -n $found ]] || { echo "tools/fuzz.sh: no target '$name'; $usage" >&2; exit 2; }
  selected+=("$found")
done
build_targets=()
for entry in "${selected[@]}"; do build_targets+=("${entry%%|*}"); done
cmake --build --preset fuzz -j "$(nproc)" --target "${build_targets[@]}"

# fuzz_one TARGET SEEDS DICTIONARY TIMEOUT: seeds the target's corpus and fuzzes it; its exit
# status goes to $build/logs/TARGET.status, its output to $build/logs/TARGET.log.
fuzz_one() {
  local target=$1 seeds=$2 dictionary=$3 timeout=$4
  local corpus=$build/corpus/$target log=$build/logs/$target.log status=0
  mkdir -p "$corpus"
  if [[ $seeds == *.seeds ]]; then
    seed_lines "$seeds" "$corpus"
  else
    cp $seeds "$corpus/"  # a glob, unquoted on purpose
  fi
  local args=(-max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb=2048 -malloc_limit_mb=2048
              -print_final_stats=1
              -artifact_prefix="$artifacts/$target-")
  [[ -n $dictionary ]] && args+=(-dict="$dictionary")
  "$build/bin/$target" "${args[@]}" "$corpus" >"$log" 2>&1 || status=$?
  echo "$status" >"$build/logs/$target.status"
}

# The targets run side by side, one per core (each writes only its own corpus, log and scratch
# folder), then are reported in the order above.
running=0
for entry in "${selected[@]}"; do
  IFS='|' read -r target seeds dictionary timeout <<<"$entry"
  if ((running >= $(nproc))); then
    wait -n
    running=$((running - 1))
  fi
  fuzz_one "$target" "$seeds" "$dictionary" "$timeout" &
  running=$((running + 1))
done
wait

failed=()
for entry in "${selected[@]}"; do
  target=${entry%%|*}
  log=$build/logs/$target.log
  status=$(cat "$build/logs/$target.status")
  runs=$(sed -nE 's/^stat::number_of_executed_units: *([0-9]+).*/\1/p' "$log" | tail -1)
  if ((status == 0)); then
    echo "fuzz: $target: ${runs:-?} executions in ${seconds} s, corpus" \
         "$(ls "$build/corpus/$target" | wc -l) inputs, no finding"
  else
    echo "fuzz: $target: FINDING after ${runs:-?} executions (exit $status); log $log:" >&2
    grep -vE '^(#[0-9]|INFO:|	NEW_FUNC)' "$log" | tail -40 >&2
    failed+=("$target")
  fi
done

if ((${#failed[@]} > 0)); then
  echo "fuzz: findings in ${failed[*]}; their inputs are in $artifacts/" >&2
  exit 1
fi
echo "fuzz: no findings"
