# Shell helpers of the process-level node tests (sourced): the tests/ground/node kill-and-resume and navcam
# replay tests and the tests/soak soak. Needs BUILD (build folder with bin/) and SCRATCH set.

fail() { echo "FAIL: $*" >&2; exit 1; }

# udpm between processes needs a multicast route: on this host when it has one, else in a private network
# namespace (as run.sh does). `ensure_multicast "$0" "$@"` re-runs the calling script in a namespace when
# needed (the script sees AREOMAP_NETNS_INNER=1 there); exits 77 (CTest skip) with the reason when neither
# works.
ensure_multicast() {
  if [[ "${AREOMAP_NETNS_INNER:-}" == 1 ]]; then
    ip link set lo up && ip route add 239.0.0.0/8 dev lo || fail "network namespace set-up"
    return 0
  fi
  ip route get 239.255.76.67 > /dev/null 2>&1 && return 0
  if unshare -n true 2> /dev/null; then
    echo "no multicast route on this host: udpm in a private network namespace"
    AREOMAP_NETNS_INNER=1 exec unshare -n "$@"
  fi
  echo "SKIP: no multicast route and no network namespace (unshare -n refused): udpm cannot be tested here"
  exit 77
}

# node_test_start SCRATCH "$0" "$@": an empty SCRATCH (not again inside the namespace re-run), then
# ensure_multicast.
node_test_start() {
  local scratch=$1
  shift
  [[ "${AREOMAP_NETNS_INNER:-}" == 1 ]] || rm -rf "$scratch"
  mkdir -p "$scratch"
  ensure_multicast "$@"
}

# A udpm URL of loopback for this test (ttl=0; receive buffers for a whole panorama, as run.sh).
node_url() { echo "udpm://239.255.76.67:$(( 20000 + $$ % 20000 ))?ttl=0&recv_buf_size=67108864"; }

# make_dataset PRESET DIR [SIM_OPTION...]: areomap-sim --preset PRESET --seed 1 [SIM_OPTION...], reused when
# DIR holds it already with the same options.
make_dataset() {
  local preset=$1 dir=$2 options="--preset $1 --seed 1${3:+ ${*:3}}"
  if [[ -f "$dir/panorama.json" && -f "$dir.options" && "$(cat "$dir.options")" == "$options" ]]; then
    echo "reusing $dir ($options)"
    return 0
  fi
  rm -rf "$dir" "$dir.options"
  local start=$SECONDS
  "$BUILD/bin/areomap-sim" $options --out "$dir" > "$dir.sim.log" 2>&1 || { tail "$dir.sim.log"; fail "areomap-sim $options"; }
  echo "$options" > "$dir.options"
  echo "areomap-sim $options: $(( SECONDS - start )) s"
}

# wait_listening LOG...: until every node log says "listening on" (at most 60 s): a replay before a node
# listens is lost to it.
wait_listening() {
  local log start=$SECONDS
  for log in "$@"; do
    until grep -q "listening on" "$log" 2> /dev/null; do
      (( SECONDS - start > 60 )) && fail "$log: the node did not start listening within 60 s"
      sleep 0.1
    done
  done
  sleep 0.5
}

# bg_start RCFILE COMMAND...: COMMAND in the background, its own pid in BG_PID; its exit status is written to
# RCFILE when it ends (bg_wait). A long script's own short-lived children can be given a finished job's pid
# again once the kernel's pids wrap, and bash's `wait PID` then no longer knows it ("not a child of this
# shell"); the file keeps the status. Redirections of the call apply to COMMAND.
bg_start() {
  local rcfile=$1
  shift
  rm -f "$rcfile" "$rcfile.pid"
  ( "$@" &
    p=$!
    echo "$p" > "$rcfile.pid"
    wait "$p"
    echo $? > "$rcfile" ) &
  while [[ ! -s "$rcfile.pid" ]]; do sleep 0.05; done
  BG_PID=$(cat "$rcfile.pid")
}

# bg_wait RCFILE: waits until the command bg_start started with RCFILE has ended; returns its exit status.
bg_wait() {
  while [[ ! -s "$1" ]]; do sleep 0.2; done
  return "$(cat "$1")"
}

# wait_for FILE SECONDS PID: until FILE exists (0), PID exits (1) or SECONDS pass (2).
wait_for() {
  local file=$1 limit=$2 pid=${3:-} start=$SECONDS
  while [[ ! -e "$file" ]]; do
    [[ -n "$pid" ]] && ! kill -0 "$pid" 2> /dev/null && return 1
    (( SECONDS - start > limit )) && return 2
    sleep 0.2
  done
  return 0
}

# sanitizer_build: true when BUILD was configured with AddressSanitizer (the asan preset; CMakeCache.txt).
sanitizer_build() { grep -q -- '-fsanitize=[a-z,]*address' "$BUILD/CMakeCache.txt" 2> /dev/null; }

# rss_kib PID: the resident set now (KiB), from /proc.
rss_kib() { awk '/^VmRSS:/ {print $2}' "/proc/$1/status" 2> /dev/null || echo 0; }

# same_products A B: the report-independent products of two out dirs are byte-identical (eo.csv,
# tiepoints.csv, rover_tiepoints.csv, models/, rover_models/, and the rasters when both have them).
same_products() {
  local a=$1 b=$2 f n=0
  for f in eo.csv tiepoints.csv rover_tiepoints.csv dem.tif dem_sigma.tif ortho.tif; do
    [[ -f "$a/$f" || -f "$b/$f" ]] || continue
    cmp -s "$a/$f" "$b/$f" || { echo "differs: $f ($a vs $b)"; return 1; }
    n=$(( n + 1 ))
  done
  for f in models rover_models; do
    [[ -d "$a/$f" || -d "$b/$f" ]] || continue
    diff -rq "$a/$f" "$b/$f" > /dev/null || { echo "differs: $f/ ($a vs $b)"; return 1; }
    n=$(( n + $(ls "$a/$f" | wc -l) ))
  done
  [[ $n -gt 0 ]] || { echo "no products to compare in $a"; return 1; }
  echo "same: $n product files ($a = $b)"
}
