#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, for trying strandmesh's job arrays (docs/batch.md)
# and for the test labelled `slurm`. Everything lives in one state folder (default
# /tmp/strandmesh-slurm): its own munge key and socket, slurm.conf, spool and logs; nothing in
# /etc is touched, and only the daemons started here are stopped here.
#
#   scripts/slurm_localhost.sh install   # Debian packages slurm-wlm and munge (as root)
#   scripts/slurm_localhost.sh start     # munged, slurmctld, slurmd; waits until the node is idle
#   eval "$(scripts/slurm_localhost.sh env)"   # SLURM_CONF for sbatch, squeue, sinfo in this shell
#   scripts/slurm_localhost.sh stop
#
# The daemons run as the calling user (root in a container or CI; as another user slurmd cannot
# start jobs for others, which a test does not need). Set STRANDMESH_SLURM_DIR to use another folder.
set -euo pipefail
STATE="${STRANDMESH_SLURM_DIR:-/tmp/strandmesh-slurm}"
CONF="$STATE/slurm.conf"
log() { printf '\033[1m[slurm]\033[0m %s\n' "$*" >&2; }

install_packages() {
  source "$(dirname "$0")/common.sh"
  STRANDMESH_PACKAGES=(slurm-wlm munge)
  ensure_packages
}

write_config() {
  mkdir -p "$STATE"/{spool/slurmctld,spool/slurmd,log,munge}
  chmod 700 "$STATE/munge"
  [ -f "$STATE/munge/munge.key" ] || mungekey --create --keyfile="$STATE/munge/munge.key" >/dev/null 2>&1 ||
    dd if=/dev/urandom of="$STATE/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$STATE/munge/munge.key"
  local host cpus mem user
  host="$(hostname -s)"
  cpus="$(nproc)"
  mem="$(awk '/MemTotal/ {printf "%d", $2 / 1024 * 0.9}' /proc/meminfo)"
  user="$(id -un)"
  cat >"$CONF" <<EOF
# Written by scripts/slurm_localhost.sh: one node, no accounting, no cgroups.
ClusterName=strandmesh
SlurmctldHost=$host(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
AuthInfo=socket=$STATE/munge/munge.sock
CredType=cred/munge
SlurmctldPort=16817
SlurmdPort=16818
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
StateSaveLocation=$STATE/spool/slurmctld
SlurmdSpoolDir=$STATE/spool/slurmd
SlurmctldPidFile=$STATE/slurmctld.pid
SlurmdPidFile=$STATE/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
}

# A daemon is alive while its pid file names a running process (it removes the file on exit).
alive() {
  local pid
  pid=$(cat "$1" 2>/dev/null) && [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null
}

start() {
  for tool in munged slurmctld slurmd sbatch; do
    command -v "$tool" >/dev/null || { log "$tool not found: run '$0 install' first"; exit 77; }
  done
  write_config
  export SLURM_CONF="$CONF"
  if ! alive "$STATE/munge/munged.pid"; then
    munged --force --key-file="$STATE/munge/munge.key" --socket="$STATE/munge/munge.sock" \
      --pid-file="$STATE/munge/munged.pid" --log-file="$STATE/log/munged.log" --seed-file="$STATE/munge/munge.seed"
  fi
  alive "$STATE/slurmctld.pid" || slurmctld -f "$CONF"
  alive "$STATE/slurmd.pid" || slurmd -f "$CONF"
  for _ in $(seq 1 60); do
    if sinfo -h -o '%t' 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then
      log "node $(hostname -s) up ($(nproc) CPUs); state in $STATE"
      return 0
    fi
    sleep 1
  done
  log "the node did not come up; see $STATE/log/"
  sinfo 2>&1 | head -5 >&2 || true
  exit 1
}

stop() {
  for pidfile in "$STATE/slurmd.pid" "$STATE/slurmctld.pid" "$STATE/munge/munged.pid"; do
    if alive "$pidfile"; then
      kill "$(cat "$pidfile" 2>/dev/null)" 2>/dev/null || true
      for _ in $(seq 1 50); do alive "$pidfile" || break; sleep 0.1; done
    fi
  done
  log "stopped"
}

case "${1:-}" in
  install) install_packages ;;
  start) start ;;
  stop) stop ;;
  env) echo "export SLURM_CONF=$CONF" ;;
  *) sed -n '2,14p' "$0" >&2; exit 2 ;;
esac
