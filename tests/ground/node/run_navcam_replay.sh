#!/usr/bin/env bash
# The navcam panorama (areomap-sim --preset navcam --seed 1: 18 pairs of 1024x1024) packed and
# replayed at full speed (stock `lcm-logplayer -s 0`) over udpm on loopback to both nodes: the ground's
# collector (areomap-ground --stream-only) and the rover must see every pair: 0 sequence gaps, nothing
# rejected, every pair accepted by the rover and its final EO arrived.
# The dataset is made once and kept in $AREOMAP_NAVCAM_DATASET or BUILD_DIR/test-scratch/navcam-seed1-ss1
# (areomap-sim takes a few minutes on 2 shared cores; the replay test itself 1-3 min: the rover's panorama).
# Usage: run_navcam_replay.sh BUILD_DIR SCRATCH_DIR
set -euo pipefail
BUILD=$1
SCRATCH=$2
source "$(dirname "$0")/nodes_lib.sh"
node_test_start "$SCRATCH" "$0" "$@"
DATASET=${AREOMAP_NAVCAM_DATASET:-$BUILD/test-scratch/navcam-seed1-ss1}
mkdir -p "$(dirname "$DATASET")"
# One ray per pixel: what this test checks (transport at full speed, every pair taken by the rover) does not
# depend on the renderer's anti-aliasing, and one ray is a quarter of the sim's work.
make_dataset navcam "$DATASET" --supersample 1
"$BUILD/bin/areomap-pack" "$DATASET" --out "$SCRATCH/navcam.lcm" > /dev/null 2>&1 || fail "areomap-pack"
URL=$(node_url)
rmem=$(sysctl -n net.core.rmem_max 2> /dev/null || echo 0)
[[ "$rmem" -ge 67108864 || $(id -u) -ne 0 ]] || sysctl -q -w net.core.rmem_max=67108864 || true
echo "net.core.rmem_max $(sysctl -n net.core.rmem_max 2> /dev/null || echo '?')"

"$BUILD/bin/areomap-ground" --lcm "$URL" --out "$SCRATCH/ground" --stream-only --rover-silent-s 30 \
  > "$SCRATCH/ground.out" 2> "$SCRATCH/ground.log" &
GROUND=$!
"$BUILD/bin/areomap-rover" --lcm "$URL" --exit-at-end --quiet > "$SCRATCH/rover.out" 2> "$SCRATCH/rover.log" &
ROVER=$!
wait_listening "$SCRATCH/ground.log" "$SCRATCH/rover.log"
start=$(date +%s%N)
lcm-logplayer -s 0 --lcm-url="$URL" "$SCRATCH/navcam.lcm" > /dev/null 2>&1 || fail "lcm-logplayer"
echo "lcm-logplayer -s 0: $(stat -c %s "$SCRATCH/navcam.lcm") bytes in $(( ($(date +%s%N) - start) / 1000000 )) ms"
wait "$ROVER" || fail "areomap-rover exited $?"
wait "$GROUND" || { tail "$SCRATCH/ground.log"; fail "areomap-ground exited $?"; }
cat "$SCRATCH/ground.out"
pairs=$(python3 -c "import json,sys; print(len(json.load(open(sys.argv[1]))['pairs']))" "$DATASET/panorama.json")
grep -q "^stream: $pairs pairs, 0 gaps, 0 duplicates, 0 reordered, 0 rejected;" "$SCRATCH/ground.out" \
  || fail "the ground's collector did not get all $pairs pairs without a gap"
grep -q "^rover: $pairs pairs seen, $pairs accepted, 0 rejected, 0 binned, 0 sequence gaps; $pairs tie-point messages (0 lost); heap allocations after start-up 0; final EO arrived" \
  "$SCRATCH/ground.out" || fail "the rover did not take all $pairs pairs without a gap"
echo "navcam replay: ok ($pairs pairs, 0 gaps at the ground and at the rover)"
