#!/usr/bin/env bash
# bench/dds_vs_cyclone.sh [RUNS]: the DDS transport model against real Cyclone DDS on this machine.
#
# For samples of 0.9, 1, 2 and 4.9 MB offered at 30 Hz, x {Cyclone's defaults, a 4 MB socket
# receive buffer, 64 KB fragments} x {quiet, one busy loop per core}, it runs Debian's ddsperf
# (cyclonedds-tools) RUNS times (default 5) in a private network namespace on loopback only, and
# `autonomsim transport` with scenarios/platforms/x86_loopback.yaml and the same settings (and
# --background-load giving the same busy loops), and prints ddsperf's delivered rates (median, min,
# max) beside the model's, and whether the model lies within [min/2, 2*max].
#
# First it measures this machine's figures the profile holds (bench_loopback: a loopback datagram's
# sendto and recvfrom, the copy bandwidth; net.core.rmem_max) and prints them beside the profile's:
# they are measured, never fitted to ddsperf's rates.
#
# Needs root (unshare -n), ddsperf (tools/install_deps.sh installs cyclonedds-tools) and a release
# build (build/bin). Not a CI test: it needs a network namespace, takes about 15 minutes, and its
# figures are only as steady as the machine. Writes its raw outputs under build/dds_vs_cyclone/;
# with DDS_BENCH_REUSE=1 it reads ddsperf's from there instead of running it again (a changed
# model against the last measurements: seconds, and no root needed).
# docs/model.md#dds-against-cyclone-dds has the table and how to read it.
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-5}"
[[ $runs =~ ^[1-9][0-9]*$ ]] || { echo "usage: bench/dds_vs_cyclone.sh [RUNS]" >&2; exit 2; }
seconds=6    # each ddsperf run; the first 2 s (discovery, start) are not counted
rate_hz=30
profile=scenarios/platforms/x86_loopback.yaml
out=build/dds_vs_cyclone
for tool in ddsperf unshare ip build/bin/autonomsim build/bin/bench_loopback; do
  command -v "$tool" >/dev/null || { echo "dds_vs_cyclone: $tool not found" >&2; exit 2; }
done
reuse="${DDS_BENCH_REUSE:-0}"
[[ $reuse == 1 || $(id -u) == 0 ]] || { echo "dds_vs_cyclone: needs root for unshare -n" >&2; exit 2; }
mkdir -p "$out"

[[ $reuse == 1 ]] && echo "== ddsperf's rates from the logs in $out (DDS_BENCH_REUSE=1)"
echo "== this machine ($(nproc) cores, $(uname -r)) against $profile"
build/bin/bench_loopback --benchmark_format=json --benchmark_repetitions=3 \
  --benchmark_report_aggregates_only=true >"$out/loopback.json" 2>/dev/null
python3 - "$out/loopback.json" "$profile" <<'EOF'
import json, re, subprocess, sys
bench = {b["name"]: b for b in json.load(open(sys.argv[1]))["benchmarks"] if b["name"].endswith("_median")}
def ns(name): return bench[name + "_median"]["real_time"]
prof = open(sys.argv[2]).read()
def prof_value(key):
    m = re.search(r"^\s*%s:\s*([0-9.e+-]+)" % key, prof, re.M)
    return m.group(1) if m else "?"
memcpy = bench["BM_Memcpy/4915200_median"]["bytes_per_second"]
print(f"  copy bandwidth        {memcpy/1e9:.2f} GB/s     (profile cpu.memcpy_bytes_per_s {prof_value('memcpy_bytes_per_s')})")
for side, name in (("send", "BM_LoopbackSendto/14720"), ("receive", "BM_LoopbackRecvfrom/14720")):
    total = ns(name) / 1e3
    print(f"  {side:8s} 14 720 B     {total:.2f} us, of which the copy {14720/memcpy*1e6:.2f} us")
rmem = open("/proc/sys/net/core/rmem_max").read().strip()
print(f"  net.core.rmem_max     {rmem} B   (profile dds.host_rmem_max_bytes {prof_value('host_rmem_max_bytes')})")
EOF

# A Cyclone configuration on lo only, no multicast, the peer 127.0.0.1, plus $1 (extra XML).
cyclone_xml() {
  cat <<EOF
<CycloneDDS><Domain>
  <General><Interfaces><NetworkInterface name="lo"/></Interfaces>
    <AllowMulticast>false</AllowMulticast>$1</General>
  <Discovery><Peers><Peer address="127.0.0.1"/></Peers><ParticipantIndex>auto</ParticipantIndex></Discovery>
  <Internal>$2</Internal>
</Domain></CycloneDDS>
EOF
}

# one ddsperf run: delivered samples per second from 2 s on, from the subscriber's running total
# (its per-second lines: "[pid] T size B total N lost L delta D ..."; a second without data may
# print no line, so totals, not deltas)
ddsperf_run() {  # bytes xml_file log
  unshare -n bash -c "ip link set lo up
    export CYCLONEDDS_URI=file://$PWD/$2
    ddsperf -D $((seconds + 1)) sub >'$3' 2>&1 &
    sleep 0.5
    ddsperf -D $seconds pub ${rate_hz}Hz size $1 >/dev/null 2>&1
    wait" || true
  ddsperf_rate "$3"
}
ddsperf_rate() {  # log
  awk '$3 == "size" { t = $2 + 0; if (t < 2) { t0 = t; n0 = $6 } else if (t <= '"$seconds"') { t1 = t; n1 = $6 } }
       END { if (t1 > t0) printf "%.2f\n", (n1 - n0) / (t1 - t0); else print "0" }' "$1"
}

busy_pids=()
start_busy() { for _ in $(seq "$(nproc)"); do (while :; do :; done) & busy_pids+=($!); done; }
stop_busy() { ((${#busy_pids[@]})) && kill "${busy_pids[@]}" 2>/dev/null; wait "${busy_pids[@]}" 2>/dev/null || true; busy_pids=(); }
trap stop_busy EXIT

declare -A general=([defaults]="" [rcvbuf_4MB]="" [frag_64KB]="<FragmentSize>65000B</FragmentSize><MaxMessageSize>65500B</MaxMessageSize>")
declare -A internal=([defaults]="" [rcvbuf_4MB]="<SocketReceiveBufferSize min=\"4MiB\"/>" [frag_64KB]="")
declare -A model_set=([defaults]="" [rcvbuf_4MB]="--set dds.receive_buffer_bytes=4194304" [frag_64KB]="--set dds.fragment_bytes=65000 --set dds.max_message_bytes=65500")
# ddsperf's data writer is reliable, KEEP_ALL, max blocking 10 s (ddsperf.c); the model the same
ddsperf_qos="--set dds.history=keep_all --set dds.max_blocking_s=10"

printf "\n%-10s %-11s %-6s | %-30s | %-8s %s\n" size config load "ddsperf Hz: median (min-max)" "model Hz" "within [min/2, 2 max]"
judged=0; inside=0
for load in quiet busy; do
  for config in defaults rcvbuf_4MB frag_64KB; do
    xml="$out/$config.xml"
    cyclone_xml "${general[$config]}" "${internal[$config]}" >"$xml"
    for bytes in 921600 1000000 2000000 4915200; do
      rates=()
      [[ $load == busy && $reuse != 1 ]] && start_busy
      for run in $(seq "$runs"); do
        log="$out/$load-$config-$bytes-$run.log"
        if [[ $reuse == 1 ]]; then
          [[ -f $log ]] || { echo "dds_vs_cyclone: no $log to reuse" >&2; exit 2; }
          rates+=("$(ddsperf_rate "$log")")
        else
          rates+=("$(ddsperf_run "$bytes" "$xml" "$log")")
        fi
      done
      stop_busy
      background=0; [[ $load == busy ]] && background=$(nproc)
      # shellcheck disable=SC2086  # the --set words are meant to split
      model=$(build/bin/autonomsim transport --bytes "$bytes" --rate-hz "$rate_hz" --seconds 20 \
        --warmup 2 --profile "$profile" --background-load "$background" $ddsperf_qos \
        ${model_set[$config]} --json | python3 -c 'import json,sys; print(round(json.load(sys.stdin)["delivered_hz"], 2))')
      read -r median lo hi verdict < <(python3 - "$model" "${rates[@]}" <<'EOF'
import statistics, sys
model = float(sys.argv[1]); r = sorted(float(x) for x in sys.argv[2:])
ok = r[0] / 2 <= model <= 2 * r[-1]
print(f"{statistics.median(r):.1f} {r[0]:.1f} {r[-1]:.1f} {'yes' if ok else 'NO'}")
EOF
)
      judged=$((judged + 1)); [[ $verdict == yes ]] && inside=$((inside + 1))
      printf "%-10s %-11s %-6s | %6s (%s-%s) %-14s | %-8s %s\n" "$bytes" "$config" "$load" \
        "$median" "$lo" "$hi" "" "$model" "$verdict"
    done
  done
done
echo "model within [min/2, 2 max] of ddsperf in $inside of $judged configurations ($(date -u +%F), $(nproc) cores)"
[[ $inside == "$judged" ]]
