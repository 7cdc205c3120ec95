#!/usr/bin/env bash
# Fresh machine to a verdict: installs what is missing (Debian 12), builds, and runs every test
# with ctest. With AUTONOMSIM_SANITIZE=1 (set by CI) it then builds again with AddressSanitizer
# and UndefinedBehaviorSanitizer and runs the suite a second time under them.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs="$(nproc)"
# Each stage's start, with the seconds since this script began (CI's time budget: .ci/run).
stage() { echo "== test.sh: $1 (at ${SECONDS} s)"; }
tools/install_deps.sh
tools/reset_stale_build.sh build build-asan
# AUTONOMSIM_DEBUG_LINES_ONLY=1 (set by CI): line tables instead of full debug info, see CMakeLists.txt.
configure_args=(-DAUTONOMSIM_DEBUG_LINES_ONLY="${AUTONOMSIM_DEBUG_LINES_ONLY:-0}")
# AUTONOMSIM_BUILD_BENCH=0 (set by CI): the release build without the benchmarks (bench/), which
# no test runs; a developer's build and the README's commands build them.
release_args=("${configure_args[@]}" -DAUTONOMSIM_BUILD_BENCH="${AUTONOMSIM_BUILD_BENCH:-1}")

cmake --preset release "${release_args[@]}" >/dev/null
stage "release build"
cmake --build --preset release -j "$jobs"
# One test more than cores: the real-time tests (label realtime, started first) spend a minute
# mostly asleep on the wall clock, and would otherwise hold a core's place.
stage "release tests"
ctest --preset release -j "$((jobs + 1))"

if [ "${AUTONOMSIM_SANITIZE:-0}" = "1" ]; then
  # Under the sanitizers, skip the tests that only run whole scenarios again to compare results
  # (determinism and link equality): the second run adds no sanitizer coverage, the code they
  # exercise is run under the sanitizers by other tests, and they all ran in the pass above.
  asan_skip='CheckGivesTheSameResultsWhateverTheNumberOfJobs|SeparateProcessesGiveTheSameResult'
  asan_skip+='|CheckPassesTheShippedScenarios|SameScenarioAndSeedGiveBitIdenticalResults'
  asan_skip+='|RunsOnTwoThreadsAtOnceMatchASequentialRun|TheSeedChangesTheRun'
  asan_skip+='|TheSnapshotIsTheFullRunsWorldAtThatInstant|GivesTheSameResultOverMqtt'
  asan_skip+='|AnExternalBrokerAndTlserverServeARun|ShardsRunByGnuParallelMergeToTheSameTable'
  asan_skip+='|TheShippedScenarioGivesItsPinnedResult|CheckPassesTheShippedFaultScenarios'
  # The faults' code runs under the sanitizers in Faults.EveryKindAtOnceGivesTheSameResultTwice
  # (all eleven kinds in one run, three runs of 20 s) and the server_down and uplink tests; each
  # other fault test drives a 25 s run and a baseline to judge a behaviour the pass above judged.
  asan_skip+='|Faults\.(AreEvents|CarStall|ADead|ACarWhose|APartition|ALossBurst|ABrokerOutage'
  asan_skip+='|AServerRestart|ACrashed|AHung|AFrozen|ABlackedOut|AGyroBias|ALocalizationJump)'
  # The same for the GL backend's repeat runs (the GL code runs under the sanitizers in
  # ReportTest.RenderWritesACameraDatasetWithLabelsFromEitherBackend), a sweep's jobs-and-shards
  # equality, three whole-run stack behaviours and the lane detector's sweeps along the track's
  # corners: each judges again what the pass above judged, on code other tests run under them.
  asan_skip+='|TheGlCameraBackendGivesTheSameResultTwiceAndOnTwoThreads'
  asan_skip+='|ResumesAndGivesTheSameTableWhateverTheJobsAndShards'
  asan_skip+='|SimulationStackTest\.(WithoutThePoseFixTheEstimateDrifts'
  asan_skip+='|TheCollisionModelDecidesWhetherTheCarStopsBeforeTheBox'
  asan_skip+='|TheLabsBlockingClientAndServerCrossWithoutCollisions)'
  asan_skip+='|LaneTrack\.(ThroughCornersTheFaithfulAlgorithmIsWithin18cmOfThePaintedCentre'
  asan_skip+='|EnteringAndLeavingCornersLanePointsFollowThePaintedCentre)'
  # Each Table1 test runs Table I's ten setups again in its own process (2.5 s each under the
  # sanitizers): one of them, the DDS rows', is enough to run that code under them.
  asan_skip+='|Table1\.(EightRows|EveryZeroCopy|ARowsCpu|TheRateProbe|HeldOutRowsPrint|TheTextShows'
  asan_skip+='|DdsCostsMore|TheSameRun|JsonHas|WholeUnit)'
  cmake --preset asan "${configure_args[@]}" >/dev/null
  stage "asan build"
  cmake --build --preset asan -j "$jobs"
  # The asan test preset leaves out the labels realtime (runs paced to the wall clock: under the
  # sanitizers they only wait longer) and python (the module is not built there); ctest ignores
  # an -LE given here when the preset has its own.
  stage "asan tests"
  ctest --preset asan -j "$jobs" -E "$asan_skip"
fi
stage "done"
