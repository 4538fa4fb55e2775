#!/bin/sh
# Time and peak memory of areomap-sim for each preset (figures in BENCHMARKS.md "Simulator").
# Usage: tests/ground/sim/benchmark.sh [BUILD_DIR] [PRESET...]   (default: build, tiny navcam imp)
set -eu
build=${1:-build}
[ $# -gt 0 ] && shift
presets=${*:-tiny navcam imp}
sim="$build/bin/areomap-sim"
[ -x "$sim" ] || { echo "benchmark.sh: $sim not built" >&2; exit 1; }
[ -x /usr/bin/time ] || { echo "benchmark.sh: needs /usr/bin/time (Debian package 'time')" >&2; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf '%-8s %10s %10s %8s %12s %10s  %s\n' preset wall_s cpu_s cpu_pct peak_rss_mb images_mb "load before"
for preset in $presets; do
  load=$(cut -d' ' -f1 /proc/loadavg)
  /usr/bin/time -f '%e %U %S %P %M' -o "$out/time.txt" "$sim" --preset "$preset" --seed 1 --out "$out/$preset" 2>"$out/log.txt" ||
    { cat "$out/log.txt" >&2; exit 1; }
  read -r wall user sys pct rss < "$out/time.txt"
  images=$(du -sm "$out/$preset/images" | cut -f1)
  cpu=$(awk "BEGIN { print $user + $sys }")
  printf '%-8s %10s %10s %8s %12s %10s  %s\n' "$preset" "$wall" "$cpu" "$pct" "$((rss / 1024))" "$images" "$load"
  rm -rf "${out:?}/$preset"
done
