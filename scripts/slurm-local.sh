#!/usr/bin/env bash
# A throw-away one-node Slurm cluster on 127.0.0.1 for tests (docs/cluster.md, "Local cluster").
#
#   scripts/slurm-local.sh check             exit 0 if a cluster can start here, else exit 77
#                                            and print the reason on one line (tests skip on it)
#   scripts/slurm-local.sh start DIR [CPUS]  start munged, slurmctld and slurmd with every file
#                                            under DIR (created; must not exist or be empty);
#                                            writes DIR/env.sh (SLURM_CONF=...) and prints
#                                            {"dir":..., "slurm_conf":..., "start_s":...}
#   scripts/slurm-local.sh stop DIR          stop the three daemons by their pid files and
#                                            remove DIR
#   scripts/slurm-local.sh restart DIR [CPUS]  stop (a cluster left by a killed run), then start
#
# The packages are test-only: scripts/install-cluster-test-deps.sh installs them
# (scripts/install-deps.sh does not).
#
# Nothing outside DIR is touched: its own munge key (generated here), socket and seed file;
# its own slurm.conf, state, spool and log directories; ports picked free on 127.0.0.1. No
# systemd: the daemons are started directly. Accounting is off (no slurmdbd); the job
# completion log (jobcomp/filetxt, DIR/log/jobcomp.txt) records every finished job, and
# `sacct --completion` reads it. Slurm needs root here: slurmd starts job steps as the
# submitting user and slurmstepd needs the privileges for it.
set -euo pipefail

die() { echo "slurm-local: $*" >&2; exit 1; }
skip() { echo "slurm-local: cannot run here: $*"; exit 77; }

daemons=(munged slurmctld slurmd sbatch squeue scontrol sacct sinfo)

cmd_check() {
  [ "$(id -u)" -eq 0 ] || skip "needs root (slurmd runs job steps as the submitting user)"
  local missing=()
  for d in "${daemons[@]}"; do
    command -v "$d" >/dev/null 2>&1 || [ -x "/usr/sbin/$d" ] || missing+=("$d")
  done
  [ ${#missing[@]} -eq 0 ] || skip "missing ${missing[*]} (Debian 12 packages slurm-wlm and munge: run 'sudo scripts/install-cluster-test-deps.sh')"
  command -v python3 >/dev/null 2>&1 || skip "python3 missing (picks free ports)"
  exit 0
}

# Prints N distinct ports that were free on 127.0.0.1 a moment ago (bound, then released).
free_ports() {
  python3 - "$1" <<'EOF'
import socket, sys
socks = []
for _ in range(int(sys.argv[1])):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    socks.append(s)
print(" ".join(str(s.getsockname()[1]) for s in socks))
EOF
}

write_conf() {
  local dir=$1 cpus=$2 ctl_port=$3 slurmd_port=$4 host
  host=$(hostname -s)
  cat >"$dir/etc/slurm.conf" <<EOF
# Written by scripts/slurm-local.sh for one test run; everything lives under $dir.
ClusterName=hdrdlocal
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctl_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroups in a container: track job processes by their parent pids.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$dir/log/jobcomp.txt
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# A node with fewer cores than configured stays up (the test runs 3 one-CPU shards at once
# on a 2-core machine); ReturnToService=2 makes it usable as soon as slurmd registers.
SlurmdParameters=config_overrides
ReturnToService=2
# Finished jobs stay visible to squeue/scontrol for 10 minutes.
MinJobAge=600
KillWait=5
InactiveLimit=0
NodeName=hdrdnode NodeHostname=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=1024 State=UNKNOWN
PartitionName=hdrd Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
}

# wait_for SECONDS COMMAND...: runs COMMAND until it succeeds; returns 1 after SECONDS.
wait_for() {
  local limit=$1 t0=$SECONDS
  shift
  until "$@" >/dev/null 2>&1; do
    (( SECONDS - t0 < limit )) || return 1
    sleep 0.1
  done
}

controller_up() { scontrol ping | grep -q UP; }
node_up() { sinfo -h -N -o %t | grep -Eq '^(idle|mix|alloc)$'; }

cmd_start() {
  local dir=${1:?start needs a directory} cpus=${2:-4}
  ( cmd_check ) >&2 || exit 77
  if [ -e "$dir" ] && [ -n "$(ls -A "$dir" 2>/dev/null)" ]; then die "$dir exists and is not empty"; fi
  local t_start
  t_start=$(date +%s.%N)
  mkdir -p "$dir"/{etc,munge,state,spool,run,log}
  dir=$(cd "$dir" && pwd)
  chmod 0700 "$dir" "$dir/munge"
  # Its own munge key: 1024 random bytes, readable by root only (munged refuses looser modes).
  head -c 1024 /dev/urandom >"$dir/munge/munge.key"
  chmod 0400 "$dir/munge/munge.key"
  local ports
  read -r -a ports <<<"$(free_ports 2)"
  write_conf "$dir" "$cpus" "${ports[0]}" "${ports[1]}"
  cat >"$dir/env.sh" <<EOF
export SLURM_CONF=$dir/etc/slurm.conf
EOF

  # --force: munged otherwise refuses a key and socket outside its packaged directories
  # when their parents (e.g. /tmp) are writable by others.
  munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/munge/munged.seed" || { cat "$dir/log/munged.log" >&2; die "munged did not start"; }
  wait_for 10 munge --socket="$dir/munge/munge.socket" --input=/dev/null || die "munged does not answer"

  export SLURM_CONF=$dir/etc/slurm.conf
  slurmctld -f "$SLURM_CONF" || { tail -20 "$dir/log/slurmctld.log" >&2; die "slurmctld did not start"; }
  wait_for 20 controller_up || { tail -20 "$dir/log/slurmctld.log" >&2; die "slurmctld does not answer"; }
  slurmd -f "$SLURM_CONF" -N hdrdnode || { tail -20 "$dir/log/slurmd.log" >&2; die "slurmd did not start"; }
  # Ready when the node takes jobs: idle (or mixed/allocated), not down/unknown/drained.
  wait_for 30 node_up \
    || { tail -20 "$dir/log/slurmd.log" >&2; sinfo -N -l >&2 || true; die "slurmd did not register with slurmctld"; }
  local t_end
  t_end=$(date +%s.%N)
  python3 -c 'import json,sys; print(json.dumps({"dir": sys.argv[1], "slurm_conf": sys.argv[2], "start_s": round(float(sys.argv[4]) - float(sys.argv[3]), 3)}))' \
    "$dir" "$SLURM_CONF" "$t_start" "$t_end"
}

# Sends SIGTERM to the pid in a pid file, if that process is still the named daemon (a pid
# file left by a killed run may name a reused pid), and waits up to 10 s (then SIGKILL).
stop_pid() {
  local pidfile=$1 name=$2 pid
  [ -f "$pidfile" ] || return 0
  pid=$(cat "$pidfile" 2>/dev/null || true)
  [[ "$pid" =~ ^[0-9]+$ ]] || return 0
  [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$name" ] || return 0
  kill -TERM "$pid" 2>/dev/null || return 0
  for _ in $(seq 100); do
    kill -0 "$pid" 2>/dev/null || return 0
    sleep 0.1
  done
  kill -KILL "$pid" 2>/dev/null || true
}

cmd_stop() {
  local dir=${1:?stop needs a directory}
  [ -d "$dir" ] || return 0
  [ -f "$dir/etc/slurm.conf" ] || die "$dir is not a slurm-local directory (no etc/slurm.conf)"
  # Jobs first (their steps are children of slurmd), then the daemons in reverse start order.
  if [ -f "$dir/run/slurmctld.pid" ]; then
    SLURM_CONF=$dir/etc/slurm.conf timeout 10 scancel --quiet --full -u "$(id -un)" 2>/dev/null || true
  fi
  stop_pid "$dir/run/slurmd.pid" slurmd
  stop_pid "$dir/run/slurmctld.pid" slurmctld
  stop_pid "$dir/run/munged.pid" munged
  rm -rf "$dir"
}

case "${1:-}" in
  check) cmd_check ;;
  start) shift; cmd_start "$@" ;;
  stop) shift; cmd_stop "$@" ;;
  restart) shift; cmd_stop "${1:?restart needs a directory}"; cmd_start "$@" ;;
  *) echo "usage: $0 check | start DIR [CPUS] | stop DIR | restart DIR [CPUS]" >&2; exit 2 ;;
esac
