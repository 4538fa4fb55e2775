#!/usr/bin/env bash
# The hardware-in-the-loop run (CTest label `hil` in the aarch64 build). One command:
#   tests/hil/run.sh [--host-build build] [--target-build build-aarch64] [--out DIR] [--pairs N] [--sites S]
# 1. the native build makes a traverse of S `tiny` sites (default 2; areomap-sim --preset traverse --pairs N
#    per site; S = 1: one panorama);
# 2. all-native run: ./run.sh --dataset (areomap-ground and areomap-rover over udpm on loopback, stock
#    lcm-logplayer at full speed; a private network namespace when the host has no multicast route);
# 3. HIL run: the same ./run.sh, but areomap-rover is the aarch64 build under qemu-aarch64 (a bin/ folder
#    whose areomap-rover execs the emulator, the other tools the native ones);
# 4. the products of both compared, site by site (compare_hil.py): the rover's tie points identical, the
#    rover's EO within the golden tolerance (tests/golden/compare_golden.py), the ground's products made and
#    equal; on a traverse also the rover's own site poses (rover_poses.csv, AREOMAP_SITE_POSE) within that
#    tolerance, a pose for every site.
# Exit: 0 equal, 1 different or a step failed, 2 usage, 77 skipped (a build lacks the programs).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
HOST=${AREOMAP_HOST_BUILD:-$ROOT/build}
TARGET_BUILD=$ROOT/build-aarch64
OUT=$ROOT/build-aarch64/test-scratch/hil
PAIRS=${AREOMAP_HIL_PAIRS:-4}
SITES=${AREOMAP_HIL_SITES:-2}
EMULATOR=${AREOMAP_HIL_EMULATOR:-qemu-aarch64 -L /}
while [[ $# -gt 0 ]]; do
  case "$1" in
    --help|-h) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    --host-build) HOST=${2:?--host-build needs a folder}; shift 2 ;;
    --target-build) TARGET_BUILD=${2:?--target-build needs a folder}; shift 2 ;;
    --out) OUT=${2:?--out needs a folder}; shift 2 ;;
    --pairs) PAIRS=${2:?--pairs needs a number}; shift 2 ;;
    --sites) SITES=${2:?--sites needs a number}; shift 2 ;;
    *) echo "hil: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ -n "${AREOMAP_HOST_BUILD:-}" ]] && HOST=$AREOMAP_HOST_BUILD  # the environment wins (CTest passes --host-build)
fail() { echo "FAIL hil: $*" >&2; exit 1; }
HOST=$(cd "$HOST" 2> /dev/null && pwd) || { echo "SKIP hil: no native build folder"; exit 77; }
for t in areomap-sim areomap-pack areomap-ground areomap-rover; do
  [[ -x "$HOST/bin/$t" ]] || { echo "SKIP hil: $HOST/bin/$t is missing (build the native preset, or set AREOMAP_HOST_BUILD)"; exit 77; }
done
[[ -x "$TARGET_BUILD/bin/areomap-rover" ]] || { echo "SKIP hil: $TARGET_BUILD/bin/areomap-rover is missing (cmake --build --preset aarch64)"; exit 77; }
command -v lcm-logplayer > /dev/null || fail "lcm-logplayer not found (./setup.sh)"
command -v ${EMULATOR%% *} > /dev/null || fail "${EMULATOR%% *} not found (toolchains/setup-targets.sh aarch64)"
TARGET_BUILD=$(cd "$TARGET_BUILD" && pwd)
rm -rf "$OUT"
mkdir -p "$OUT/hil-build/bin"
OUT=$(cd "$OUT" && pwd)

# The HIL bin/ folder: the native simulator, packer and ground; the target's rover under the emulator.
for t in areomap-sim areomap-pack areomap-ground; do ln -s "$HOST/bin/$t" "$OUT/hil-build/bin/$t"; done
printf '#!/bin/sh\nexec %s %s "$@"\n' "$EMULATOR" "$TARGET_BUILD/bin/areomap-rover" > "$OUT/hil-build/bin/areomap-rover"
chmod +x "$OUT/hil-build/bin/areomap-rover"

# The sites' legs are 6-8 m: the tiny camera sees the ground out to about 11 m, so neighbours share ground.
NAME=tiny
SIM=(--preset tiny --seed 1 --pairs "$PAIRS")
if [[ "$SITES" -gt 1 ]]; then
  NAME=tiny-traverse
  SIM=(--preset traverse --camera tiny --seed 1 --pairs "$PAIRS" --sites "$SITES" --leg-min-m 6 --leg-max-m 8)
fi
"$HOST/bin/areomap-sim" "${SIM[@]}" --threads 2 --out "$OUT/$NAME" > "$OUT/sim.log" 2>&1 \
  || { cat "$OUT/sim.log"; fail "areomap-sim"; }
# udpm in a private network namespace (lo, route 239.0.0.0/8 dev lo) when this user may make one: isolated
# from other udpm traffic on the host; else ./run.sh picks (host multicast route, else file replay).
TRANSPORT=auto
unshare -n true 2> /dev/null && TRANSPORT=netns
for run in native hil; do
  build=$HOST
  [[ $run == hil ]] && build=$OUT/hil-build
  start=$(date +%s)
  "$ROOT/run.sh" --build "$build" --dataset "$OUT/$NAME" --out "$OUT/$run" --transport "$TRANSPORT" > "$OUT/$run.out" 2>&1 \
    || { cat "$OUT/$run.out"; fail "run.sh ($run) exited $?"; }
  echo "hil: $run run ($(grep '^transport:' "$OUT/$run.out" | sed 's/^transport: //')) took $(( $(date +%s) - start )) s"
  grep -E '^(rover|stream|traverse|site [^ ]*):' "$OUT/$run.out" | sed "s/^/hil: $run: /"
  grep -E '^areomap-rover: traverse:' "$OUT/$run/rover.log" | sed "s/^areomap-rover: /hil: $run: rover's /" || true
  [[ "$(tail -n 1 "$OUT/$run.out")" == "products: $OUT/$run/products-$NAME" ]] || fail "$run: no products line"
  # The ground heard the rover end every site (its final EO and status), not a wait that timed out.
  heard=$(grep -c '^rover: .*; final EO arrived$' "$OUT/$run/ground.out" || true)
  [[ "$heard" -eq "$SITES" ]] || fail "$run: the ground heard the rover finish $heard of $SITES sites ($OUT/$run/ground.out)"
done
python3 "$ROOT/tests/hil/compare_hil.py" "$OUT/native/products-$NAME" "$OUT/hil/products-$NAME" "$PAIRS" \
  || fail "the HIL products differ from the all-native run's"
