#!/usr/bin/env bash
# A throw-away single-node Slurm for the tests (DESIGN §8): munged, slurmctld and slurmd started
# by hand with their state, spool, logs, pid files and munge key under DIR, stopped by PID.
#
#   tools/slurm_cluster.sh start DIR   # up and idle, or exit 1 with the reason
#   tools/slurm_cluster.sh stop DIR    # cancel its jobs, stop the daemons by PID, remove the config
#
# The config must lie at the default path /etc/slurm/slurm.conf: the Slurm executor's in-job step
# strips SLURM_* variables, so a SLURM_CONF would be lost inside the jobs. That file is only ever
# written when it is absent or is one this script wrote (its first line says so, with DIR); a
# slurm.conf of anyone else's is refused, never overwritten. Slurm's ports are fixed: one such
# cluster per machine at a time, and one whose daemons still run is refused too.
set -euo pipefail
conf=/etc/slurm/slurm.conf
marker="# written by mixmc tools/slurm_cluster.sh for"
die() { echo "slurm_cluster.sh: $*" >&2; exit 1; }

[[ $# == 2 ]] || die "usage: $0 start|stop DIR"
cmd=$1
mkdir -p "$2"
dir=$(cd "$2" && pwd)

# The PIDs in DIR's pid files that are still alive.
alive_pids() {
  local d=$1 f
  for f in "$d"/run/slurmd.pid "$d"/run/slurmctld.pid "$d"/munge/munged.pid; do
    [[ -s $f ]] || continue
    local pid
    pid=$(<"$f")
    kill -0 "$pid" 2>/dev/null && echo "$pid"
  done
  return 0
}

# Stop one daemon by the PID in its file: TERM, then KILL after 10 s.
stop_pid_file() {
  local f=$1 pid i
  [[ -s $f ]] || return 0
  pid=$(<"$f")
  kill -0 "$pid" 2>/dev/null || { rm -f "$f"; return 0; }
  kill -TERM "$pid" 2>/dev/null || true
  for i in $(seq 100); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  kill -0 "$pid" 2>/dev/null && kill -KILL "$pid" 2>/dev/null || true
  rm -f "$f"
}

start() {
  command -v slurmctld >/dev/null && command -v munged >/dev/null \
    || die "Slurm or munge is not installed: run bash tools/setup.sh (as root)"
  [[ $(id -u) == 0 ]] || die "must run as root (SlurmUser=root, the config in /etc/slurm)"
  if [[ -e $conf ]]; then
    local first owner
    first=$(head -1 "$conf")
    [[ $first == "$marker "* ]] || die "$conf exists and was not written by this script: refusing to replace it"
    owner=${first#"$marker "}
    if [[ -n $(alive_pids "$owner") ]]; then
      die "a test cluster from $owner is still running (stop it with: $0 stop $owner)"
    fi
  fi
  mkdir -p "$dir"/{munge,state,spool,log,run}
  chmod 755 "$dir" "$dir/munge"
  [[ -s $dir/munge/munge.key ]] || mungekey -c -k "$dir/munge/munge.key" >/dev/null
  chmod 600 "$dir/munge/munge.key"
  local socket=$dir/munge/munge.socket
  munged --force --key-file="$dir/munge/munge.key" --socket="$socket" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/munge/munged.seed" 2>"$dir/log/munged.err" \
    || die "munged did not start: $(tail -1 "$dir/log/munged.err")"
  local host mem
  host=$(hostname -s)
  mem=$(slurmd -C | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p')
  mem=$((mem - 1024))
  local cpus
  cpus=$(nproc)
  mkdir -p "$(dirname "$conf")"
  cat >"$conf" <<EOF
$marker $dir
ClusterName=mixmc-test
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/affinity
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerParameters=batch_sched_delay=0
MinJobAge=300
KillWait=5
MailProg=/bin/true
ReturnToService=2
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus Sockets=1 CoresPerSocket=$cpus ThreadsPerCore=1 RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  slurmctld -i 2>"$dir/log/slurmctld.err" || die "slurmctld did not start: $(tail -1 "$dir/log/slurmctld.err")"
  slurmd 2>"$dir/log/slurmd.err" || die "slurmd did not start: $(tail -1 "$dir/log/slurmd.err")"
  local i state=""
  for i in $(seq 200); do
    state=$(sinfo -h -o %T 2>/dev/null || true)
    [[ $state == idle ]] && { echo "slurm up in $dir (node $host, $cpus CPUs, ${mem} MB)"; return 0; }
    sleep 0.1
  done
  die "the node did not become idle in 20 s (state '${state}'); logs in $dir/log"
}

stop() {
  # Jobs first (their steps end with slurmd), while slurmctld still answers: scancel would wait
  # out its message timeout on a controller that is gone.
  local ctld=$dir/run/slurmctld.pid
  if [[ -e $conf && $(head -1 "$conf") == "$marker $dir" && -s $ctld ]] && kill -0 "$(<"$ctld")" 2>/dev/null; then
    timeout 10 scancel --full --quiet --user=root 2>/dev/null || true
  fi
  stop_pid_file "$dir/run/slurmd.pid"
  stop_pid_file "$dir/run/slurmctld.pid"
  stop_pid_file "$dir/munge/munged.pid"
  if [[ -e $conf && $(head -1 "$conf") == "$marker $dir" ]]; then
    rm -f "$conf"
  fi
}

case $cmd in
  start) start ;;
  stop) stop ;;
  *) die "usage: $0 start|stop DIR" ;;
esac
