#!/usr/bin/env bash
# A throw-away single-node Slurm cluster for tests: everything (slurm.conf, munge key and socket,
# state, spool, logs, pid files) lives in one directory, on free TCP ports, so it neither needs
# nor disturbs a system Slurm or munge.
#
#   slurm_cluster.sh start DIR   writes DIR/slurm.conf, starts munged, slurmctld and slurmd,
#                                waits until the node is idle, writes DIR/env.sh
#                                (`. DIR/env.sh` exports SLURM_CONF for sbatch/squeue/...)
#   slurm_cluster.sh stop DIR    kills exactly the processes it started (by their pid files)
#   slurm_cluster.sh check       exit 0 when a cluster could start here, 77 (and why) otherwise
#
# Exit code 77 means "cannot run here" (not root, a binary missing): callers turn it into a
# skipped test. Needs root because slurmd must run as root to launch jobs as their users.
set -euo pipefail

SKIP=77
BINARIES=(munged mungekey slurmctld slurmd sbatch squeue sinfo scontrol scancel)

skip() {
  echo "SKIP: real-Slurm test cannot run here: $*" >&2
  exit "$SKIP"
}

find_bin() {
  # Daemons live in /usr/sbin, which is not on every PATH.
  local name=$1
  if command -v "$name" >/dev/null 2>&1; then command -v "$name"; return; fi
  for dir in /usr/sbin /sbin /usr/local/sbin; do
    if [ -x "$dir/$name" ]; then echo "$dir/$name"; return; fi
  done
  return 1
}

check() {
  [ "$(id -u)" -eq 0 ] || skip "needs root (slurmd launches jobs as their users); running as $(id -un)"
  local name
  for name in "${BINARIES[@]}"; do
    find_bin "$name" >/dev/null || skip "'$name' not found (install slurmctld slurmd slurm-client munge)"
  done
  command -v python3 >/dev/null 2>&1 || skip "python3 not found (used to find free ports)"
}

free_port() {
  python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()'
}

pid_alive() {
  local file=$1
  [ -s "$file" ] && kill -0 "$(cat "$file")" 2>/dev/null
}

wait_for() {
  # wait_for SECONDS DESCRIPTION COMMAND...: polls COMMAND every 0.2 s.
  local seconds=$1 what=$2
  shift 2
  local deadline=$((SECONDS + seconds))
  until "$@" >/dev/null 2>&1; do
    if ((SECONDS >= deadline)); then
      echo "slurm_cluster: timed out after ${seconds}s waiting for $what" >&2
      return 1
    fi
    sleep 0.2
  done
}

node_idle() {
  local state
  state=$(SLURM_CONF="$DIR/slurm.conf" "$SINFO" -h -N -n localhost -o %T 2>/dev/null) || return 1
  [ "$state" = "idle" ]
}

dump_logs() {
  local f
  for f in "$DIR"/log/*.log; do
    [ -f "$f" ] || continue
    echo "----- $f (last 20 lines)" >&2
    tail -n 20 "$f" >&2 || true
  done
}

start() {
  check
  mkdir -p "$DIR"
  DIR=$(cd "$DIR" && pwd)
  # munged insists that its key, socket and log directories are not writable by others.
  chmod 0700 "$DIR"
  mkdir -p "$DIR/munge" "$DIR/state" "$DIR/spool" "$DIR/log" "$DIR/run"
  chmod 0700 "$DIR/munge"

  local munged mungekey slurmctld slurmd
  munged=$(find_bin munged)
  mungekey=$(find_bin mungekey)
  slurmctld=$(find_bin slurmctld)
  slurmd=$(find_bin slurmd)
  SINFO=$(find_bin sinfo)

  # Our own munged: own key (created once), own socket, own pid file.
  if [ ! -s "$DIR/munge/munge.key" ]; then
    "$mungekey" --create --keyfile="$DIR/munge/munge.key" >/dev/null
    chmod 0600 "$DIR/munge/munge.key"
  fi
  local socket="$DIR/munge/munge.socket"
  "$munged" --force --socket="$socket" --key-file="$DIR/munge/munge.key" \
    --pid-file="$DIR/run/munged.pid" --log-file="$DIR/log/munged.log" \
    --seed-file="$DIR/munge/munged.seed" || { dump_logs; echo "slurm_cluster: munged failed" >&2; exit 1; }
  wait_for 10 "munged's pid file" pid_alive "$DIR/run/munged.pid" || { dump_logs; exit 1; }
  wait_for 10 "munged's socket" test -S "$socket" || { dump_logs; exit 1; }

  # The node's real size, as slurmd sees it.
  local probe cpus memory
  probe=$("$slurmd" -C | head -n 1)
  cpus=$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$probe")
  memory=$(sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p' <<<"$probe")
  [ -n "$cpus" ] || cpus=$(nproc)
  [ -n "$memory" ] || memory=1000
  local ctld_port slurmd_port
  ctld_port=$(free_port)
  slurmd_port=$(free_port)
  while [ "$slurmd_port" = "$ctld_port" ]; do slurmd_port=$(free_port); done

  cat >"$DIR/slurm.conf" <<EOF
# Written by tests/slurm/slurm_cluster.sh: a single-node test cluster confined to $DIR.
ClusterName=geltest
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool/slurmd-%n
SlurmctldPidFile=$DIR/run/slurmctld.pid
SlurmdPidFile=$DIR/run/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$DIR/log/jobcomp.txt
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
# Schedule batch jobs at once (the default batch_sched_delay=3 adds up to 3 s per job).
SchedulerParameters=batch_sched_delay=0
MpiDefault=none
ReturnToService=2
# Finished jobs stay visible to 'scontrol show job' for 5 minutes.
MinJobAge=300
KillWait=10
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
NodeName=localhost NodeHostname=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
  # Empty cgroup.conf/plugstack so no system file is read.
  : >"$DIR/plugstack.conf"
  echo "PlugStackConfig=$DIR/plugstack.conf" >>"$DIR/slurm.conf"

  export SLURM_CONF="$DIR/slurm.conf"
  # -i: ignore saved state (fresh job ids). Both daemons fork; their pid files name them.
  "$slurmctld" -i -f "$SLURM_CONF" || { dump_logs; echo "slurm_cluster: slurmctld failed" >&2; exit 1; }
  wait_for 15 "slurmctld's pid file" pid_alive "$DIR/run/slurmctld.pid" || { dump_logs; exit 1; }
  "$slurmd" -N localhost -f "$SLURM_CONF" || { dump_logs; echo "slurm_cluster: slurmd failed" >&2; exit 1; }
  wait_for 15 "slurmd's pid file" pid_alive "$DIR/run/slurmd.pid" || { dump_logs; exit 1; }
  wait_for 30 "node localhost to become idle" node_idle || { dump_logs; exit 1; }

  cat >"$DIR/env.sh" <<EOF
export SLURM_CONF=$DIR/slurm.conf
EOF
  echo "slurm_cluster: up in $DIR (slurmctld port $ctld_port, slurmd port $slurmd_port, $cpus CPUs, ${memory} MB)"
}

stop() {
  [ -d "$DIR" ] || return 0
  local name file pid i
  # Reverse start order; only the pids this script recorded.
  for name in slurmd slurmctld munged; do
    file="$DIR/run/$name.pid"
    [ -s "$file" ] || continue
    pid=$(cat "$file")
    if kill -0 "$pid" 2>/dev/null; then
      kill -TERM "$pid" 2>/dev/null || true
      for i in $(seq 1 50); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.2
      done
      if kill -0 "$pid" 2>/dev/null; then
        echo "slurm_cluster: $name ($pid) ignored SIGTERM for 10s; SIGKILL" >&2
        kill -KILL "$pid" 2>/dev/null || true
      fi
    fi
    rm -f "$file"
  done
  echo "slurm_cluster: stopped ($DIR)"
}

command=${1:-}
case "$command" in
  start)
    [ $# -eq 2 ] || { echo "usage: $0 start DIR" >&2; exit 2; }
    DIR=$2
    start
    ;;
  stop)
    [ $# -eq 2 ] || { echo "usage: $0 stop DIR" >&2; exit 2; }
    DIR=$2
    stop
    ;;
  check)
    check
    ;;
  *)
    echo "usage: $0 start DIR | stop DIR | check" >&2
    exit 2
    ;;
esac
