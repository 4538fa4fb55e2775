#!/usr/bin/env bash
# areomap-traverse --executor slurm on the one-node cluster of cluster.sh (CTest label `slurm`):
#
#   run_slurm.sh BUILD SCRATCH prepare         the 3-site tiny traverse (SCRATCH/ds) and its local run,
#                                              site after site in one process (SCRATCH/local/out)
#   run_slurm.sh BUILD SCRATCH array           the traverse through the job array equals the local run
#   run_slurm.sh BUILD SCRATCH killed-task     a task scancel'd part way: the join is cancelled, the report
#                                              names the site; --resume maps that site alone, and the products
#                                              equal the local run's
#   run_slurm.sh BUILD SCRATCH failing-site    a site whose folder cannot be written fails its task: the join
#                                              is cancelled with the reason in report.json; a site with a bad
#                                              label is only reported; --resume --no-wait finishes the run
#
# The cluster is SCRATCH/cluster (cluster.sh start, a CTest fixture); exit 77 (skip) when it is not up.
# The traverse is as small as works: 2 pairs of 128x96 per site, adjusted on truth cross-site ties.
set -euo pipefail
build=$(cd "$1" && pwd)
mkdir -p "$2"
scratch=$(cd "$2" && pwd)
case_name=$3
here=$(cd "$(dirname "$0")" && pwd)
traverse=$build/bin/areomap-traverse

fail() { echo "FAIL: $*"; exit 1; }
same() { python3 "$here/same_products.py" "$@"; }
# json FILE PYTHON-EXPRESSION-OF-r: prints the value.
json() { python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print($2)" "$1"; }

if [[ $case_name == prepare ]]; then
  rm -rf "$scratch/ds" "$scratch/local"
  "$build/bin/areomap-sim" --preset traverse --camera tiny --sites 3 --seed 3 --leg-min-m 10 --leg-max-m 10 \
    --pairs 2 --size 128 96 --extent-m 4 --no-shadows --check-points 50 --supersample 1 \
    --out "$scratch/ds" >"$scratch/sim.log" 2>&1 || { tail "$scratch/sim.log"; fail "areomap-sim"; }
  mkdir -p "$scratch/local"
  (cd "$scratch/local" && "$traverse" ../ds --out out --truth-cross-ties --jobs 1 --quiet >run.log 2>&1) ||
    fail "the local run"
  echo "prepared: $scratch/ds, the local run in $scratch/local/out"
  exit 0
fi

if [[ ! -f $scratch/cluster/env.sh ]]; then
  echo "SKIP: no cluster in $scratch/cluster (tests/slurm/cluster.sh start)"
  exit 77
fi
# shellcheck disable=SC1091
source "$scratch/cluster/env.sh"
sinfo -h >/dev/null 2>&1 || { echo "SKIP: the cluster in $scratch/cluster does not answer"; exit 77; }
[[ -f $scratch/local/out/report.json ]] || fail "no local run in $scratch/local (the prepare step)"

work=$scratch/$case_name
rm -rf "$work"
mkdir -p "$work"
cd "$work"  # every run gives --out as "out": the products name the same folders

case "$case_name" in
  array)
    "$traverse" ../ds --out out --truth-cross-ties --executor slurm >run.log 2>&1 || {
      tail -n 20 run.log; fail "the run through the array"; }
    grep -q "slurm: sites job [0-9]* (3 tasks)" run.log || fail "not one array of 3 tasks: $(cat run.log)"
    grep -q "join PENDING (Dependency)" run.log || fail "no progress line with the join waiting"
    grep "^slurm\|traverse:" run.log
    same "$scratch/local/out" out
    ;;

  killed-task)
    # The local run's complete sites, site02 gone: --resume maps site02 alone, and it is killed part way.
    cp -a "$scratch/local/out" out
    rm -rf out/sites/site02 out/report.json
    "$traverse" ../ds --out out --truth-cross-ties --executor slurm --resume >run1.log 2>&1 &
    tool=$!
    for ((k = 0; k < 600; k++)); do
      [[ -f out/sites/site02/eo.csv ]] && break
      kill -0 "$tool" 2>/dev/null || break
      sleep 0.05
    done
    [[ -f out/sites/site02/eo.csv && ! -f out/sites/site02/manifest.json ]] ||
      fail "site02's pass was not caught part way: $(cat run1.log)"
    job=$(sed -n 's/^slurm: sites job \([0-9]*\) (1 tasks).*/\1/p' run1.log)
    [[ -n $job ]] || fail "no array of 1 task: $(cat run1.log)"
    scancel "${job}_2"
    rc=0
    wait "$tool" || rc=$?
    [[ $rc == 1 ]] || fail "exit $rc after the kill (1 expected): $(tail run1.log)"
    [[ $(json out/report.json 'r["status"]') == incomplete ]] || fail "report.json: not incomplete"
    state=$(json out/report.json 'r["traverse"]["site"][1]["job_failed"]["state"]')
    [[ $state == CANCELLED* ]] || fail "site02's task state: $state"
    [[ $(json out/report.json 'r["executor"]["join_state"]') == CANCELLED* ]] || fail "the join was not cancelled"
    echo "killed: task ${job}_2 $state; the join $(json out/report.json 'r["executor"]["join_state"]')"
    "$traverse" ../ds --out out --truth-cross-ties --executor slurm --resume >run2.log 2>&1 || {
      tail -n 20 run2.log; fail "the resumed run"; }
    grep -q "slurm: sites job [0-9]* (1 tasks)" run2.log || fail "the resume did not map site02 alone"
    grep "^slurm\|traverse:" run2.log
    same "$scratch/local/out" out
    ;;

  failing-site)
    # site03's label is broken (its data: reported, the others mapped); site02's folder is a file (its task
    # fails, the join is cancelled).
    cp -al "$scratch/ds" ds
    rm ds/sites/site03/panorama.json
    printf '{ "version": 1, "pairs": [' >ds/sites/site03/panorama.json
    mkdir -p out/sites
    echo "not a folder" >out/sites/site02
    rc=0
    "$traverse" ds --out out --no-products --no-cross-ties --executor slurm >run1.log 2>&1 || rc=$?
    [[ $rc == 1 ]] || fail "exit $rc with a failing task (1 expected): $(tail run1.log)"
    [[ $(json out/report.json 'r["status"]') == incomplete ]] || fail "report.json: not incomplete"
    [[ $(json out/report.json 'r["executor"]["join_state"]') == CANCELLED* ]] || fail "the join was not cancelled"
    reason=$(json out/report.json 'r["traverse"]["site"][1]["job_failed"]["reason"]')
    [[ $reason == *"not a folder"* ]] || fail "site02's reason: '$reason'"
    [[ $(json out/report.json 'r["traverse"]["site"][0]["mapped"]') == True ]] || fail "site01 not mapped"
    [[ $(json out/report.json 'r["traverse"]["site"][2]["error"]') == *panorama.json* ]] ||
      fail "site03's error does not name panorama.json"
    grep -q "site site02 (job [0-9]*_2) failed: FAILED, exit 1" run1.log || fail "the console: $(cat run1.log)"
    echo "failed: site02 ($reason); join $(json out/report.json 'r["executor"]["join_state"]')"
    rm out/sites/site02
    "$traverse" ds --out out --no-products --no-cross-ties --executor slurm --resume --no-wait >run2.log 2>&1 ||
      fail "the resumed submission: $(cat run2.log)"
    join=$(sed -n 's/^slurm: sites job [0-9]* (2 tasks), join job \([0-9]*\)$/\1/p' run2.log)
    [[ -n $join ]] || fail "--resume --no-wait: not 2 tasks and a join: $(cat run2.log)"
    grep -q -- "--out out --join --no-products --no-cross-ties" run2.log || fail "no join command printed"
    for ((k = 0; k < 600; k++)); do
      state=$(squeue -h --states=all -j "$join" -o %T 2>/dev/null || true)
      [[ $state == PENDING || $state == RUNNING || $state == COMPLETING || -z $state ]] || break
      sleep 0.1
    done
    [[ $state == COMPLETED ]] || fail "the join ended $state: $(cat out/logs/join.log)"
    [[ $(json out/report.json '"status" in r') == False ]] || fail "report.json still incomplete"
    for k in 0 1; do
      [[ $(json out/report.json "r['traverse']['site'][$k]['mapped']") == True ]] || fail "site $k not mapped"
    done
    [[ $(json out/report.json 'r["traverse"]["site"][2]["mapped"]') == False ]] || fail "site03 mapped"
    echo "resumed: $(json out/report.json 'r["traverse"]["site"][2]["error"]')"
    ;;

  *) echo "run_slurm.sh: unknown case '$case_name'" >&2; exit 2 ;;
esac
echo "ok: $case_name"
