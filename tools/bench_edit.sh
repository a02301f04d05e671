#!/usr/bin/env bash
# B3 (docs/benchmarks.md): the paper-scale scene through `amhv edit`, timed.
#
#   tools/bench_edit.sh [BUILD_DIR] [RUNS] [VOXEL] [ANGLE_STEP]
#
# Writes the scene with amhv_make_paper_scene into a temporary folder (10 mm / 2 deg, or the voxel
# and angle step given), runs `amhv edit` RUNS times (3 by default), and prints per run the wall
# time, the peak resident memory and result.json's timings_s, then the median wall time. The edit's
# outputs go to a temporary folder that is removed at the end.
set -euo pipefail
build="${1:-build}"
runs="${2:-3}"
voxel="${3:-0.01}"
step="${4:-2.0}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
"$build/tools/amhv_make_paper_scene" "$work/scene" > /dev/null
sed -i "s/^voxel = .*/voxel = $voxel/; s/^angle_step_deg = .*/angle_step_deg = $step/" "$work/scene/scene.toml"
walls=()
for run in $(seq 1 "$runs"); do
  /usr/bin/time -f "%e %M" -o "$work/time" "$build/amhv" edit "$work/scene/scene.toml" --out "$work/out" > /dev/null
  read -r wall rss < "$work/time"
  walls+=("$wall")
  timings="$(python3 -c 'import json,sys; t=json.load(open(sys.argv[1]))["timings_s"]; print(" ".join(f"{k} {v:.2f}" for k,v in t.items()))' "$work/out/result.json")"
  echo "run $run: ${wall} s wall, $((rss / 1024)) MiB peak; timings_s: $timings"
done
printf '%s\n' "${walls[@]}" | sort -n | awk '{a[NR]=$1} END {print "median wall: " a[int((NR+1)/2)] " s over " NR " runs"}'
