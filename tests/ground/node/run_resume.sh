#!/usr/bin/env bash
# Kill-and-resume on the tiny panorama: areomap-ground and areomap-rover as separate
# processes over udpm, the camera stream from stock lcm-logplayer at full speed.
#   1. an uninterrupted pass: the reference products;
#   2. the same, with the ground killed (SIGKILL) in the middle of its pass (after the stream and the rover's
#      results arrived, while it writes its products): no report.json, i.e. no finished product set;
#   3. the ground restarted on its own recording (`--lcm file://OUT/received.lcm --out OUT`): the same
#      products as the reference, byte for byte (eo.csv, tiepoints.csv, rover_tiepoints.csv, models/,
#      rover_models/), with the rover's tie points (ground.tie_source = rover).
# The DEM/ortho products are made in step 2 only (so that the kill lands inside the pass, whose products
# stage takes a minute on tiny); steps 1 and 3 make the adjustment products (--no-products).
# Usage: run_resume.sh BUILD_DIR SCRATCH_DIR
set -euo pipefail
BUILD=$1
SCRATCH=$2
source "$(dirname "$0")/nodes_lib.sh"
node_test_start "$SCRATCH" "$0" "$@"
make_dataset tiny "$SCRATCH/tiny"
"$BUILD/bin/areomap-pack" "$SCRATCH/tiny" --out "$SCRATCH/tiny.lcm" > /dev/null 2>&1 || fail "areomap-pack"
URL=$(node_url)

# pass NAME [ground options...]: ground + rover over udpm, replay; the ground's PID in GROUND_PID (not waited).
pass() {
  local name=$1
  shift
  rm -rf "$SCRATCH/$name"
  "$BUILD/bin/areomap-ground" --lcm "$URL" --out "$SCRATCH/$name" "$@" \
    > "$SCRATCH/$name.out" 2> "$SCRATCH/$name.log" &
  GROUND_PID=$!
  "$BUILD/bin/areomap-rover" --lcm "$URL" --exit-at-end --quiet > "$SCRATCH/$name.rover.out" 2>&1 &
  ROVER_PID=$!
  wait_listening "$SCRATCH/$name.log" "$SCRATCH/$name.rover.out"
  lcm-logplayer -s 0 --lcm-url="$URL" "$SCRATCH/tiny.lcm" > /dev/null 2>&1 || fail "lcm-logplayer"
}

# 1. Reference.
pass reference --no-products
wait "$ROVER_PID" || fail "rover (reference) exited $?"
wait "$GROUND_PID" || { tail "$SCRATCH/reference.log"; fail "ground (reference) exited $?"; }

# 2. Killed inside its pass.
pass killed
wait_for_log() {
  local start=$SECONDS
  until grep -q "$1" "$SCRATCH/killed.log" 2> /dev/null; do
    kill -0 "$GROUND_PID" 2> /dev/null || return 1
    (( SECONDS - start > 300 )) && return 2
    sleep 0.1
  done
}
wait_for_log "integrated adjustment" || { tail "$SCRATCH/killed.log"; fail "the ground never reached its integrated adjustment"; }
sleep 1
kill -KILL "$GROUND_PID"
set +e
wait "$GROUND_PID"
rc=$?
set -e
wait "$ROVER_PID" || true
[[ $rc -eq 137 ]] || fail "the ground was not killed mid-pass (exit $rc): it finished first?"
[[ ! -f "$SCRATCH/killed/report.json" ]] || fail "report.json exists: the kill came after the pass"
echo "killed: ground SIGKILLed in its pass ($(tail -n 1 "$SCRATCH/killed.log")); $(stat -c %s "$SCRATCH/killed/received.lcm") bytes recorded"

# 3. Restarted on its recording, into the same folder.
"$BUILD/bin/areomap-ground" --lcm "file://$SCRATCH/killed/received.lcm" --out "$SCRATCH/killed" --no-products \
  > "$SCRATCH/resumed.out" 2> "$SCRATCH/resumed.log" || { tail "$SCRATCH/resumed.log"; fail "the restarted ground exited $?"; }
grep '^stream:' "$SCRATCH/resumed.out"
python3 - "$SCRATCH/reference/report.json" "$SCRATCH/killed/report.json" <<'PY'
import json, sys
ref, res = (json.load(open(p)) for p in sys.argv[1:])
for name, r in (("reference", ref), ("resumed", res)):
    print("%s: tie_source %s, stream %s, rover eo_vs_ground_px %s, method1 after %.4f px" % (
        name, r["ground"]["tie_source"], {k: r["stream"][k] for k in ("pairs", "gaps", "duplicates")},
        r["rover"].get("eo_vs_ground_px"), r["method1_px"]["after"]["dist"]))
assert ref["ground"]["tie_source"] == "rover", "the reference used the rover's ties"
assert res["ground"]["tie_source"] == "rover", "the resumed pass used the rover's ties from the recording"
assert res["stream"] == ref["stream"], "the same stream figures"
PY
same_products "$SCRATCH/reference" "$SCRATCH/killed" || fail "the resumed products differ from the reference"
echo "resume: ok"
