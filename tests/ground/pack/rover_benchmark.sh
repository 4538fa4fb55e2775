#!/bin/sh
# Rover node benchmark: areomap-pack, then areomap-rover on a file:// replay (per-stage time per
# pair, whole-panorama time, peak RSS) and over udpm with stock lcm-logplayer at full speed (-s 0) in a
# private network namespace (messages per second, sequence gaps), and the binary's static memory (size).
# With REFERENCE (another areomap-rover binary, e.g. main's, built elsewhere) it first runs both on the same
# file:// replay, alternately, RUNS times each (default 3), and prints each run's per-pair stage times: the
# reference comes from the same load as the figure.
# usage: tests/ground/pack/rover_benchmark.sh [BUILD_DIR] [DATASET] [REFERENCE [RUNS]]
#        (DATASET default or "": areomap-sim navcam seed 1)
set -eu
BUILD=${1:-build}
BIN=$BUILD/bin
WORK=$BUILD/bench/rover
mkdir -p "$WORK"
DATASET=${2:-}
if [ -z "$DATASET" ]; then
  DATASET=$WORK/navcam
  [ -f "$DATASET/panorama.json" ] || "$BIN/areomap-sim" --preset navcam --seed 1 --out "$DATASET" >/dev/null 2>&1
fi
LOG=$WORK/stream.lcm
"$BIN/areomap-pack" "$DATASET" --out "$LOG" 2>/dev/null
echo "log: $(ls -l "$LOG" | awk '{print $5}') bytes, $(basename "$DATASET")"
REFERENCE=${3:-}
if [ -n "$REFERENCE" ]; then
  echo "--- per pair, this build against $REFERENCE, alternately (file:// replay)"
  RUN=1
  while [ "$RUN" -le "${4:-3}" ]; do
    for B in "$REFERENCE" "$BIN/areomap-rover"; do
      LABEL=this; [ "$B" = "$REFERENCE" ] && LABEL=reference
      printf '%s run %d: ' "$LABEL" "$RUN"
      "$B" --lcm "file://$(realpath "$LOG")" --quiet 2>&1 | grep 'seconds per accepted pair' | sed 's/^areomap-rover: //'
    done
    RUN=$((RUN + 1))
  done
fi
echo "static memory of the rover binary (size):"
size "$BIN/areomap-rover"
echo "--- file:// replay (pipeline as fast as it goes)"
/usr/bin/time -f "peak RSS %M KiB, wall %e s" "$BIN/areomap-rover" --lcm "file://$(realpath "$LOG")" --quiet 2>&1 | grep -v listening
echo "--- udpm, lcm-logplayer -s 0 (full speed), private network namespace"
if unshare -n true 2>/dev/null; then
  unshare -n sh -c '
    ip link set lo up && ip route add 239.0.0.0/8 dev lo
    URL="udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608"
    "$0/areomap-rover" --lcm "$URL" --exit-at-end --quiet --max-seconds 900 2> "$1/rover-udpm.err" &
    R=$!
    sleep 1
    S=$(date +%s.%N); lcm-logplayer -s 0 -l "$URL" "$2" >/dev/null 2>&1; E=$(date +%s.%N)
    echo "lcm-logplayer: $(echo "$E - $S" | bc) s for the whole log"
    wait $R
    grep -v listening "$1/rover-udpm.err"' "$BIN" "$WORK" "$LOG"
else
  echo "SKIP: unshare -n not permitted (needs root); run the rover and lcm-logplayer by hand"
fi
