#!/usr/bin/env bash
# The main job (README command 1, after ./setup.sh): a synthetic panorama (areomap-sim --preset navcam) or a
# real dataset folder -> areomap-pack (LCM log of the camera stream) -> stock lcm-logplayer replays it over
# udpm on loopback to areomap-rover and areomap-ground -> products and a one-screen summary. See usage().
set -euo pipefail
cd "$(dirname "$0")"
ROOT=$(pwd)

usage() {
  cat <<'EOF'
usage: ./run.sh [--dataset DIR | --preset NAME] [--out DIR] [--speed S] [--transport auto|udpm|netns|file]
       ./run.sh --traverse [--sites N] [--camera C] [--seed S] [--stop-spacing-m D] [--truth-cross-ties] [--out DIR] [--speed S]
                [--transport T]
       ./run.sh --dataset TRAVERSE_DIR (a folder with traverse.json: as --traverse on it)

Makes (or reuses) a dataset, packs it into an LCM log, starts areomap-ground and areomap-rover on a udpm
URL of loopback (ttl=0, 8 MiB receive buffers), replays the log with stock lcm-logplayer, waits for the
products and prints a summary; the last line is `products: <dir>`.

  --dataset DIR   a real dataset folder (panorama.json; truth figures when DIR/truth exists), or a folder
                  of frames as downloaded (raw-image records with their images, PDS3/VICAR/PDS4
                  products): areomap-dataset makes a dataset per rover position, each is mapped, and a
                  summary per position (pairs, ties, method 1, matching noise, DEM coverage) follows
  --preset NAME   areomap-sim preset when no --dataset (default navcam); reused from OUT/NAME when it was
                  made with the same options
  --out DIR       work and product folder (default out/); products in OUT/products-<name>
  --speed S       lcm-logplayer speed (default 0 = as fast as possible)
  --transport T   auto (default): udpm on this host when a multicast route exists, else udpm in a private
                  network namespace (unshare -n, lo up, route 239.0.0.0/8 dev lo), else file replay
                  (the ground reads the log itself; the rover replays it apart)
  --build DIR     build folder with bin/ (default build, or $AREOMAP_BUILD_DIR)

A multi-site traverse over the same stream (issue 21): --traverse makes (or reuses) a traverse with
areomap-sim --preset traverse into OUT/traverse-C-sN-seedS, packs it (each site announced on AREOMAP_SITE,
then its pairs and end-of-panorama marker), and the two nodes map it site after site: the rover adjusts and
publishes each site's pass as it arrives, the ground (areomap-ground --traverse) writes each site's
products into OUT/products-NAME/sites/<id>/ and, after the last site, the traverse steps of
areomap-traverse (poses.csv, the rover's own poses as rover_poses.csv, the merged dem.tif / dem_sigma.tif /
ortho.tif, report.json). The summary gives
the sites, the distance driven, the position error a priori and after, the cross-site ties and the merged
DEM's RMSE against the truth.

  --traverse      map a multi-site traverse (above)
  --sites N       sites of the simulated traverse (default 3)
  --camera C      camera of each site: navcam-small (default), tiny, imp, navcam, fido. navcam-small is
                  the navcam preset at 256 x 256 pixels with its angular pointing errors (0.75-3.75 px) on
                  a 3 cm terrain: its sites register and tie, so the run shows the sites localised, within
                  minutes on 2 cores; a full navcam site has up to 5 min of simulation and 10 min of ground
                  pass in the DESIGN.md budgets, so 3 navcam sites would take up to ~45 min
  --seed S        traverse seed (default 1)
  --stop-spacing-m D  traversing stops (default 0: none): the rover also stops at least every D m on each
                  leg and takes a few stereo pairs looking forward (areomap-sim --stop-spacing-m); each
                  stop is a site of its own on the stream (site_t kind KIND_STOP), tying the sites around it
  --truth-cross-ties  the sites' poses from the multi-site adjustment with cross-site ties made from the
                  synthetic traverse's truth (0.3 px noise; areomap-traverse --truth-cross-ties): a check
                  of the adjustment, not a measurement. Without it the ground matches the received
                  sites itself, as areomap-traverse does (report.json traverse.site_pairs); a pair left
                  untied is warned and its poses rest on the odometry
EOF
}

DATASET=""
PRESET=navcam
TRAVERSE=0
CROSS_TIES=()
SITES=3
STOP_SPACING=0
CAMERA=navcam-small
SEED=1
OUT=out
SPEED=0
TRANSPORT=auto
BUILD=${AREOMAP_BUILD_DIR:-build}
ARGS=("$@")
while [[ $# -gt 0 ]]; do
  case "$1" in
    --help|-h) usage; exit 0 ;;
    --dataset) DATASET=${2:?--dataset needs a folder}; shift 2 ;;
    --preset) PRESET=${2:?--preset needs a name}; shift 2 ;;
    --out) OUT=${2:?--out needs a folder}; shift 2 ;;
    --speed) SPEED=${2:?--speed needs a number}; shift 2 ;;
    --transport) TRANSPORT=${2:?--transport needs auto, udpm, netns or file}; shift 2 ;;
    --build) BUILD=${2:?--build needs a folder}; shift 2 ;;
    --traverse) TRAVERSE=1; shift ;;
    --sites) SITES=${2:?--sites needs a number}; shift 2 ;;
    --camera) CAMERA=${2:?--camera needs a preset}; shift 2 ;;
    --seed) SEED=${2:?--seed needs a number}; shift 2 ;;
    --stop-spacing-m) STOP_SPACING=${2:?--stop-spacing-m needs metres}; shift 2 ;;
    --truth-cross-ties) CROSS_TIES=(--truth-cross-ties); shift ;;
    *) echo "run: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case "$TRANSPORT" in auto|udpm|netns|file|netns-inner) ;; *) echo "run: --transport: '$TRANSPORT'" >&2; exit 2 ;; esac

[[ "$SITES" =~ ^[0-9]+$ && "$SITES" -ge 1 ]] || { echo "run: --sites: '$SITES' is not a whole number >= 1" >&2; exit 2; }
[[ "$SEED" =~ ^[0-9]+$ ]] || { echo "run: --seed: '$SEED' is not a whole number" >&2; exit 2; }
[[ "$STOP_SPACING" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "run: --stop-spacing-m: '$STOP_SPACING' is not a number of metres" >&2; exit 2; }
case "$CAMERA" in
  navcam-small) CAMERA_OPTIONS="--camera navcam --size 256 256 --pointing-error-px 0.75 3.75 --cell-m 0.03 --extent-m 15" ;;
  tiny|imp|navcam|fido) CAMERA_OPTIONS="--camera $CAMERA" ;;
  *) echo "run: --camera: '$CAMERA' (navcam-small, tiny, imp, navcam or fido)" >&2; exit 2 ;;
esac
[[ -n "$DATASET" && -f "$DATASET/traverse.json" ]] && TRAVERSE=1

BIN="$BUILD/bin"
TOOLS=(areomap-sim areomap-pack areomap-rover areomap-ground)
missing=()
for t in "${TOOLS[@]}"; do [[ -x "$BIN/$t" ]] || missing+=("$t"); done
if [[ ${#missing[@]} -gt 0 ]]; then
  if [[ -f "$BUILD/build.ninja" || -f "$BUILD/Makefile" ]]; then
    echo "run: building ${missing[*]} in $BUILD"
    cmake --build "$BUILD" --target "${missing[@]}" -j2
  else
    echo "run: $BIN lacks ${missing[*]}: run ./setup.sh first" >&2
    exit 1
  fi
fi
command -v lcm-logplayer > /dev/null || { echo "run: lcm-logplayer not found (Debian package liblcm-bin): run ./setup.sh" >&2; exit 1; }
mkdir -p "$OUT"
OUT=$(cd "$OUT" && pwd)

# map_frames: $DATASET is a folder of frames as downloaded (raw-image records, PDS3/VICAR/PDS4 products).
# areomap-dataset turns them into OUT/BASE/datasets/<position>/ (index.json lists them and what it left
# out); each position is then mapped by this script into OUT/BASE/<position>/products-<position>; a summary
# per position follows, and the last line names OUT/BASE.
map_frames() {
  local base frames_out index rc=0
  base=$(basename "$(cd "$DATASET" && pwd)")
  frames_out="$OUT/$base"
  [[ -x "$BIN/areomap-dataset" ]] || cmake --build "$BUILD" --target areomap-dataset -j2
  echo "run: areomap-dataset $DATASET --out $frames_out/datasets"
  "$BIN/areomap-dataset" "$DATASET" --out "$frames_out/datasets" || rc=$?
  index="$frames_out/datasets/index.json"
  [[ -f "$index" ]] || { echo "run: areomap-dataset wrote no $index" >&2; return 1; }
  [[ $rc -eq 0 ]] || echo "run: areomap-dataset exited with $rc: some inputs were left out ($index \"skipped\")"
  local names
  mapfile -t names < <(python3 -c 'import json,sys; [print(d["name"]) for d in json.load(open(sys.argv[1]))["datasets"]]' "$index")
  [[ ${#names[@]} -gt 0 ]] || { echo "run: no dataset could be made from $DATASET" >&2; return 1; }
  local failed=0 name
  for name in "${names[@]}"; do
    echo "run: --- position $name"
    "$0" --dataset "$frames_out/datasets/$name" --out "$frames_out/$name" --speed "$SPEED" \
      --transport "$TRANSPORT" --build "$BUILD" | sed '/^products: /d' || { failed=$((failed + 1)); echo "run: position $name failed" >&2; }
  done
  python3 - "$frames_out" "${names[@]}" <<'PYEOF'
import json, os, sys
root, names = sys.argv[1], sys.argv[2:]
def num(v, fmt):
    return fmt % v if isinstance(v, (int, float)) else "n/a"
print("=" * 78)
index = json.load(open(os.path.join(root, "datasets", "index.json")))
print("frames:    %d positions; %d inputs left out (%s)" % (
    len(index.get("datasets", [])), len(index.get("skipped", [])), os.path.join(root, "datasets", "index.json")))
for name in names:
    products = os.path.join(root, name, "products-" + name)
    try:
        r = json.load(open(os.path.join(products, "report.json")))
    except Exception as e:
        print("%s: no products (%s)" % (name, e))
        continue
    m1 = r.get("method1_px", {})
    tp = r.get("tie_points", {})
    sigmas = [p.get("match_sigma_px") for p in r.get("dense", {}).get("pairs", [])]
    noise = " / ".join("%.3f" % v for v in sigmas if isinstance(v, (int, float))) or None
    cov = r.get("dem_coverage", {}).get("fraction_2_10m")
    print("%s: %s pairs, ties %s intra + %s inter (%s rejected), method 1 %s -> %s px, matching noise %s px, "
          "DEM coverage %s of what both cameras see at 2-10 m" % (
        name, r.get("stream", {}).get("pairs", len(r.get("pairs", [])) or "n/a"), tp.get("intra"), tp.get("inter"),
        tp.get("rejected"), num(m1.get("before", {}).get("dist"), "%.3f"), num(m1.get("after", {}).get("dist"), "%.3f"),
        noise or "n/a", num(100 * cov, "%.1f %%") if isinstance(cov, (int, float)) else "n/a"))
    print("    products: %s" % products)
print("=" * 78)
PYEOF
  echo "products: $frames_out"
  [[ $failed -eq 0 ]]
}

# 1. The dataset (INDEX: panorama.json, or traverse.json for a traverse).
INDEX=panorama.json
[[ $TRAVERSE -eq 1 ]] && INDEX=traverse.json
# simulate: areomap-sim $SIM_OPTIONS into $DATASET, reused when $DATASET/$INDEX exists and was made with the
# same options ($DATASET.options).
simulate() {
  [[ "$TRANSPORT" == netns-inner ]] && return 0
  if [[ -f "$DATASET/$INDEX" && -f "$DATASET.options" && "$(cat "$DATASET.options")" == "$SIM_OPTIONS" ]]; then
    echo "run: reusing $DATASET (areomap-sim $SIM_OPTIONS)"
    return 0
  fi
  echo "run: areomap-sim $SIM_OPTIONS --out $DATASET"
  rm -rf "$DATASET" "$DATASET.options"
  local start
  start=$(date +%s)
  "$BIN/areomap-sim" $SIM_OPTIONS --out "$DATASET"
  echo "$SIM_OPTIONS" > "$DATASET.options"
  echo "run: dataset made in $(( $(date +%s) - start )) s"
}
# A folder of downloaded frames (no panorama.json, no traverse.json): areomap-dataset makes one dataset per
# rover position, and each is mapped by the job below (a run of this script per position).
if [[ -n "$DATASET" && -d "$DATASET" && ! -f "$DATASET/panorama.json" && ! -f "$DATASET/traverse.json" \
      && "$TRANSPORT" != netns-inner ]]; then
  map_frames
  exit $?
fi
if [[ -n "$DATASET" ]]; then
  [[ -f "$DATASET/$INDEX" ]] || { echo "run: $DATASET/$INDEX: no such file" >&2; exit 1; }
  DATASET=$(cd "$DATASET" && pwd)
  NAME=$(basename "$DATASET")
elif [[ $TRAVERSE -eq 1 ]]; then
  NAME="traverse-$CAMERA-s$SITES-seed$SEED"
  [[ "$STOP_SPACING" != 0 ]] && NAME="$NAME-stops$STOP_SPACING"
  DATASET="$OUT/$NAME"
  SIM_OPTIONS="--preset traverse $CAMERA_OPTIONS --sites $SITES --seed $SEED --stop-spacing-m $STOP_SPACING"
  simulate
else
  NAME=$PRESET
  DATASET="$OUT/$PRESET"
  SIM_OPTIONS="--preset $PRESET --seed 1"
  simulate
fi
TRUTH=()
[[ -d "$DATASET/truth" ]] && TRUTH=(--truth "$DATASET")
GROUND_MODE=()
[[ $TRAVERSE -eq 1 ]] && GROUND_MODE=(--traverse "${CROSS_TIES[@]}")
if [[ ${#CROSS_TIES[@]} -gt 0 && ( $TRAVERSE -ne 1 || ${#TRUTH[@]} -eq 0 ) ]]; then
  echo "run: --truth-cross-ties needs a traverse with truth/" >&2
  exit 2
fi
LOG="$OUT/$NAME.lcm"
PRODUCTS="$OUT/products-$NAME"

# 2. The camera stream as an LCM log.
if [[ "$TRANSPORT" != netns-inner ]]; then
  if [[ -f "$LOG" && "$LOG" -nt "$DATASET/$INDEX" ]]; then
    echo "run: reusing $LOG"
  else
    echo "run: areomap-pack $DATASET --out $LOG"
    "$BIN/areomap-pack" "$DATASET" --out "$LOG" --interval-s 2
  fi
fi

# timed NAME CMD...: runs CMD, its peak RSS (KiB) into OUT/NAME.rss when GNU time is installed.
timed() {
  local name=$1
  shift
  if [[ -x /usr/bin/time ]]; then
    /usr/bin/time -f "%M" -o "$OUT/$name.rss" "$@"
  else
    "$@"
  fi
}

# 3. The nodes over udpm, and the replay.
# A full-speed replay delivers the whole panorama (~15 MB for navcam) in milliseconds while the rover takes
# about a second per pair: what its static inbox (14 MiB) cannot hold waits in the kernel's socket buffer,
# so that buffer is sized for a whole panorama (kernel memory, outside the rover's static budget).
RECV_BUF_BYTES=67108864
run_udpm() {
  local url="udpm://239.255.76.67:$(( 20000 + $$ % 20000 ))?ttl=0&recv_buf_size=$RECV_BUF_BYTES"
  rm -rf "$PRODUCTS"
  local rmem
  rmem=$(sysctl -n net.core.rmem_max 2> /dev/null || echo 0)
  if [[ "$rmem" -lt $RECV_BUF_BYTES && $(id -u) -eq 0 ]]; then
    sysctl -q -w net.core.rmem_max=$RECV_BUF_BYTES && echo "run: raised net.core.rmem_max from $rmem to $RECV_BUF_BYTES (UDP receive buffers)"
  elif [[ "$rmem" -lt $RECV_BUF_BYTES ]]; then
    echo "run: warning: net.core.rmem_max is $rmem (< $RECV_BUF_BYTES) and this is not root: a full-speed replay may lose pairs (counted as gaps)"
  fi
  echo "run: url $url"
  timed ground "$BIN/areomap-ground" --lcm "$url" --out "$PRODUCTS" "${TRUTH[@]}" "${GROUND_MODE[@]}" \
    > "$OUT/ground.out" 2> "$OUT/ground.log" &
  local ground=$!
  timed rover "$BIN/areomap-rover" --lcm "$url" --exit-at-end --quiet \
    > "$OUT/rover.out" 2> "$OUT/rover.log" &
  local rover=$!
  # Replay only once both nodes listen (a busy machine can take seconds to start the ground's libraries;
  # a replay before that is lost to it).
  local waited=0
  until grep -q "listening on" "$OUT/ground.log" 2> /dev/null && grep -q "listening on" "$OUT/rover.log" 2> /dev/null; do
    kill -0 "$ground" 2> /dev/null && kill -0 "$rover" 2> /dev/null || break
    (( waited++ < 600 )) || { echo "run: the nodes did not start listening within 60 s" >&2; break; }
    sleep 0.1
  done
  sleep 0.5
  local start
  start=$(date +%s%N)
  lcm-logplayer -s "$SPEED" --lcm-url="$url" "$LOG" > "$OUT/logplayer.log" 2>&1
  echo "run: lcm-logplayer -s $SPEED replayed $LOG in $(( ($(date +%s%N) - start) / 1000000 )) ms"
  echo "run: waiting for the rover's final adjustment and the ground's products (progress: $OUT/ground.log)"
  local rover_rc=0 ground_rc=0
  wait "$rover" || rover_rc=$?
  wait "$ground" || ground_rc=$?
  [[ $rover_rc -eq 0 ]] || echo "run: areomap-rover exited with $rover_rc (see $OUT/rover.log)"
  if [[ $ground_rc -ne 0 ]]; then
    echo "run: areomap-ground exited with $ground_rc; its last lines:" >&2
    tail -n 20 "$OUT/ground.log" >&2
    return 1
  fi
}

run_file() {
  rm -rf "$PRODUCTS"
  echo "run: file replay: the rover replays the log apart (its figures in $OUT/rover.log); the ground reads the log itself"
  timed rover "$BIN/areomap-rover" --lcm "file://$LOG" --quiet \
    > "$OUT/rover.out" 2> "$OUT/rover.log" || echo "run: areomap-rover exited with $? (see $OUT/rover.log)"
  timed ground "$BIN/areomap-ground" --lcm "file://$LOG" --out "$PRODUCTS" "${TRUTH[@]}" "${GROUND_MODE[@]}" \
    > "$OUT/ground.out" 2> "$OUT/ground.log" || { tail -n 20 "$OUT/ground.log" >&2; return 1; }
}

RAN=""
case "$TRANSPORT" in
  netns-inner)
    ip link set lo up && ip route add 239.0.0.0/8 dev lo
    run_udpm
    exit 0 ;;
  udpm) run_udpm; RAN="udpm on this host (loopback, ttl=0)" ;;
  netns)
    unshare -n "$0" "${ARGS[@]}" --out "$OUT" --transport netns-inner
    RAN="udpm in a private network namespace (unshare -n; lo up; route 239.0.0.0/8 dev lo)" ;;
  file) run_file; RAN="file replay (file://$LOG)" ;;
  auto)
    if ip route get 239.255.76.67 > /dev/null 2>&1; then
      run_udpm
      RAN="udpm on this host (loopback, ttl=0; a multicast route exists)"
    elif unshare -n true 2> /dev/null; then
      echo "run: no multicast route on this host: udpm in a private network namespace"
      unshare -n "$0" "${ARGS[@]}" --out "$OUT" --transport netns-inner
      RAN="udpm in a private network namespace (no multicast route on the host)"
    else
      echo "run: no multicast route and no network namespace (unshare -n refused): file replay"
      run_file
      RAN="file replay (no multicast route, no network namespace)"
    fi ;;
esac

# 4. The summary.
if [[ $TRAVERSE -eq 1 ]]; then
  python3 - "$PRODUCTS" "$RAN" "$OUT" "$DATASET" <<'EOF'
import json, math, os, sys
products, ran, out, dataset = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
r = json.load(open(os.path.join(products, "report.json")))
t = r.get("traverse", {})
s = r.get("stream", {})
def num(v, fmt):
    return fmt % v if isinstance(v, (int, float)) else "n/a"
def rss(name):
    try:
        return "%.0f MiB" % (int(open(os.path.join(out, name + ".rss")).read().split()[-1]) / 1024)
    except Exception:
        return "n/a"
print("=" * 78)
print("transport: %s" % ran)
mapped = sum(1 for x in t.get("site", []) if x.get("mapped"))
stops = " (%s traversing stops)" % t["stops"] if t.get("stops") else ""
print("traverse:  %s sites%s (%d mapped), %s m driven; site announcements %s accepted, rejected %s" % (
    t.get("sites"), stops, mapped, num(t.get("distance_m"), "%.1f"), s.get("sites_announced"), s.get("rejected") or "none"))
print("position:  error %s m a priori (%s %% of the distance) -> %s m after (%s %%)" % (
    num(t.get("position_error_apriori_m"), "%.3f"), num(t.get("position_error_apriori_pct"), "%.2f"),
    num(t.get("position_error_m"), "%.3f"), num(t.get("position_error_pct"), "%.2f")))
print("ties:      cross-site ties %s (method 1 %s px)" % (t.get("cross_site_ties"), num(t.get("cross_site_method1_px"), "%.3f")))
for p in t.get("site_pairs", []):
    print("pair %s-%s: %s, %s ties" % (p["site_a"], p["site_b"], p["status"], p["ties"]))
# Each site against the truth: the odometry's pose (a priori) and the pose after.
try:
    truth = {x["id"]: x["pose"]["position_m"] for x in json.load(open(os.path.join(dataset, "truth", "traverse.json")))["sites"]}
    apriori = {x["id"]: x["apriori"]["position_m"] for x in json.load(open(os.path.join(dataset, "traverse.json")))["sites"]}
    for x in t.get("site", []):
        if x["id"] in truth and x["id"] in apriori:
            print("localised: %s %s m a priori -> %s m after against truth (%s, sigma %s m)" % (
                x["id"], "%.3f" % math.dist(apriori[x["id"]], truth[x["id"]]),
                "%.3f" % math.dist(x["position_m"], truth[x["id"]]), x.get("source"),
                "%.3f" % math.hypot(*x.get("sigma_m", [0, 0, 0]))))
except (OSError, KeyError, ValueError):
    pass
rp = r.get("rover_poses")
if rp:
    print("rover:     on board, %s site poses (rover_poses.csv): error %s m (%s %% of the distance), ground %s m (%s %%) over them; %s m RMS apart" % (
        rp.get("sites"), num(rp.get("position_error_m"), "%.3f"), num(rp.get("position_error_pct"), "%.2f"),
        num(rp.get("ground_position_error_m"), "%.3f"), num(rp.get("ground_position_error_pct"), "%.2f"),
        num(rp.get("vs_ground_rms_m"), "%.3f")))
else:
    print("rover:     no site pose from the rover (AREOMAP_SITE_POSE)")
tr = r.get("truth", {})
print("dem:       merged DEM RMSE against the truth %s m over %s cells (within %s m of a site)" % (
    num(tr.get("dem_rmse_m"), "%.3f"), tr.get("dem_cells", "n/a"), tr.get("dem_radius_m", "n/a")))
for x in t.get("site", []):
    rep = os.path.join(products, "sites", x["id"], "report.json")
    rv, st = {}, {}
    if os.path.exists(rep):
        sr = json.load(open(rep))
        rv, st = sr.get("rover", {}), sr.get("stream", {})
    print("site %s: %s, method 1 %s px, truth EO %s px, %s pairs; rover heap after start-up %s, EO vs ground %s px" % (
        x["id"], "mapped" if x.get("mapped") else "NOT mapped (%s)" % x.get("error"), num(x.get("method1_px"), "%.3f"),
        num(x.get("truth_eo_px"), "%.3f"), st.get("pairs", "n/a"), rv.get("heap_allocs_after_init", "n/a"),
        num(rv.get("eo_vs_ground_px"), "%.4f")))
print("memory:    peak RSS ground %s, rover %s" % (rss("ground"), rss("rover")))
for w in r.get("warnings", [])[:6]:
    print("warning:   " + w)
print("=" * 78)
EOF
  echo "products: $PRODUCTS"
  exit 0
fi
python3 - "$PRODUCTS/report.json" "$RAN" "$OUT" <<'EOF'
import json, os, sys
path, ran, out = sys.argv[1], sys.argv[2], sys.argv[3]
r = json.load(open(path))
def rss(name):
    try:
        return "%.0f MiB" % (int(open(os.path.join(out, name + ".rss")).read().split()[-1]) / 1024)
    except Exception:
        return "n/a"
m1 = r.get("method1_px", {})
s = r.get("stream", {})
rv = r.get("rover", {})
t = r.get("truth")
tp = r.get("tie_points", {})
print("=" * 78)
print("transport: %s" % ran)
print("stream:    %s pairs received, %s gaps, %s duplicates, %s reordered, rejected %s" % (
    s.get("pairs"), s.get("gaps"), s.get("duplicates"), s.get("reordered"), s.get("rejected") or "none"))
print("ties:      tie points %s intra, %s inter (%s observations rejected as outliers); the %s's" % (
    tp.get("intra"), tp.get("inter"), tp.get("rejected"), r.get("ground", {}).get("tie_source", "?")))
print("ground:    method 1 mean distance %.3f px before -> %.3f px after (integrated, %s iterations; fast %s sweeps)" % (
    m1.get("before", {}).get("dist", float("nan")), m1.get("after", {}).get("dist", float("nan")), r.get("iterations"),
    r.get("ground", {}).get("fast_sweeps")))
if t:
    print("truth:     EO error %.3f px a priori -> %.3f px adjusted (datum removed; raw %.3f px)" % (
        t.get("eo_px_before") or float("nan"), t.get("eo_px"), t.get("eo_px_raw")))
if rv.get("heap_allocs_after_init") is not None:
    st = rv.get("stage_seconds_per_pair", {})
    print("rover:     %s pairs accepted, %s sweeps (final), rms %.3f px, heap allocations after start-up %s, memory (static and start-up reserve) %.1f of 72 MiB" % (
        rv.get("pairs_accepted"), rv.get("sweeps"), rv.get("rms_px") or float("nan"), rv.get("heap_allocs_after_init"),
        (rv.get("static_bytes") or 0) / 2**20))
    print("rover:     per pair %.2f s (%s)" % (rv.get("seconds_per_pair") or 0,
          ", ".join("%s %.2f" % (k, v) for k, v in st.items() if v)))
    ev = rv.get("eo_vs_ground_px")
    print("rover:     EO vs the ground's integrated adjustment %s px (datum removed)" % ("%.4f" % ev if ev is not None else "n/a"))
else:
    print("rover:     no rover figures arrived")
dp = r.get("dense", {}).get("pairs", [])
if dp:
    v = [p.get("match_sigma_px", float("nan")) for p in dp]
    fb = [str(p.get("pair")) for p in dp if p.get("match_sigma_source") != "left_right"]
    print("dense:     matching noise %.3f-%.3f px over %d pairs (left-right estimate%s)" % (
        min(v), max(v), len(dp), "; the constant for pair(s) " + ", ".join(fb) if fb else ""))
cov = r.get("dem_coverage", {}).get("fraction_2_10m")
if isinstance(cov, (int, float)):
    print("dem:       covers %.1f %% of the cells both cameras of a pair see at 2-10 m" % (100 * cov))
print("ground:    stage seconds %s" % ", ".join("%s %.1f" % (k, v) for k, v in r.get("seconds", {}).items()))
print("memory:    peak RSS ground %s, rover %s" % (rss("ground"), rss("rover")))
for w in r.get("warnings", [])[:6]:
    print("warning:   " + w)
if len(r.get("warnings", [])) > 6:
    print("warning:   ... %d more in report.json" % (len(r["warnings"]) - 6))
print("=" * 78)
EOF
echo "products: $PRODUCTS"
