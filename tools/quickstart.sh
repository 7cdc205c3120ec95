#!/usr/bin/env bash
# Fresh machine to first result: installs what is missing (Debian 12), builds, runs the default
# two-car scenario and prints where its results are.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/install_deps.sh
tools/reset_stale_build.sh build
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
build/bin/autonomsim run scenarios/lab_two_cars.yaml "$@"
