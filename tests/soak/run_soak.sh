#!/usr/bin/env bash
# Soak: PASSES copies of one panorama back to back through both nodes -- one
# areomap-ground (--panoramas 0, stopped at the end) and one areomap-rover for the whole run, over udpm on loopback, each
# pass replayed by stock lcm-logplayer at full speed once the ground has made the previous pass's products.
# Checks: the rover's heap allocations after start-up stay 0 (its status, in every pass's report); the
# ground's and the rover's resident memory stay flat after the first pass (VmRSS after each pass; every pass
# after the first at most GROWTH_PCT % + GROWTH_MIB MiB above pass 2); every pass's products are byte-identical
# to the first pass's, which is a single-pass run of a fresh process (eo.csv, tiepoints.csv,
# rover_tiepoints.csv, models/, rover_models/, and dem.tif, dem_sigma.tif, ortho.tif with --products).
#
# CTest (label soak): run_soak.sh BUILD SCRATCH tiny 3            (adjustment products only; ~1-2 min)
# Benchmark:          run_soak.sh build /tmp/soak navcam 10 --products   (BENCHMARKS.md)
set -euo pipefail
BUILD=$1
SCRATCH=$2
PRESET=${3:-tiny}
PASSES=${4:-3}
PRODUCTS=${5:---no-products}
[[ "$PRODUCTS" == --products ]] && PRODUCTS=""
GROWTH_PCT=${GROWTH_PCT:-5}
GROWTH_MIB=${GROWTH_MIB:-8}
HERE=$(cd "$(dirname "$0")/../ground/node" && pwd)
source "$HERE/nodes_lib.sh"
if [[ "${AREOMAP_NETNS_INNER:-}" != 1 ]]; then
  mkdir -p "$SCRATCH"
  rm -rf "$SCRATCH/out" "$SCRATCH"/*.log
fi
ensure_multicast "$0" "$@"
DATASET=${AREOMAP_SOAK_DATASET:-$SCRATCH/$PRESET}
make_dataset "$PRESET" "$DATASET"
LOG="$SCRATCH/$PRESET.lcm"
"$BUILD/bin/areomap-pack" "$DATASET" --out "$LOG" > /dev/null 2>&1 || fail "areomap-pack"
URL=$(node_url)
OUT="$SCRATCH/out"
PASS_LIMIT_S=$([[ "$PRESET" == tiny ]] && echo 600 || echo 3600)

# In an AddressSanitizer build the ground runs without ASan's quarantine of freed memory (256 MiB by default,
# filled pass after pass: RSS would grow by design); every other ASan check stays on.
GROUND_ENV=()
if sanitizer_build; then
  GROUND_ENV=(env "ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=0")
  echo "sanitizer build: the ground runs with ${GROUND_ENV[1]} (ASan's quarantine would grow its RSS)"
fi
# --panoramas 0 (until stopped): the ground stays up after the last pass, so its RSS can be read then too.
"${GROUND_ENV[@]}" "$BUILD/bin/areomap-ground" --lcm "$URL" --out "$OUT" --panoramas 0 $PRODUCTS \
  --truth "$DATASET" > "$SCRATCH/ground.out" 2> "$SCRATCH/ground.log" &
GROUND=$!
"$BUILD/bin/areomap-rover" --lcm "$URL" --quiet > "$SCRATCH/rover.out" 2> "$SCRATCH/rover.log" &
ROVER=$!
trap 'kill $GROUND $ROVER 2> /dev/null || true' EXIT
wait_listening "$SCRATCH/ground.log" "$SCRATCH/rover.log"
start_all=$SECONDS
: > "$SCRATCH/rss.txt"
for (( k = 1; k <= PASSES; k++ )); do
  dir=$(printf "%s/panorama-%03d" "$OUT" "$k")
  t0=$SECONDS
  lcm-logplayer -s 0 --lcm-url="$URL" "$LOG" > /dev/null 2>&1 || fail "lcm-logplayer (pass $k)"
  set +e
  wait_for "$dir/report.json" "$PASS_LIMIT_S" "$GROUND"
  rc=$?
  set -e
  [[ $rc -eq 0 ]] || { tail -n 20 "$SCRATCH/ground.log"; fail "pass $k: no report.json (ground exited or timed out: $rc)"; }
  sleep 1
  g=$(rss_kib "$GROUND")
  r=$(rss_kib "$ROVER")
  echo "$k $g $r $(( SECONDS - t0 ))" >> "$SCRATCH/rss.txt"
  echo "pass $k: $(( SECONDS - t0 )) s; RSS ground $(( g / 1024 )) MiB, rover $(( r / 1024 )) MiB"
done
kill -0 "$GROUND" 2> /dev/null || { tail "$SCRATCH/ground.log"; fail "areomap-ground stopped before the end"; }
set +e
kill -TERM "$GROUND" "$ROVER" 2> /dev/null
wait "$GROUND" "$ROVER"
set -e
trap - EXIT
echo "soak: $PASSES passes of $PRESET in $(( SECONDS - start_all )) s"

python3 - "$OUT" "$PASSES" "$SCRATCH/rss.txt" "$GROWTH_PCT" "$GROWTH_MIB" <<'PY'
import json, os, sys
out, passes, rss_path, pct, mib = sys.argv[1], int(sys.argv[2]), sys.argv[3], float(sys.argv[4]), float(sys.argv[5])
rows = [list(map(int, l.split())) for l in open(rss_path) if l.strip()]
ok = True
for k in range(1, passes + 1):
    r = json.load(open(os.path.join(out, "panorama-%03d" % k, "report.json")))
    rv, s = r.get("rover", {}), r["stream"]
    print("pass %d: stream pairs %d gaps %d; tie source %s; rover heap after start-up %s, eo_vs_ground_px %s; "
          "method1 after %.4f px; truth eo %.4f px" % (
              k, s["pairs"], s["gaps"], r["ground"]["tie_source"], rv.get("heap_allocs_after_init"),
              rv.get("eo_vs_ground_px"), r["method1_px"]["after"]["dist"], r.get("truth", {}).get("eo_px", -1)))
    if rv.get("heap_allocs_after_init") != 0:
        print("FAIL: pass %d: the rover's heap allocations after start-up are %s" % (k, rv.get("heap_allocs_after_init")))
        ok = False
    if s["gaps"] != 0 or r["ground"]["tie_source"] != "rover":
        print("FAIL: pass %d: gaps %d, tie source %s" % (k, s["gaps"], r["ground"]["tie_source"]))
        ok = False
# Flat after the first pass: every later pass within the limit of pass 2 (the first pass sets up caches,
# libraries and allocator arenas).
base = rows[1] if len(rows) > 1 else rows[0]
for name, col in (("ground", 1), ("rover", 2)):
    first, second, last, peak = rows[0][col], base[col], rows[-1][col], max(r[col] for r in rows[1:] or rows)
    limit = second * (1 + pct / 100) + mib * 1024
    print("RSS %s: pass 1 %.1f MiB, pass 2 %.1f MiB, last %.1f MiB, highest after pass 1 %.1f MiB (limit %.1f MiB = "
          "pass 2 + %g %% + %g MiB)" % (name, first / 1024, second / 1024, last / 1024, peak / 1024, limit / 1024, pct, mib))
    if peak > limit:
        print("FAIL: the %s's RSS grew after the first pass" % name)
        ok = False
sys.exit(0 if ok else 1)
PY
for (( k = 2; k <= PASSES; k++ )); do
  same_products "$OUT/panorama-001" "$(printf "%s/panorama-%03d" "$OUT" "$k")" || fail "pass $k's products differ from pass 1's"
done
echo "soak: ok"
