#!/usr/bin/env bash
# A throwaway single-node Slurm cluster on this machine, for tests/slurm.rs: munged, slurmctld and
# slurmd of Debian 12's slurm-wlm 22.05 with every file (key, sockets, state, spool, logs, pid files)
# under one directory, nothing in /etc touched, no systemd and no cgroups.
#
#   ci/slurm-cluster.sh install     # apt-get install slurm-wlm munge if missing (root or sudo)
#   ci/slurm-cluster.sh start DIR   # configure and start; waits until the node accepts jobs
#   ci/slurm-cluster.sh stop DIR    # stop the daemons started in DIR (also after a failed start)
#
# Clients (sbatch, srun, squeue) find the cluster through SLURM_CONF=DIR/slurm.conf. Ports: 6817/6818
# unless SLURM_TEST_PORT (slurmctld; slurmd uses the next one) says otherwise.
#
# What makes it run without cgroups (containers, gVisor): ProctrackType=proctrack/linuxproc (the
# process tree from /proc), TaskPlugin=task/none (no binding), JobAcctGatherType=jobacct_gather/none,
# AccountingStorageType=accounting_storage/none (so no sacct; squeue works). SlurmdParameters=
# config_overrides lets the node claim 2 CPUs on a 1-CPU machine, so that 2-rank runs fit.
set -euo pipefail

usage() {
  echo "usage: $0 install | start DIR | stop DIR" >&2
  exit 2
}

install() {
  local missing=()
  for p in slurm-wlm munge; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    local sudo=""
    [ "$(id -u)" -ne 0 ] && sudo="sudo"
    echo "installing: ${missing[*]}"
    $sudo apt-get update -qq
    # no recommends: the -dev plugin packages are not needed to run jobs
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
      "${missing[@]}" >/dev/null
  fi
}

# Stops what a start in DIR started, by the pids it recorded; idempotent.
stop() {
  local dir=$1
  [ -d "$dir" ] || return 0
  for name in slurmd slurmctld munged; do
    local pidfile="$dir/$name.pid"
    [ -s "$pidfile" ] || continue
    local pid
    pid=$(cat "$pidfile")
    if kill -0 "$pid" 2>/dev/null; then
      kill -TERM "$pid" 2>/dev/null || true
      for _ in $(seq 50); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
      done
      kill -KILL "$pid" 2>/dev/null || true
    fi
    rm -f "$pidfile"
  done
}

start() {
  local dir
  mkdir -p "$1"
  dir=$(cd "$1" && pwd)
  stop "$dir"
  rm -rf "$dir/munge" "$dir/state" "$dir/spool" "$dir"/*.log
  # a start that fails half way stops what it started
  trap 'echo "slurm-cluster: start failed; logs in $dir" >&2; stop "$dir"' ERR

  for b in munged slurmctld slurmd sbatch srun squeue; do
    command -v "$b" >/dev/null || { echo "slurm-cluster: $b not found (run: $0 install)" >&2; exit 1; }
  done

  # munge: its own key and socket; munged refuses group/world-accessible keys and socket folders
  mkdir -p "$dir/munge" "$dir/state" "$dir/spool"
  chmod 700 "$dir/munge"
  dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$dir/munge/munge.key"
  munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
    --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munge/seed"
  for _ in $(seq 50); do [ -S "$dir/munge/munge.socket" ] && break; sleep 0.1; done

  local host cpus mem port
  host=$(hostname -s)
  cpus=$(nproc)
  [ "$cpus" -lt 2 ] && cpus=2
  # MiB, as slurmd -C reports it, less a margin for the daemons
  mem=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)
  port=${SLURM_TEST_PORT:-6817}
  cat >"$dir/slurm.conf" <<EOF
# written by ci/slurm-cluster.sh: a single-node test cluster, everything under $dir
ClusterName=nurbscontact
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=$(id -un)
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/slurmd
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SwitchType=switch/none
MpiDefault=none
ReturnToService=2
SlurmdParameters=config_overrides
# quick turnaround for tests: the main scheduler every second (default 60 s)
SchedulerParameters=sched_interval=1
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF="$dir/slurm.conf"
  slurmctld -f "$SLURM_CONF"
  slurmd -f "$SLURM_CONF"
  # the node is up when sinfo lists it idle
  local state=""
  for _ in $(seq 150); do
    state=$(sinfo --noheader --nodes="$host" --format=%t 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.2
  done
  if [ "$state" != idle ]; then
    echo "slurm-cluster: node $host is '${state:-not listed}', not idle, after 30 s" >&2
    tail -n 20 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
    false
  fi
  trap - ERR
  echo "slurm-cluster: up ($host, $cpus CPUs, $mem MiB); export SLURM_CONF=$SLURM_CONF"
}

case "${1:-}" in
  install) install ;;
  start) [ $# -eq 2 ] || usage; start "$2" ;;
  stop) [ $# -eq 2 ] || usage; stop "$2" ;;
  *) usage ;;
esac
