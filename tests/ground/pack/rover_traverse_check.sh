#!/bin/sh
# The rover's own site poses against the truth, on traverses at hand: each TRAVERSE (an areomap-sim
# --preset traverse folder, with truth/traverse.json) is packed (areomap-pack), replayed into areomap-rover
# over file:// with its results published to a file, and the last AREOMAP_SITE_POSE of each site is set
# against the true pose (horizontal error, error along z, heading error), beside the rover's line per leg
# (registration, ties, refusals). No ground node: the figure is the rover's alone.
# usage: tests/ground/pack/rover_traverse_check.sh BUILD_DIR TRAVERSE...
set -eu
[ $# -ge 2 ] || { echo "usage: $0 BUILD_DIR TRAVERSE..." >&2; exit 2; }
BIN=$1/bin
shift
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
for T in "$@"; do
  [ -f "$T/truth/traverse.json" ] || { echo "$T: no truth/traverse.json" >&2; exit 2; }
  echo "== $T"
  "$BIN/areomap-pack" "$T" --out "$WORK/stream.lcm" --interval-s 0 >"$WORK/pack.log" 2>&1 ||
    { cat "$WORK/pack.log" >&2; exit 1; }
  rm -f "$WORK/poses.lcm"
  "$BIN/areomap-rover" --lcm "file://$WORK/stream.lcm" --publish "file://$WORK/poses.lcm?mode=w" --exit-at-end \
    2>&1 | grep -E "cross-site ties \(|traverse:" | sed 's/^areomap-rover: /  /'
  python3 - "$WORK/poses.lcm" "$T/truth/traverse.json" <<'PY'
import json, math, struct, sys

def events(path):  # the LCM log format: sync, event number, time, channel and data lengths, channel, data
    b = open(path, "rb").read()
    i = 0
    while i + 28 <= len(b):
        _, _, _, cl, dl = struct.unpack(">IqqII", b[i:i + 28])
        i += 28
        yield b[i:i + cl].decode(), b[i + cl:i + cl + dl]
        i += cl + dl

def string(d, o):
    n = struct.unpack(">i", d[o:o + 4])[0]
    return d[o + 4:o + 3 + n].decode(), o + 4 + n

last = {}
for channel, d in events(sys.argv[1]):
    if channel != "AREOMAP_SITE_POSE":
        continue
    o = 8 + 16  # fingerprint, utime, sequence (msgs/site_pose_t.lcm)
    _, o = string(d, o)
    site, o = string(d, o)
    o += 4
    _, o = string(d, o)
    o += 4
    position = struct.unpack(">3d", d[o:o + 24])
    o += 24 + 72
    heading = struct.unpack(">d", d[o:o + 8])[0]
    o += 8 + 36 * 8 + 48
    status, ties = struct.unpack(">bi", d[o:o + 5])
    last[site] = (position, heading, status, ties)
names = {1: "datum", 2: "tied", 3: "odometry", 4: "held", 5: "failed"}
for s in json.load(open(sys.argv[2]))["sites"]:
    if s["id"] not in last:
        print("  %s: no pose published" % s["id"])
        continue
    (x, y, z), h, status, ties = last[s["id"]]
    t = s["pose"]["position_m"]
    print("  %s: %s, %d tie observations; error %.4f m horizontal, %+.4f m z, heading %+.3f deg"
          % (s["id"], names.get(status, status), ties, math.hypot(x - t[0], y - t[1]), z - t[2],
             h - s["pose"]["heading_deg"]))
PY
done
