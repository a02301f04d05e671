#!/usr/bin/env bash
# B5 (docs/benchmarks.md): the paper-scale scene's sweep in N shards, run as a Slurm job array on a
# one-node cluster started here (tools/slurm_one_node.sh), then merged and edited by the plan's
# dependent jobs. Each shard gets every core of the node (--cpus-per-task), so the shards run one
# after the other and each shard's time is what one machine like this one takes for it.
#
#   tools/bench_shards.sh [BUILD_DIR] [SHARDS] [VOXEL] [ANGLE_STEP] [MACHINES]   (build 8 0.005 1.0 8)
#
# Prints per shard its key segments and angles, wall time and peak memory (from shard.json), the
# merge's and the edit's times, and the estimate for MACHINES machines: the shards' measured times
# scheduled as Slurm starts an array's tasks (in order, each on the first machine free), plus the
# merge. With SHARDS = MACHINES that is the longest shard plus the merge.
set -euo pipefail
source_dir="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-build}" && pwd)"
shards="${2:-8}"
voxel="${3:-0.005}"
step="${4:-1.0}"
machines="${5:-8}"
work="$(mktemp -d)"
source "$source_dir/tools/slurm_one_node.sh"
trap 'slurm_one_node_stop; rm -rf "$work"' EXIT

"$build/tools/amhv_make_paper_scene" "$work/scene" > /dev/null
sed -i "s/^voxel = .*/voxel = $voxel/; s/^angle_step_deg = .*/angle_step_deg = $step/" "$work/scene/scene.toml"
slurm_one_node_start "$work/slurm"
"$build/amhv" plan "$work/scene/scene.toml" --shards "$shards" --cpus-per-task "$(nproc)" --out "$work/plan" > /dev/null
start=$(date +%s.%N)
submitted=$(bash "$work/plan/slurm.sbatch")
echo "$submitted"
for step_name in shards merge edit; do
  id=$(sed -n "s/.*$step_name=\([0-9]*\).*/\1/p" <<< "$submitted")
  echo "$step_name job $id: $(wait_for_job "$id" 14400) at $(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$(date +%s.%N)") s"
done
python3 - "$work/plan" "$machines" <<'EOF'
import heapq, json, pathlib, sys
plan = pathlib.Path(sys.argv[1])
machines = int(sys.argv[2])
shards = sorted((plan / "shards").iterdir(), key=lambda p: int(p.name))
print("| shard | key segments (angles) | wall | peak memory |")
print("|---|---|---|---|")
longest = 0
times = []
for folder in shards:
    m = json.load(open(folder / "shard.json"))
    pieces = ", ".join(f"{p['segment']} ({p['angles'][0]}-{p['angles'][1]})" for p in m["pieces"])
    t = m["timings_s"]
    longest = max(longest, t["total"])
    times.append(t["total"])
    print(f"| {m['shard']['index']} | {pieces} | {t['total']:.1f} s | {t['peak_memory_mb'] / 1024:.2f} GiB |")
merged = json.load(open(plan / "sweep/result.json"))["timings_s"]
s = merged["shards"]
print(f"shards: {s['seconds']:.1f} s in all, longest {s['longest_s']:.1f} s, peak {s['peak_memory_mb'] / 1024:.2f} GiB")
edit = plan / "edit/result.json"
edit_s = f"{json.load(open(edit))['timings_s']['total']:.1f} s" if edit.exists() else "did not finish"
print(f"merge: {merged['total']:.1f} s; edit --from-sweep: {edit_s}")
free = [0.0] * machines  # when each machine is next free; tasks start in array order
for t in times:
    heapq.heappush(free, heapq.heappop(free) + t)
print(f"estimate for {machines} machines: the shards {max(free):.1f} s (longest shard {longest:.1f} s) + merge = {max(free) + merged['total']:.1f} s")
EOF
