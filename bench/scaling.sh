#!/usr/bin/env bash
# The fleet at scale (issue 38): for 1, 2, 4, 6, 8 and 10 stack-driven cars (the first N of
# scenarios/fleet_ten_cars.yaml, 60 s), one `autonomsim run` process each on one core (taskset),
# its wall time and peak memory (/usr/bin/time -f %M); writes OUT_DIR/scaling.csv and
# OUT_DIR/scaling.png (real-time factor and memory against cars, gnuplot).
#   bench/scaling.sh [OUT_DIR] [BIN_DIR]     (defaults: runs/scaling, build/bin)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-runs/scaling} bin=${2:-build/bin}
mkdir -p "$out"
echo "cars,sim_s,wall_s,real_time_factor,peak_rss_mb" > "$out/scaling.csv"
for n in 1 2 4 6 8 10; do
  drop=()
  for ((k = 9; k >= n; --k)); do drop+=(--set "cars[$k]=null"); done
  stats=$( { /usr/bin/time -f "%e %M" taskset -c 0 "$bin/autonomsim" run scenarios/fleet_ten_cars.yaml \
              "${drop[@]}" --out "$out/run_$n" --force -q >/dev/null; } 2>&1 | tail -1)
  read -r wall rss_kb <<<"$stats"
  awk -v n="$n" -v w="$wall" -v r="$rss_kb" \
    'BEGIN { printf "%d,60,%.2f,%.2f,%.1f\n", n, w, 60 / w, r / 1024 }' >> "$out/scaling.csv"
  echo "scaling: $n car(s): $(tail -1 "$out/scaling.csv")" >&2
done
gnuplot <<GP
set terminal pngcairo size 900,520 font "sans,11"
set output "$out/scaling.png"
set datafile separator ","
set title "The closed loop at scale: stack-driven cars, 60 s simulated, one core" font "sans,13"
set xlabel "stack-driven cars"
set ylabel "real-time factor (simulated s per wall s)"
set y2label "peak memory of the process (MB)"
set ytics nomirror
set y2tics
set yrange [0:*]
set y2range [0:*]
set grid ytics
set key outside bottom center horizontal
plot "$out/scaling.csv" every ::1 using 1:4 with linespoints lw 2 pt 7 title "real-time factor", \
     "$out/scaling.csv" every ::1 using 1:5 axes x1y2 with linespoints lw 2 pt 5 dt 2 title "peak memory (MB)"
GP
echo "scaling: $out/scaling.csv, $out/scaling.png" >&2
