#!/bin/bash
# Runs the Slurm recipes of docs/cluster.md (the job scripts in
# scripts/slurm/, as they are) on a one-node Slurm started here, and compares
# their results with the unsharded ones bit for bit (issue 33). Not part of CI.
#
#   just slurm-check        (= cargo build --release && scripts/slurm_check.sh)
#
# Needs root on Debian: installs slurm-wlm and munge with apt if missing,
# starts munged, slurmctld and slurmd in the background from a temporary
# directory (own key, socket, ports 16817/16818, spool), and at the end stops
# exactly those three processes (by the PIDs it kept) and removes the
# directory. Nothing outside the temporary directory is written but the
# packages.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
bin="$repo/target/release/stickslip"
[ -x "$bin" ] || { echo "error: build first: cargo build --release" >&2; exit 1; }
[ "$(id -u)" = 0 ] || { echo "error: run as root (munged and slurmd)" >&2; exit 1; }
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  echo "installing slurm-wlm and munge (apt)"
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends slurm-wlm munge >/dev/null
fi

tmp=$(mktemp -d /tmp/stickslip-slurm.XXXXXX)
chmod 755 "$tmp"
pids=()
cleanup() {
  set +e
  if [ -n "${SLURM_CONF:-}" ] && [ ${#pids[@]} -gt 1 ]; then
    scancel --quiet --user=root 2>/dev/null
  fi
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
  done
  echo "stopped the ${#pids[@]} processes it started (pids ${pids[*]})"
  rm -rf "$tmp"
}
trap cleanup EXIT

# munge: own key (a private directory), socket (a directory all may enter),
# run as the munge user.
mkdir -p "$tmp/munge-key" "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge-key/munge.key" bs=1024 count=1 2>/dev/null
chown -R munge:munge "$tmp/munge-key" "$tmp/munge"
chmod 700 "$tmp/munge-key"
chmod 400 "$tmp/munge-key/munge.key"
chmod 755 "$tmp/munge"
setpriv --reuid=munge --regid=munge --init-groups munged -F \
  --socket="$tmp/munge/munge.socket" --key-file="$tmp/munge-key/munge.key" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" \
  --seed-file="$tmp/munge/munged.seed" 2>"$tmp/munged.err" &
pids+=($!)
for _ in $(seq 50); do [ -S "$tmp/munge/munge.socket" ] && break; sleep 0.1; done
[ -S "$tmp/munge/munge.socket" ] || { echo "error: munged did not start:"; tail -n 3 "$tmp/munged.err"; exit 1; }

# One node, two CPUs, no accounting, state under $tmp.
mkdir -p "$tmp/state" "$tmp/spool"
cpus=$(nproc)
cat >"$tmp/slurm.conf" <<EOF
ClusterName=stickslip-check
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
AuthType=auth/munge
AuthInfo=socket=$tmp/munge/munge.socket
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=check Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$tmp/slurm.conf"
slurmctld -D -f "$SLURM_CONF" >"$tmp/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -N localhost -f "$SLURM_CONF" >"$tmp/slurmd.out" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
  sinfo -h -o %T 2>/dev/null | grep -qx idle && break
  sleep 0.2
done
sinfo -h -o %T | grep -qx idle || { echo "error: the node did not come up:"; tail -n 5 "$tmp"/slurm*.log; exit 1; }
echo "$(sinfo -V), one node ($cpus CPUs): munged, slurmctld, slurmd = pids ${pids[*]}"

# The campaign directory: the jobs run in it, with stickslip on PATH (sbatch
# exports the submitting shell's PATH).
work="$tmp/work"
mkdir -p "$work"
cp "$repo"/datasets/char_N{1.2,2.2,4,7.2,30}.mcap "$work/"
export PATH="$repo/target/release:$PATH"
cd "$work"
jobs_of="$repo/scripts/slurm"
wait_job() { # waits until job $1 (and its array tasks) left the queue
  for _ in $(seq 1800); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 0.5
  done
  echo "error: job $1 still queued after 15 min"; squeue; exit 1
}
state_of() { scontrol show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z]*' | head -1 | cut -d= -f2; }
fail=0
check() { # name, command...
  local name=$1; shift
  if "$@"; then echo "ok   $name"; else echo "FAIL $name"; fail=1; fi
}

# 1. A sharded sweep, arrays from 0 and from 1, afterany merge: the merged
#    table is the unsharded one, byte for byte.
sweep_args=(--m 4 --k 1 --rho-s 0.3,0.5,0.7 --from-rest --eta-min 0.4 --eta-max 1.4 --points 30)
stickslip sweep "${sweep_args[@]}" --out ref.parquet 2>/dev/null
for array in 0-2 1-3; do
  rm -rf parts
  job=$(sbatch --parsable --array=$array --cpus-per-task=1 "$jobs_of/sweep-shard.sbatch" "${sweep_args[@]}")
  merge=$(sbatch --parsable --dependency=afterany:$job "$jobs_of/sweep-merge.sbatch" map.parquet)
  wait_job "$merge"
  check "sweep --array=$array, afterany merge: map.parquet = unsharded table (cmp)" cmp -s map.parquet ref.parquet
  rm -f map.parquet
done
threads=$(grep -ho 'RAYON_NUM_THREADS=[0-9]*' slurm-*.out | sort -u | tr '\n' ' ')
check "--cpus-per-task=1 -> $threads" test "$threads" = "RAYON_NUM_THREADS=1 "

# 2. A failed task: the afterany merge runs and names the missing shard.
rm -rf parts slurm-*.out
job=$(sbatch --parsable --hold --array=0-2 --cpus-per-task=1 "$jobs_of/sweep-shard.sbatch" "${sweep_args[@]}")
scancel "${job}_1"
scontrol release "$job" >/dev/null
merge=$(sbatch --parsable --dependency=afterany:$job "$jobs_of/sweep-merge.sbatch" map.parquet)
wait_job "$merge"
said=$(grep -h '^error:' "slurm-$merge.out" || true)
check "task 1 of --array=0-2 cancelled: merge $(state_of "$merge"), said: $said" \
  grep -q 'incomplete set of shards: 1 of 3 missing (2/3)' "slurm-$merge.out"

# 3. Fits -> merge -> batch: batch.json equals batch on the logs (every key
#    but wall times), for arrays from 0 and from 1.
logs=(char_N1.2.mcap char_N2.2.mcap char_N4.mcap char_N7.2.mcap char_N30.mcap)
stickslip batch "${logs[@]}" --out ref-batch.json 2>/dev/null
same_json() {
  python3 - "$1" "$2" <<'EOF'
import json, sys
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if k not in ("seconds", "stage_seconds")}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
a, b = (strip(json.load(open(p))) for p in sys.argv[1:3])
sys.exit(0 if a == b else 1)
EOF
}
for array in 0-2 1-3; do
  rm -rf parts fits.json batch.json
  job=$(sbatch --parsable --array=$array --cpus-per-task=1 "$jobs_of/fit-shard.sbatch" "${logs[@]}")
  batch=$(sbatch --parsable --dependency=afterany:$job --cpus-per-task=2 "$jobs_of/fit-merge-batch.sbatch")
  wait_job "$batch"
  check "fit --array=$array -> merge -> batch --fits: batch.json = batch on the logs (but seconds)" same_json batch.json ref-batch.json
done
mu=$(python3 -c "import json; b=json.load(open('batch.json')); print('mu_s', b['mu_s'], 'mu_d', b['mu_d'], 'recommended', b['recommended_normal_force_n'], 'N')")
echo "     ($mu)"
[ $fail = 0 ] && echo "slurm-check: all passed" || echo "slurm-check: FAILED"
exit $fail
