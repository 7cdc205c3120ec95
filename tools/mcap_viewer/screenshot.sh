#!/usr/bin/env bash
# A screenshot of an MCAP recording opened in Foxglove Studio 1.48 in headless Chromium, with the
# layout layouts/autonomsim.json (3D view of the track, car 0's cameras, its lane points):
#   tools/mcap_viewer/screenshot.sh FILE.mcap OUT.png [AT_S] [LAYOUT.json]
# AT_S: the simulated second to show (default 20). The first call installs the viewer (npm, 36 MB:
# @foxglove/studio-base's prebuilt bundle, React 17, puppeteer-core, which drives the system
# chromium). Not part of the build or of CI; docs/mcap.md says what it showed.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
file=$(realpath "$1") out=$(realpath -m "$2") at=${3:-20} layout=${4:-$here/layouts/autonomsim.json}
[[ -f $file ]] || { echo "screenshot: no file $1" >&2; exit 2; }
if [[ ! -d $here/node_modules/@foxglove/studio-base ]]; then
  (cd "$here" && npm ci --no-audit --no-fund --ignore-scripts)
fi
cp "$layout" "$here/layouts/.current.json"
port=$((20000 + RANDOM % 20000))
node "$here/server.mjs" "$port" "$(dirname "$file")" >/dev/null &
server=$!
trap 'kill $server 2>/dev/null; rm -f "$here/layouts/.current.json"' EXIT
sleep 1
time=$(date -u -d "@$at" +%Y-%m-%dT%H:%M:%S.000000000Z)
url="http://127.0.0.1:$port/?ds=remote-file&ds.url=http://127.0.0.1:$port/data/$(basename "$file")"
url+="&layoutUrl=/layouts/.current.json&sidebar=none&time=$time"
node "$here/shot.mjs" "$url" "$out" 4000
