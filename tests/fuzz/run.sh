#!/usr/bin/env bash
# tests/fuzz/run.sh [SECONDS] [options]: builds the fuzz targets when needed (clang, libFuzzer + ASan +
# UBSan; the `fuzz` preset, build-fuzz/) and runs every target, SECONDS IN TOTAL split evenly over the
# targets (default 60). Exits 1 if any target crashes, leaks a sanitizer report or breaks an invariant; the
# input that did it is kept in BUILD/fuzz/crashes/<target>/ (make it a regression: tests/README.md).
#
#   --runs N            run each target for N executions instead of a time (the benchmark: BENCHMARKS.md);
#                       with --seconds-each S, at most S seconds each
#   --seconds-each S    S seconds per target instead of SECONDS in total
#   --only TARGET       one target (lcm_message lcm_log jpeg pds3 camera_file panorama tiepoints)
#   --build-dir DIR     the fuzz build folder (default: <checkout>/build-fuzz, configured with --preset fuzz)
#   --no-build          do not configure or build (CTest's smoke entries)
#
# Corpus: BUILD/fuzz/seeds/<target>/ is generated once (fuzz_seeds: every message type, logs, JPEGs, model
# text; make_corpus.py: the real files of ../shared/data and a tiny simulated panorama); the committed
# tests/fuzz/seeds/ and tests/fuzz/regressions/ are read too; new inputs go to BUILD/fuzz/corpus/<target>/.
# AREOMAP_SIM=PATH takes the simulator from another build of this checkout (default BUILD/bin/areomap-sim,
# built with the fuzz targets; with AREOMAP_SIM it is not built in BUILD).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/../.." && pwd)

usage() { sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; }

total=60
each=""
runs=""
only=""
build_dir="$src/build-fuzz"
build=1
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs="${2:?}"; shift 2 ;;
    --seconds-each) each="${2:?}"; shift 2 ;;
    --only) only="${2:?}"; shift 2 ;;
    --build-dir) build_dir="${2:?}"; shift 2 ;;
    --no-build) build=0; shift ;;
    -h|--help) usage; exit 0 ;;
    [0-9]*) total="$1"; shift ;;
    *) echo "run.sh: unknown option '$1'" >&2; usage >&2; exit 2 ;;
  esac
done

targets=(lcm_message lcm_log jpeg pds3 camera_file panorama tiepoints)
if [ -n "$only" ]; then
  case " ${targets[*]} " in *" $only "*) targets=("$only") ;; *) echo "run.sh: no target '$only'" >&2; exit 2 ;; esac
fi

if [ "$build" = 1 ]; then
  if ! command -v clang++ >/dev/null; then
    echo "run.sh: clang++ not found: ./setup.sh --fuzz installs clang and libFuzzer" >&2
    exit 1
  fi
  if [ ! -f "$build_dir/build.ninja" ]; then
    if [ "$build_dir" = "$src/build-fuzz" ]; then
      (cd "$src" && cmake --preset fuzz >/dev/null)
    else
      cmake -S "$src" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang \
        -DCMAKE_CXX_COMPILER=clang++ -DAREOMAP_FUZZ=ON -DAREOMAP_BUILD_TESTS=OFF \
        -DAREOMAP_WARNINGS_AS_ERRORS=OFF >/dev/null
    fi
  fi
  # The simulator only makes seeds: with AREOMAP_SIM (another build's, e.g. CI's native build/) it is not
  # built here with the fuzz instrumentation.
  if [ -n "${AREOMAP_SIM:-}" ]; then
    cmake --build "$build_dir" -j2 --target fuzz_targets
  else
    cmake --build "$build_dir" -j2 --target fuzz_targets areomap-sim
  fi
fi

fz="$build_dir/fuzz"
for t in "${targets[@]}"; do
  [ -x "$fz/fuzz_$t" ] || { echo "run.sh: $fz/fuzz_$t is not built" >&2; exit 1; }
done

# The generated seeds, once per build folder (again when areomap-sim has been built since).
sim_bin="${AREOMAP_SIM:-$build_dir/bin/areomap-sim}"
have_sim=no
[ -x "$sim_bin" ] && have_sim=yes
if [ ! -f "$fz/seeds/.done" ] || { [ "$have_sim" = yes ] && ! grep -q sim=yes "$fz/seeds/.done"; }; then
  rm -rf "$fz/seeds" "$fz/sim"
  "$fz/fuzz_seeds" "$fz/seeds"
  if [ "$have_sim" = yes ]; then
    ASAN_OPTIONS=detect_leaks=0 "$sim_bin" --preset tiny --pairs 2 --no-images --seed 1 --out "$fz/sim" >/dev/null ||
      { echo "run.sh: areomap-sim failed: no simulated seeds" >&2; have_sim=no; }
  fi
  python3 "$here/make_corpus.py" "$fz/seeds" --data "${AREOMAP_SHARED_DATA:-$src/../shared/data}" --sim "$fz/sim"
  echo "sim=$have_sim" >"$fz/seeds/.done"
fi

# The readers that take a path get their input through a file: tmpfs when there is one (3x faster).
if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then export TMPDIR=/dev/shm; fi

n=${#targets[@]}
if [ -n "$each" ]; then per=$each; else per=$(( total / n )); [ "$per" -ge 1 ] || per=1; fi
failed=0
printf '%-12s %12s %10s %8s %s\n' target executions exec/s seconds result
for t in "${targets[@]}"; do
  mkdir -p "$fz/corpus/$t" "$fz/crashes/$t" "$fz/logs"
  dirs=("$fz/corpus/$t")
  for d in "$fz/seeds/$t" "$here/seeds/$t" "$here/regressions/$t"; do [ -d "$d" ] && dirs+=("$d"); done
  # --runs N: N executions (capped by --seconds-each when given); otherwise the time.
  if [ -n "$runs" ]; then
    limit=(-runs="$runs")
    [ -n "$each" ] && limit+=(-max_total_time="$each")
  else
    limit=(-max_total_time="$per")
  fi
  log="$fz/logs/$t.log"
  s=$(date +%s)
  rc=0
  ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}" UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1}" \
    "$fz/fuzz_$t" "${limit[@]}" -timeout=25 -rss_limit_mb=2560 -print_final_stats=1 \
    -artifact_prefix="$fz/crashes/$t/" "${dirs[@]}" >"$log" 2>&1 || rc=$?
  secs=$(( $(date +%s) - s ))
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  if [ "$rc" = 0 ]; then result=ok; else result="CRASH (exit $rc; log $log; inputs in $fz/crashes/$t/)"; failed=1; fi
  printf '%-12s %12s %10s %8s %s\n' "$t" "${execs:-?}" "${rate:-?}" "$secs" "$result"
  if [ "$rc" != 0 ]; then grep -m5 -E 'ERROR|SUMMARY|invariant|terminate' "$log" | sed 's/^/    /' || true; fi
done
exit $failed
