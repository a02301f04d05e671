#!/usr/bin/env bash
# B5 (docs/benchmarks.md): the paper-scale scene's sweep in N shards, run as a Slurm job array on a
# one-node cluster started here (tools/slurm_one_node.sh), then merged and edited by the plan's
# dependent jobs. Each shard gets every core of the node (--cpus-per-task), so the shards run one
# after the other and each shard's time is what one machine like this one takes for it.
#
#   tools/bench_shards.sh [BUILD_DIR] [SHARDS] [VOXEL] [ANGLE_STEP]     (build 8 0.005 1.0)
#
# Prints per shard its key segments and angles, wall time and peak memory (from shard.json), the
# merge's and the edit's times, and the estimate for N machines: the longest shard plus the merge.
set -euo pipefail
source_dir="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:-build}" && pwd)"
shards="${2:-8}"
voxel="${3:-0.005}"
step="${4:-1.0}"
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
python3 - "$work/plan" <<'EOF'
import json, pathlib, sys
plan = pathlib.Path(sys.argv[1])
shards = sorted((plan / "shards").iterdir(), key=lambda p: int(p.name))
print("| shard | key segments (angles) | wall | peak memory |")
print("|---|---|---|---|")
longest = 0
for folder in shards:
    m = json.load(open(folder / "shard.json"))
    pieces = ", ".join(f"{p['segment']} ({p['angles'][0]}-{p['angles'][1]})" for p in m["pieces"])
    t = m["timings_s"]
    longest = max(longest, t["total"])
    print(f"| {m['shard']['index']} | {pieces} | {t['total']:.1f} s | {t['peak_memory_mb'] / 1024:.2f} GiB |")
merged = json.load(open(plan / "sweep/result.json"))["timings_s"]
s = merged["shards"]
print(f"shards: {s['seconds']:.1f} s in all, longest {s['longest_s']:.1f} s, peak {s['peak_memory_mb'] / 1024:.2f} GiB")
edit = plan / "edit/result.json"
edit_s = f"{json.load(open(edit))['timings_s']['total']:.1f} s" if edit.exists() else "did not finish"
print(f"merge: {merged['total']:.1f} s; edit --from-sweep: {edit_s}")
print(f"estimate for {len(shards)} machines: longest shard + merge = {longest + merged['total']:.1f} s")
EOF
