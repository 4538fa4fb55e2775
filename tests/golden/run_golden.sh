#!/usr/bin/env bash
# Golden output on one cross target (CTest label `golden`, registered by tests/golden/CMakeLists.txt
# in the cross builds). In one run: the native build makes a small `tiny` panorama (areomap-sim) and its
# camera-stream log (areomap-pack); the native golden_rover and this target's golden_rover (under qemu) run
# the rover pipeline on that log; compare_golden.py compares tie points (identical lists) and the final EO
# (within the stated tolerance). Nothing golden is stored: the solver changes, both sides run now.
# Usage: run_golden.sh TARGET_NAME TARGET_GOLDEN_ROVER HOST_BUILD SCRATCH EMULATOR [EMULATOR ARGS...]
#   HOST_BUILD is overridden by the environment variable AREOMAP_HOST_BUILD.
#   AREOMAP_GOLDEN_SIM overrides the simulator options (default below: 3 pairs of tiny, ~1 min under qemu).
# Exit: 0 same answers, 1 different or a step failed, 77 skipped (the native build lacks the tools), 2 usage.
set -euo pipefail
[[ $# -ge 5 ]] || { echo "usage: run_golden.sh TARGET_NAME TARGET_GOLDEN_ROVER HOST_BUILD SCRATCH EMULATOR..." >&2; exit 2; }
TARGET=$1
TARGET_ROVER=$2
HOST=${AREOMAP_HOST_BUILD:-$3}
SCRATCH=$4
shift 4
EMULATOR=("$@")
HERE=$(cd "$(dirname "$0")" && pwd)
SIM_OPTIONS=${AREOMAP_GOLDEN_SIM:---preset tiny --seed 1 --pairs 3 --threads 2}
fail() { echo "FAIL golden $TARGET: $*" >&2; exit 1; }

for f in bin/areomap-sim bin/areomap-pack tests/golden_rover; do
  if [[ ! -x "$HOST/$f" ]]; then
    echo "SKIP golden $TARGET: the native build $HOST has no $f (build the native preset first, or set AREOMAP_HOST_BUILD)"
    exit 77
  fi
done
[[ -x "$TARGET_ROVER" ]] || fail "no $TARGET_ROVER"
rm -rf "$SCRATCH"
mkdir -p "$SCRATCH"

# The input: made natively, consumed by both.
"$HOST/bin/areomap-sim" $SIM_OPTIONS --out "$SCRATCH/dataset" > "$SCRATCH/sim.log" 2>&1 || { cat "$SCRATCH/sim.log"; fail "areomap-sim $SIM_OPTIONS"; }
"$HOST/bin/areomap-pack" "$SCRATCH/dataset" --out "$SCRATCH/stream.lcm" > "$SCRATCH/pack.log" 2>&1 || { cat "$SCRATCH/pack.log"; fail "areomap-pack"; }
echo "golden $TARGET: input areomap-sim $SIM_OPTIONS, log $(stat -c %s "$SCRATCH/stream.lcm") bytes"

# run NAME CMD...: runs CMD, prints its stage line and its user CPU seconds.
run() {
  local name=$1
  shift
  local start
  start=$(date +%s%N)
  "$@" "$SCRATCH/stream.lcm" "$SCRATCH/$name.csv" 2> "$SCRATCH/$name.log" || { cat "$SCRATCH/$name.log"; fail "$name golden_rover exited $?"; }
  echo "golden $TARGET: $name: $(grep '^golden_rover: pairs' "$SCRATCH/$name.log" | sed 's/^golden_rover: //') (process $(( ($(date +%s%N) - start) / 1000000 )) ms)"
}
run native "$HOST/tests/golden_rover"
run "$TARGET" "${EMULATOR[@]}" "$TARGET_ROVER"

python3 "$HERE/compare_golden.py" "$SCRATCH/native.csv" "$SCRATCH/$TARGET.csv" --label "golden $TARGET" || fail "outputs differ"
