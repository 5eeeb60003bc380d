#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for the `--executor slurm` tests and benchmarks.
#
#   scripts/slurm-local-cluster.sh up     # install (Debian packages) if needed, configure, start
#   scripts/slurm-local-cluster.sh down   # stop what `up` started and remove its files
#   scripts/slurm-local-cluster.sh status # say whether it is up
#
# Runs as root on a fresh Debian machine or container: no systemd, the daemons (munged,
# slurmctld, slurmd) are started directly and stopped by the process ids they record.
# The node is this machine (all its CPUs and memory) in one partition, `debug`, with one
# counted GPU (`gres: gpu:1`, no device) so that jobs asking for `--gres=gpu:1` schedule
# the way they do on a GPU cluster. Accounting is off: `sacct` has nothing to say here,
# `squeue` keeps finished jobs for MinJobAge (300 s).
#
# `up` refuses to touch a slurm.conf it did not write (a real cluster's).
set -euo pipefail

MARK="# written by objectsplat scripts/slurm-local-cluster.sh"
CONF_DIR=/etc/slurm
CONF="$CONF_DIR/slurm.conf"
GRES_CONF="$CONF_DIR/gres.conf"
STATE=/var/lib/objectsplat-slurm
RUN=/run/objectsplat-slurm
LOG=/var/log/objectsplat-slurm

die() { echo "slurm-local-cluster: $*" >&2; exit 1; }

ours() { [ -f "$CONF" ] && head -n 1 "$CONF" | grep -qF "$MARK"; }

install_packages() {
  if command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
     && command -v sbatch >/dev/null && command -v munged >/dev/null; then
    return
  fi
  command -v apt-get >/dev/null || die "slurmctld, slurmd, sbatch or munged is missing and there is no apt-get to install them"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  # The split packages of Debian 12 (what the `slurm-wlm` metapackage pulls in).
  apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
}

alive() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

start_munge() {
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  chown munge:munge /run/munge /var/log/munge /var/lib/munge
  chmod 0755 /run/munge
  if [ ! -s /etc/munge/munge.key ]; then
    mkdir -p /etc/munge
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
  fi
  chown munge:munge /etc/munge /etc/munge/munge.key
  chmod 0700 /etc/munge
  chmod 0400 /etc/munge/munge.key
  if alive /run/munge/munged.pid; then return; fi
  runuser -u munge -- /usr/sbin/munged --pid-file=/run/munge/munged.pid
  for _ in $(seq 50); do munge -n </dev/null >/dev/null 2>&1 && return; sleep 0.1; done
  die "munged did not answer (see /var/log/munge/munged.log)"
}

write_conf() {
  local host cpus mem_mb
  host=$(hostname -s)
  cpus=$(nproc --all)
  # Leave 512 MiB to the system, so a job asking for "all" memory still schedules.
  mem_mb=$(awk '/^MemTotal:/ { printf "%d", $2 / 1024 - 512 }' /proc/meminfo)
  mkdir -p "$CONF_DIR" "$STATE/ctld" "$STATE/d" "$RUN" "$LOG"
  cat >"$CONF" <<EOF
$MARK (remove with \`down\`)
ClusterName=objectsplat-local
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/d
SlurmctldPidFile=$RUN/slurmctld.pid
SlurmdPidFile=$RUN/slurmd.pid
SlurmctldLogFile=$LOG/slurmctld.log
SlurmdLogFile=$LOG/slurmd.log
# No cgroups in a container: processes are tracked by their parent ids.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
GresTypes=gpu
# Quick turnaround on one machine (the defaults are tuned for thousands of nodes).
SchedulerParameters=batch_sched_delay=0,sched_min_interval=100000
MessageTimeout=30
# Room for a 10k-item fan-out: every array task is a job record, and finished ones are
# kept MinJobAge seconds (the default MaxJobCount, 10000, makes sbatch wait at 10k).
MaxJobCount=50000
MinJobAge=300
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb Gres=gpu:1 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  cat >"$GRES_CONF" <<EOF
$MARK
NodeName=$host Name=gpu File=/dev/null Count=1
EOF
}

wait_idle() {
  local host state
  host=$(hostname -s)
  for _ in $(seq 100); do
    state=$(sinfo -h -n "$host" -o '%T' 2>/dev/null || true)
    case "$state" in
      idle*|mixed*|allocated*) return ;;
      down*|drain*) scontrol update NodeName="$host" State=RESUME >/dev/null 2>&1 || true ;;
    esac
    sleep 0.2
  done
  die "the node did not come up (state: ${state:-unknown}); see $LOG/slurmctld.log and $LOG/slurmd.log"
}

up() {
  [ "$(id -u)" = 0 ] || die "run as root (it installs packages and starts daemons)"
  if [ -f "$CONF" ] && ! ours; then
    die "$CONF exists and was not written by this script: a real cluster is configured here; not touching it"
  fi
  install_packages
  start_munge
  write_conf
  alive "$RUN/slurmctld.pid" || /usr/sbin/slurmctld -i
  alive "$RUN/slurmd.pid" || /usr/sbin/slurmd
  wait_idle
  # One job end to end: submission, start, completion.
  local out
  out=$(timeout 60 srun -N1 -n1 -t 1 hostname) || die "a test job did not run; see $LOG/"
  echo "slurm-local-cluster: up (node $out, $(nproc --all) CPUs, partition debug, gres gpu:1)"
}

stop_pid() {
  local pidfile=$1 name=$2
  if alive "$pidfile"; then
    local pid
    pid=$(cat "$pidfile")
    kill "$pid"
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -0 "$pid" 2>/dev/null && { echo "slurm-local-cluster: $name ($pid) ignored SIGTERM; killing" >&2; kill -9 "$pid"; }
  fi
  rm -f "$pidfile"
}

down() {
  [ "$(id -u)" = 0 ] || die "run as root"
  if [ -f "$CONF" ] && ! ours; then
    die "$CONF was not written by this script; not stopping a real cluster"
  fi
  if ours && alive "$RUN/slurmctld.pid"; then
    scancel --full --quiet --user=root 2>/dev/null || true
    # scancel covers the jobs of every user that ran here.
    for u in $(squeue -h -o '%u' 2>/dev/null | sort -u); do scancel --quiet --user="$u" 2>/dev/null || true; done
  fi
  stop_pid "$RUN/slurmd.pid" slurmd
  stop_pid "$RUN/slurmctld.pid" slurmctld
  stop_pid /run/munge/munged.pid munged
  if ours; then rm -f "$CONF" "$GRES_CONF"; fi
  rm -rf "$STATE" "$RUN" "$LOG"
  echo "slurm-local-cluster: down"
}

status() {
  if ours && alive "$RUN/slurmctld.pid" && alive "$RUN/slurmd.pid"; then
    sinfo
  else
    echo "slurm-local-cluster: not up"
    return 1
  fi
}

case "${1:-}" in
  up) up ;;
  down) down ;;
  status) status ;;
  *) die "usage: $0 up|down|status" ;;
esac
