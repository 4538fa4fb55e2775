#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, from the Debian packages (slurm-wlm, munge; ./setup.sh installs
# them), for the tests of `areomap-traverse --executor slurm`:
#
#   tests/slurm/cluster.sh start DIR    writes DIR/slurm.conf for this host and its cores, starts munged,
#                                       slurmctld and slurmd as plain processes (no systemd, no cgroups)
#                                       with their pid files, logs and state in DIR; waits until the node
#                                       is idle. Clients: SLURM_CONF=DIR/slurm.conf (DIR/env.sh sets it).
#   tests/slurm/cluster.sh stop DIR     stops the three daemons by their pid files
#
# Exit 77 (the tests' skip) when the packages are missing or when not run as root (slurmd starts each job
# as its user, which needs root).
set -euo pipefail

usage() { sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; }
[[ $# -eq 2 ]] || { usage >&2; exit 2; }
action=$1
dir=$2

# stop_all PIDFILE...: TERM to every daemon at once (each takes about 2 s to end), then KILL what is left
# after 10 s; the pid files are removed.
stop_all() {
  local file pid k pids=()
  for file in "$@"; do
    [[ -f $file ]] || continue
    pid=$(cat "$file" 2>/dev/null || true)
    if [[ -n $pid ]] && kill -0 "$pid" 2>/dev/null; then
      kill "$pid" 2>/dev/null || true
      pids+=("$pid")
    fi
    rm -f "$file"
  done
  for pid in "${pids[@]}"; do
    for ((k = 0; k < 100; k++)); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    if kill -0 "$pid" 2>/dev/null; then
      echo "cluster: $pid did not stop on TERM: KILL" >&2
      kill -9 "$pid" 2>/dev/null || true
    fi
  done
}

case "$action" in
  stop)
    [[ -d $dir ]] || exit 0
    stop_all "$dir/slurmctld.pid" "$dir/slurmd.pid" "$dir/munged.pid"
    rm -f "$dir/env.sh"
    echo "cluster: stopped ($dir)"
    exit 0
    ;;
  start) ;;
  *) usage >&2; exit 2 ;;
esac

for exe in munged slurmctld slurmd sbatch squeue sinfo scontrol; do
  if ! command -v "$exe" >/dev/null && [[ ! -x /usr/sbin/$exe ]]; then
    echo "SKIP: $exe not installed (./setup.sh installs slurm-wlm and munge)"
    exit 77
  fi
done
if [[ $(id -u) != 0 ]]; then
  echo "SKIP: the one-node cluster needs root (slurmd)"
  exit 77
fi
PATH=$PATH:/usr/sbin

mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
# A cluster left running in DIR (a test run stopped before its clean-up) is stopped first; state and
# spool start empty.
"$0" stop "$dir" >/dev/null
rm -rf "$dir/state" "$dir/spool" "$dir/munge"
mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
chmod 700 "$dir/munge"

# A free TCP port from $1 upwards (a real cluster on this host keeps 6817/6818).
free_port() {
  local p=$1
  while ss -Htln "sport = :$p" 2>/dev/null | grep -q .; do p=$((p + 1)); done
  echo "$p"
}
ctld_port=$(free_port 16817)
slurmd_port=$(free_port $((ctld_port + 1)))

host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/MemTotal/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)

# munge: its own key, socket and pid file in DIR (the daemon checks that only root can write its folder).
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$dir/munge/munge.key"
socket=$dir/munge/munge.socket
munged --force --key-file="$dir/munge/munge.key" --socket="$socket" --pid-file="$dir/munged.pid" \
  --log-file="$dir/munged.log" --seed-file="$dir/munge/munged.seed"

cat >"$dir/slurm.conf" <<EOF
# One-node test cluster written by tests/slurm/cluster.sh for $host ($cpus cores).
ClusterName=areomap-test
SlurmctldHost=$host
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
# No systemd, no cgroups: processes tracked by their parent pid, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SwitchType=switch/none
MpiDefault=none
LaunchParameters=use_interactive_step
# One job per core.
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
# Ended jobs stay visible to squeue for 10 minutes (no accounting database here for sacct).
MinJobAge=600
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
SlurmctldDebug=info
SlurmdDebug=info
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
echo "export SLURM_CONF=$dir/slurm.conf" >"$dir/env.sh"
export SLURM_CONF=$dir/slurm.conf

slurmctld -f "$SLURM_CONF" -i
slurmd -f "$SLURM_CONF" -N "$host"

# Up when the node is idle (slurmd registered with slurmctld).
for ((k = 0; k < 300; k++)); do
  state=$(sinfo -h -N -n "$host" -o %T 2>/dev/null || true)
  if [[ $state == idle* ]]; then
    echo "cluster: up in $dir: node $host, $cpus CPUs, partition debug, ports $ctld_port/$slurmd_port"
    echo "cluster: clients: source $dir/env.sh (SLURM_CONF)"
    exit 0
  fi
  sleep 0.1
done
echo "cluster: the node did not become idle in 30 s (state '${state:-none}'); logs in $dir" >&2
tail -n 20 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
"$0" stop "$dir" >&2
exit 1
