#!/usr/bin/env bash
# B4 (docs/benchmarks.md): the sweep's time and peak memory against the voxel size and the angle
# step, for one key segment of the paper-scale scene, and the plot of both.
#
#   tools/bench_growth.sh [BUILD_DIR] [SEGMENT] [OUT_DIR]
#
# Writes the scene with amhv_make_paper_scene into a temporary folder, runs amhv_bench_growth once
# per sampling (voxel 20, 10, 7, 5 mm x angle step 4, 2, 1 deg; one process each, so each peak is
# its own), and writes OUT_DIR/growth.csv and OUT_DIR/growth.png (default OUT_DIR: the current
# folder; it refuses to start when either file is already there, and touches nothing else).
set -euo pipefail
build="${1:-build}"
segment="${2:-1}"
out="${3:-.}"
voxels=(${AMHV_GROWTH_VOXELS:-0.02 0.01 0.007 0.005})
steps=(${AMHV_GROWTH_STEPS:-4 2 1})
for file in growth.csv growth.png; do
  if [ -e "$out/$file" ]; then echo "bench_growth: $out/$file is already there; move it or choose another folder" >&2; exit 1; fi
done
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
"$build/tools/amhv_make_paper_scene" "$work/scene" > /dev/null
"$build/tools/amhv_bench_growth" --header > "$work/growth.csv"
for step in "${steps[@]}"; do
  for voxel in "${voxels[@]}"; do
    "$build/tools/amhv_bench_growth" "$work/scene/scene.toml" "$segment" "$voxel" "$step" | tee -a "$work/growth.csv"
  done
done
"$build/tools/amhv_bench_growth" --plot "$work/growth.csv" "$work/growth.png"
cp "$work/growth.csv" "$work/growth.png" "$out/"
echo "wrote $out/growth.csv and $out/growth.png"
