#!/usr/bin/env bash
# Traverse soak: one SITES-site traverse through both nodes over udpm -- one areomap-rover and one
# areomap-ground --traverse for the whole run, the traverse's log (every site announced on AREOMAP_SITE)
# replayed by stock lcm-logplayer, paced so that the pairs arrive as a rover would send them.
# Checks:
#   - every site's products are written (sites/<id>/report.json, dem.tif) and the traverse's report.json;
#   - the rover's heap allocations after start-up stay 0 at every site (each site's report);
#   - the rover's resident memory stays flat: sampled through the run; its highest by the end of each site
#     (when the next site's announcement is replayed, the log's own timestamps from the replay's start) at
#     every site after the second at most GROWTH_PCT % + GROWTH_MIB MiB above the second's (its memory is
#     static: only the pages its first sites touch come in);
#   - the rover published a pose for every site (AREOMAP_SITE_POSE, rover_poses.csv);
#   - the position error is bounded: the ground's and the rover's poses no further from the truth than the
#     odometry's (report.json traverse.position_error_apriori_m), with no gap in the stream.
# The ground's resident memory is printed per site, not checked.
#
# Usage: run_traverse_soak.sh BUILD SCRATCH [SITES] [CAMERA] [SEED]
#   CAMERA: navcam-small (default; the camera of ./run.sh --traverse, whose sites register) or tiny.
# CTest (labels soak and long): 20 navcam-small sites; it sets AREOMAP_LONG_GATE=1, so the run is skipped
# unless AREOMAP_LONG_TESTS=1.
set -euo pipefail
BUILD=$1
SCRATCH=$2
SITES=${3:-20}
CAMERA=${4:-navcam-small}
SEED=${5:-1}
GROWTH_PCT=${GROWTH_PCT:-5}
GROWTH_MIB=${GROWTH_MIB:-8}
# Seconds between pairs in the log (areomap-pack --interval-s), replayed at that pace: more than the rover's
# time per pair, so that it keeps up with the stream.
INTERVAL_S=${INTERVAL_S:-1}
HERE=$(cd "$(dirname "$0")/../ground/node" && pwd)
source "$HERE/nodes_lib.sh"

if [[ -n "${AREOMAP_LONG_GATE:-}" && "${AREOMAP_LONG_TESTS:-}" != 1 ]]; then
  echo "SKIP: a ${SITES}-site traverse soak (about half an hour on 2 cores): set AREOMAP_LONG_TESTS=1 to run it"
  exit 77
fi
case "$CAMERA" in
  navcam-small) CAMERA_OPTIONS="--camera navcam --size 256 256 --pointing-error-px 0.75 3.75 --cell-m 0.03 --extent-m 15" ;;
  tiny) CAMERA_OPTIONS="--camera tiny" ;;
  *) fail "camera '$CAMERA': navcam-small or tiny" ;;
esac
if [[ "${AREOMAP_NETNS_INNER:-}" != 1 ]]; then
  mkdir -p "$SCRATCH"
  rm -rf "$SCRATCH/out" "$SCRATCH"/*.log "$SCRATCH"/rss.txt
fi
ensure_multicast "$0" "$@"

DATASET="$SCRATCH/traverse-$CAMERA-s$SITES"
options="--preset traverse $CAMERA_OPTIONS --sites $SITES --seed $SEED"
if [[ -f "$DATASET/traverse.json" && -f "$DATASET.options" && "$(cat "$DATASET.options")" == "$options" ]]; then
  echo "reusing $DATASET ($options)"
else
  rm -rf "$DATASET" "$DATASET.options"
  start=$SECONDS
  "$BUILD/bin/areomap-sim" $options --out "$DATASET" > "$SCRATCH/sim.log" 2>&1 || { tail "$SCRATCH/sim.log"; fail "areomap-sim $options"; }
  echo "$options" > "$DATASET.options"
  echo "areomap-sim $options: $(( SECONDS - start )) s"
fi
LOG="$SCRATCH/traverse.lcm"
"$BUILD/bin/areomap-pack" "$DATASET" --out "$LOG" --interval-s "$INTERVAL_S" > /dev/null 2>&1 || fail "areomap-pack"
mapfile -t IDS < <(python3 -c 'import json,sys; print("\n".join(s["id"] for s in json.load(open(sys.argv[1]))["sites"]))' "$DATASET/traverse.json")
URL=$(node_url)
OUT="$SCRATCH/out"

# The run lasts long enough for the pids to wrap: the exit statuses are kept by bg_start (nodes_lib.sh).
bg_start "$SCRATCH/ground.rc" "$BUILD/bin/areomap-ground" --lcm "$URL" --out "$OUT" --truth "$DATASET" --traverse \
  > "$SCRATCH/ground.out" 2> "$SCRATCH/ground.log"
GROUND=$BG_PID
bg_start "$SCRATCH/rover.rc" "$BUILD/bin/areomap-rover" --lcm "$URL" --exit-at-end --quiet \
  > "$SCRATCH/rover.out" 2> "$SCRATCH/rover.log"
ROVER=$BG_PID
# The rover's resident memory every 0.2 s while it runs.
( while kill -0 "$ROVER" 2> /dev/null; do echo "$(date +%s.%N) $(rss_kib "$ROVER")"; sleep 0.2; done ) \
  > "$SCRATCH/rover_rss.txt" &
SAMPLER=$!
trap 'kill $GROUND $ROVER $SAMPLER 2> /dev/null || true' EXIT
wait_listening "$SCRATCH/ground.log" "$SCRATCH/rover.log"
start_all=$SECONDS
date +%s.%N > "$SCRATCH/replay_start.txt"
bg_start "$SCRATCH/logplayer.rc" lcm-logplayer -s 1 --lcm-url="$URL" "$LOG" > "$SCRATCH/logplayer.log" 2>&1

# The ground's resident memory when each site's products appear.
: > "$SCRATCH/rss.txt"
limit_s=$(( 600 * SITES ))
for id in "${IDS[@]}"; do
  set +e
  wait_for "$OUT/sites/$id/report.json" $(( limit_s - (SECONDS - start_all) )) "$GROUND"
  rc=$?
  set -e
  [[ $rc -eq 0 ]] || { tail -n 20 "$SCRATCH/ground.log"; fail "site $id: no report.json (ground exited or timed out: $rc)"; }
  g=$(rss_kib "$GROUND")
  echo "$id $g $(( SECONDS - start_all ))" >> "$SCRATCH/rss.txt"
  echo "site $id: products after $(( SECONDS - start_all )) s; RSS ground $(( g / 1024 )) MiB"
done
bg_wait "$SCRATCH/logplayer.rc" || fail "lcm-logplayer"
set +e
wait_for "$OUT/report.json" 1800 "$GROUND"
bg_wait "$SCRATCH/rover.rc"
rover_rc=$?
bg_wait "$SCRATCH/ground.rc"
ground_rc=$?
set -e
kill "$SAMPLER" 2> /dev/null || true
trap - EXIT
[[ $ground_rc -eq 0 ]] || { tail -n 20 "$SCRATCH/ground.log"; fail "areomap-ground exited with $ground_rc"; }
[[ $rover_rc -eq 0 ]] || { tail -n 20 "$SCRATCH/rover.log"; fail "areomap-rover exited with $rover_rc"; }
echo "traverse soak: $SITES sites in $(( SECONDS - start_all )) s"

python3 - "$OUT" "$SCRATCH" "$GROWTH_PCT" "$GROWTH_MIB" "$SITES" "$LOG" <<'PY'
import json, os, struct, sys
out, scratch, pct, mib, sites, log = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5]), sys.argv[6]
rows = [l.split() for l in open(os.path.join(scratch, "rss.txt")) if l.strip()]
samples = [tuple(map(float, l.split())) for l in open(os.path.join(scratch, "rover_rss.txt")) if len(l.split()) == 2]
samples = [(t, kib) for t, kib in samples if kib > 0]
# When each site's announcement (AREOMAP_SITE) was replayed: the LCM log's event times (sync word, event
# number, utime, channel and data lengths, big-endian) from the replay's start, at speed 1.
events = []
with open(log, "rb") as f:
    while True:
        head = f.read(28)
        if len(head) < 28:
            break
        sync, _, utime, clen, dlen = struct.unpack(">IqqII", head)
        if sync != 0xEDA1DA01:
            break
        channel = f.read(clen).decode()
        f.seek(dlen, 1)
        events.append((utime, channel))
start = float(open(os.path.join(scratch, "replay_start.txt")).read())
arrivals = [start + (u - events[0][0]) / 1e6 for u, c in events if c == "AREOMAP_SITE"]
ok = True
def bad(msg):
    global ok
    print("FAIL: " + msg)
    ok = False
r = json.load(open(os.path.join(out, "report.json")))
t = r.get("traverse", {})
if len(rows) != sites:
    bad("%d of %d sites have products" % (len(rows), sites))
for row in rows:
    site = row[0]
    d = os.path.join(out, "sites", site)
    sr = json.load(open(os.path.join(d, "report.json")))
    rv, st = sr.get("rover", {}), sr.get("stream", {})
    print("site %s: %s pairs, %s gaps; rover heap after start-up %s; method 1 after %s px" % (
        site, st.get("pairs"), st.get("gaps"), rv.get("heap_allocs_after_init"),
        sr.get("method1_px", {}).get("after", {}).get("dist")))
    if rv.get("heap_allocs_after_init") != 0:
        bad("site %s: the rover's heap allocations after start-up are %s" % (site, rv.get("heap_allocs_after_init")))
    if st.get("gaps") != 0:
        bad("site %s: %s gaps in the stream" % (site, st.get("gaps")))
    if not os.path.exists(os.path.join(d, "dem.tif")):
        bad("site %s: no dem.tif" % site)
# The rover's resident memory by the end of each site: its highest before the next site's announcement
# (the last site: before it exited). Flat after the first sites: every later site within the second's limit.
ends = arrivals[1:] + [float("inf")]
rover = [max([kib for t, kib in samples if t <= end] or [0]) for end in ends]
if len(arrivals) != sites:
    bad("%d of %d site announcements seen in the ground's log" % (len(arrivals), sites))
elif len(rover) > 2:
    limit = rover[1] * (1 + pct / 100) + mib * 1024
    peak = max(rover[2:])
    print("RSS rover: site 1 %.1f MiB, site 2 %.1f MiB, last %.1f MiB, highest after site 2 %.1f MiB (limit %.1f MiB = "
          "site 2 + %g %% + %g MiB)" % (rover[0] / 1024, rover[1] / 1024, rover[-1] / 1024, peak / 1024, limit / 1024, pct, mib))
    if peak > limit:
        bad("the rover's RSS grew after the second site")
ground = [int(x[1]) for x in rows]
print("RSS ground: site 1 %.1f MiB, last %.1f MiB (printed, not checked)" % (
    ground[0] / 1024, ground[-1] / 1024))
apriori_m, after_m = t.get("position_error_apriori_m"), t.get("position_error_m")
print("position: %.1f m driven; a priori %.3f m (%.2f %%), ground after %.3f m (%.2f %%)" % (
    t.get("distance_m", float("nan")), apriori_m, t.get("position_error_apriori_pct"), after_m, t.get("position_error_pct")))
if not after_m <= apriori_m * (1 + 1e-9):
    bad("the ground's poses are further from the truth than the odometry's")
for p in t.get("site_pairs", []):
    print("pair %s-%s: %s, %s ties" % (p["site_a"], p["site_b"], p["status"], p["ties"]))
rp = r.get("rover_poses")
if not rp:
    bad("no site pose from the rover (AREOMAP_SITE_POSE)")
else:
    num = lambda k: float("nan") if rp.get(k) is None else rp[k]
    print("rover poses: %s sites, error %.3f m (%.2f %%); the ground over them %.3f m; %.3f m RMS apart" % (
        rp.get("sites"), num("position_error_m"), num("position_error_pct"), num("ground_position_error_m"),
        num("vs_ground_rms_m")))
    if rp.get("sites") != sites:
        bad("the rover published %s of %d site poses (missing %s)" % (rp.get("sites"), sites, rp.get("missing")))
    elif not rp.get("position_error_m") <= apriori_m * (1 + 1e-9):
        bad("the rover's poses are further from the truth than the odometry's")
sys.exit(0 if ok else 1)
PY
echo "traverse soak: ok"
