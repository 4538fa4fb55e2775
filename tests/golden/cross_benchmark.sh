#!/usr/bin/env bash
# Benchmark of the rover pipeline across targets (BENCHMARKS.md "Cross targets"):
#   tests/golden/cross_benchmark.sh [HOST_BUILD [AARCH64_BUILD [POWERPC_BUILD [SIM OPTIONS...]]]]
# defaults: build build-aarch64 build-powerpc, areomap-sim --preset tiny --seed 1 --pairs 3.
# 1. per-stage rover seconds (golden_rover's RoverNode stage counters: decode, ties + coarse DEM, network +
#    adjustment, publish) natively and under qemu-aarch64 and qemu-ppc on the same log, with the ratio to
#    native measured in this run (user CPU of the process too: the host is shared);
# 2. callgrind instruction counts natively for ONE pair (the stable figure of rover cost): the whole run and
#    the inclusive counts of the matcher and the adjuster;
# 3. static memory (text/data/bss) of areomap-rover and golden_rover per target against the 64 MiB budget.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
HOST=${1:-$ROOT/build}
A64=${2:-$ROOT/build-aarch64}
PPC=${3:-$ROOT/build-powerpc}
shift $(( $# < 3 ? $# : 3 ))
SIM=("$@")
[[ ${#SIM[@]} -gt 0 ]] || SIM=(--preset tiny --seed 1 --pairs 3)
W=$(mktemp -d /tmp/areomap-cross-bench.XXXXXX)
trap 'rm -rf "$W"' EXIT
BUDGET=67108864

"$HOST/bin/areomap-sim" "${SIM[@]}" --threads 2 --out "$W/ds" > /dev/null 2>&1
"$HOST/bin/areomap-pack" "$W/ds" --out "$W/stream.lcm" > /dev/null 2>&1
"$HOST/bin/areomap-sim" --preset tiny --seed 1 --pairs 1 --threads 2 --out "$W/ds1" > /dev/null 2>&1
"$HOST/bin/areomap-pack" "$W/ds1" --out "$W/one.lcm" > /dev/null 2>&1
echo "input: areomap-sim ${SIM[*]} ($(stat -c %s "$W/stream.lcm") bytes of log); one pair for callgrind"

# stages NAME CMD...: golden_rover's stage line and the user CPU seconds.
declare -A DEC MAT ADJ USR
stages() {
  local name=$1
  shift
  /usr/bin/time -f "%U" -o "$W/$name.time" "$@" "$W/stream.lcm" "$W/$name.csv" 2> "$W/$name.log"
  local line
  line=$(grep '^golden_rover: pairs' "$W/$name.log")
  DEC[$name]=$(sed -E 's/.*decode ([0-9.]+).*/\1/' <<< "$line")
  MAT[$name]=$(sed -E 's/.*coarse DEM ([0-9.]+).*/\1/' <<< "$line")
  ADJ[$name]=$(sed -E 's/.*adjustment ([0-9.]+).*/\1/' <<< "$line")
  USR[$name]=$(tail -n 1 "$W/$name.time")
  echo "$name: ${line#golden_rover: }; user CPU ${USR[$name]} s"
}
stages native "$HOST/tests/golden_rover"
names=(native)
if [[ -x "$A64/tests/golden_rover" ]]; then stages aarch64 qemu-aarch64 -L / "$A64/tests/golden_rover"; names+=(aarch64); fi
if [[ -x "$PPC/tests/golden_rover" ]]; then stages powerpc qemu-ppc -L /usr/powerpc-linux-gnu "$PPC/tests/golden_rover"; names+=(powerpc); fi
echo
echo "| stage (seconds, whole log) | $(IFS='|'; echo "${names[*]}" | sed 's/|/ | /g') |"
for s in DEC MAT ADJ USR; do
  declare -n v=$s
  label=$(case $s in DEC) echo "JPEG decode";; MAT) echo "ties + coarse DEM";; ADJ) echo "network + adjustment";; USR) echo "process user CPU";; esac)
  row="| $label |"
  for n in "${names[@]}"; do
    row+=" ${v[$n]}"
    [[ $n != native ]] && row+=" ($(python3 -c "print('%.0fx' % (${v[$n]} / max(${v[native]}, 1e-9)))"))"
    row+=" |"
  done
  echo "$row"
done

echo
if command -v valgrind > /dev/null; then
  valgrind --tool=callgrind --callgrind-out-file="$W/cg.out" "$HOST/tests/golden_rover" "$W/one.lcm" "$W/cg.csv" > /dev/null 2> "$W/cg.log"
  total=$(grep -E '^(summary|totals):' "$W/cg.out" | head -1 | awk '{print $2}')
  echo "callgrind, one pair natively (golden_rover, start-up included): $total instructions"
  callgrind_annotate --inclusive=yes "$W/cg.out" 2> /dev/null | grep -E 'PanoramaMatcher::|FastAdjuster::|ArenaJpegDecoder::|RoverNode::(processPair|adjustNow|decodeSide)' \
    | grep -v '^ *0 ' | head -8 | sed -E 's/ +/ /g; s/^ //'
else
  echo "callgrind: valgrind not installed"
fi

echo
echo "| binary | target | text | data | bss | text+data+bss | of 64 MiB |"
for pair in "native:$HOST:size" "aarch64:$A64:aarch64-linux-gnu-size" "powerpc:$PPC:powerpc-linux-gnu-size"; do
  IFS=: read -r n dir tool <<< "$pair"
  for bin in bin/areomap-rover tests/golden_rover; do
    [[ -x "$dir/$bin" ]] || continue
    read -r text data bss <<< "$("$tool" -A -d "$dir/$bin" | awk '$1==".text"{t=$2} $1==".data"{d=$2} $1==".bss"{b=$2} END{print t, d, b}')"
    sum=$(( text + data + bss ))
    echo "| $(basename "$bin") | $n | $text | $data | $bss | $sum | $(python3 -c "print('%.1f %%' % (100.0 * $sum / $BUDGET))") |"
  done
done
