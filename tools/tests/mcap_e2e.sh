#!/usr/bin/env bash
# The MCAP recording end to end (ctest Mcap.run_and_export, label node), read by Foxglove's
# libraries against the run's own files (tools/tests/mcap_run_check.mjs):
#   1. the default scenario, 12 s (its first intersection crossings), the default topics:
#      recorded while it runs, exported afterwards from its folder; the two files equal byte
#      for byte;
#   2. 2 s with every topic, the camera images raw;
#   3. the same run exported with car 0's images as PNG.
#   tools/tests/mcap_e2e.sh BUILD_BIN_DIR WORK_DIR
# Node and the readers (node_modules, from package-lock.json) come from tools/install_deps.sh.
# Without them the test fails under CI=true and is skipped (exit 77) elsewhere.
set -euo pipefail
bin=$1 work=$2
cd "$(dirname "$0")/../.."
if ! command -v node >/dev/null || [[ ! -d node_modules/@mcap/core ]]; then
  echo "mcap_e2e: node or node_modules missing: run tools/install_deps.sh" >&2
  [[ ${CI:-} == true ]] && exit 1
  exit 77
fi
rm -rf "$work" && mkdir -p "$work"
run=(run scenarios/lab_two_cars.yaml --quiet --set expect=null)  # short runs: no lap counts

"$bin/autonomsim" "${run[@]}" --set duration_s=12 --out "$work/a" --mcap "$work/a.mcap"
"$bin/autonomsim" export "$work/a" --mcap "$work/a_export.mcap" --quiet
cmp "$work/a.mcap" "$work/a_export.mcap"
echo "ok: export equals run --mcap byte for byte"
node tools/tests/mcap_run_check.mjs "$work/a" "$work/a.mcap"

"$bin/autonomsim" "${run[@]}" --set duration_s=2 --out "$work/b" --mcap "$work/b.mcap" \
  --mcap-topics '*'
node tools/tests/mcap_run_check.mjs "$work/b" "$work/b.mcap"

"$bin/autonomsim" export "$work/b" --mcap "$work/b_png.mcap" --mcap-topics '/car0/*image*' \
  --mcap-images png --quiet
node tools/tests/mcap_run_check.mjs "$work/b" "$work/b_png.mcap" | tee "$work/b_png.txt"
grep -q "PNG images" "$work/b_png.txt"
