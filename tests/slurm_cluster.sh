#!/usr/bin/env bash
# The scale-out test on a real Slurm (issue "Scale-out"): a one-node cluster of Debian's slurm-wlm
# (slurmctld and slurmd in the foreground, a generated slurm.conf in a temporary folder, auth/none
# and cred/none so that no munge is needed), the handshake scene planned in 4 shards and submitted
# with the plan's own slurm.sbatch: the job array of shards, the merge after it (afterok), the edit
# after the merge. The merged folder must equal a one-machine `amhv sweep` byte for byte, and the
# edit must have read it. The daemons it started are stopped by their pids, also on failure.
#
#   slurm_cluster.sh AMHV SOURCE_DIR
set -euo pipefail
amhv="$1"
scene="$2/data/scenes/handshake.toml"
work=$(mktemp -d "${TMPDIR:-/tmp}/amhv-slurm.XXXXXX")
source "$2/tools/slurm_one_node.sh"
jobs_submitted=()

cleanup() {
  if [ ${#jobs_submitted[@]} -gt 0 ]; then timeout 20 scancel --quiet "${jobs_submitted[@]}" 2>/dev/null || true; fi
  slurm_one_node_stop
  rm -rf "$work"
}
trap cleanup EXIT

fail() {
  echo "slurm test: $*" >&2
  for f in "$work"/slurm/*.log "$work"/plan/logs/*.out; do
    [ -f "$f" ] && { echo "== $f"; tail -n 15 "$f"; } >&2
  done
  exit 1
}

slurm_one_node_start "$work/slurm" || fail "the one-node cluster did not come up"
"$amhv" sweep "$scene" --out "$work/one" --no-timings > /dev/null || fail "the one-machine sweep failed"
"$amhv" plan "$scene" --shards 4 --cpus-per-task 1 --no-timings --out "$work/plan" > /dev/null || fail "amhv plan failed"
submitted=$(bash "$work/plan/slurm.sbatch") || fail "slurm.sbatch could not submit: $submitted"
echo "$submitted"
for step in shards merge edit; do
  id=$(sed -n "s/.*$step=\([0-9]*\).*/\1/p" <<< "$submitted")
  [ -n "$id" ] || fail "slurm.sbatch printed no $step job: $submitted"
  jobs_submitted+=("$id")
done
for n in 0 1 2; do
  state=$(wait_for_job "${jobs_submitted[$n]}")
  [ "$state" = "JobState=COMPLETED " ] || fail "job ${jobs_submitted[$n]} ended as $state"
done

[ "$(ls "$work/plan/shards")" = "$(printf '1\n2\n3\n4')" ] || fail "the shards are not shards/1..4: $(ls "$work/plan/shards")"
diff -r "$work/one" "$work/plan/sweep" > "$work/diff.txt" || fail "the merged sweep differs from the one-machine sweep: $(head -n 5 "$work/diff.txt")"
grep -q "\"from_sweep\": \"$work/plan/sweep\"" "$work/plan/edit/result.json" || fail "the edit did not read the merged sweep"
echo "slurm test: 4 shards as a job array, merged byte-identical to one machine, edited from the merge"
