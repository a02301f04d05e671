#!/usr/bin/env bash
# A one-node Slurm cluster for the scale-out test and benchmark (sourced, not run): Debian's
# slurm-wlm daemons in the foreground with a generated slurm.conf in a folder of the caller's;
# auth/none and cred/none, so no munge; free ports on 127.0.0.1, so that runs never collide.
#
#   source tools/slurm_one_node.sh
#   slurm_one_node_start DIR      # exports SLURM_CONF; sbatch, squeue, scontrol then talk to it
#   wait_for_job ID [SECONDS]     # prints the job's end state (JobState=COMPLETED, ...), or TIMEOUT
#   slurm_one_node_stop           # stops the daemons it started, by their pids
#

slurm_daemons=()

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

slurm_one_node_start() {
  local dir="$1" node user
  mkdir -p "$dir"
  export SLURM_CONF="$dir/slurm.conf"
  node=$(hostname -s)
  user=$(id -un)
  mkdir -p "$dir/state" "$dir/spool"
  cat > "$SLURM_CONF" <<EOF
ClusterName=amhvtest
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/none
CredType=cred/none
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
NodeName=$node NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
  slurmctld -D -i -f "$SLURM_CONF" > "$dir/slurmctld.out" 2>&1 &
  slurm_daemons+=($!)
  slurmd -D -f "$SLURM_CONF" -N "$node" > "$dir/slurmd.out" 2>&1 &
  slurm_daemons+=($!)
  for _ in $(seq 120); do
    [ "$(sinfo -h -N -o %T 2>/dev/null)" = "idle" ] && return 0
    sleep 0.5
  done
  echo "slurm_one_node: the cluster did not come up: $(sinfo 2>&1 | tail -n 2)" >&2
  return 1
}

slurm_one_node_stop() {
  local pid
  for pid in "${slurm_daemons[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${slurm_daemons[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
    kill -9 "$pid" 2>/dev/null || true
  done
  slurm_daemons=()
}

# Waits until job $1 (every task of an array) has ended, at most $2 seconds (900); prints its
# JobState (COMPLETED, FAILED, CANCELLED, ...).
wait_for_job() {
  local state
  for _ in $(seq $((2 * ${2:-900}))); do
    state=$(scontrol show job "$1" -o 2>/dev/null | grep -o 'JobState=[A-Z_]*' | sort -u | tr '\n' ' ')
    case "$state" in
      *PENDING* | *RUNNING* | *CONFIGURING* | *COMPLETING* | "") sleep 0.5 ;;
      *) echo "$state"; return 0 ;;
    esac
  done
  echo "TIMEOUT"
}

