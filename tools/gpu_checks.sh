#!/usr/bin/env bash
# The device checks of a machine with a discrete GPU in one prepared run (docs/benchmarks.md, "On a
# discrete GPU"): the test suite in 16 shards with validation on, B1 and B2 (Vulkan paths), B3 at 10 mm /
# 2 deg (alternating with a second build when given) and at 5 mm / 1 deg with its per-segment log,
# and B4's key segment 1 at four samplings.
#
#   tools/gpu_checks.sh BUNDLE.tar.xz OUT_DIR [BASE_AMHV]
#
# Run from the repository root on the GPU machine. BUNDLE comes from tools/gpu_bundle.sh (built
# here, carried there); BASE_AMHV is another build's `amhv` to time beside it (the same shared
# libraries). Every step has its own time limit (seconds, from the environment: GPU_TESTS_S,
# GPU_EDIT10_S, GPU_EDIT5_S, GPU_BENCH_S), so that one slow step leaves the others their share;
# OUT_DIR gets log.txt (the summary), tests.log, edit5.log and the edits' result.json files. Takes
# about six minutes on an H100 machine with the defaults. GPU_STEPS picks the steps (default "tests
# bench b4 b3 b3_5mm"). Where the bundle carries perf and it runs there, the 5 mm edit is recorded
# with it and OUT_DIR gets perf5.txt: the samples by library and symbol, and by thread. Where the
# bundle also carries a build with frame pointers (bin/amhv_fp), that build is the one recorded,
# 99 samples a second with call chains, and perf5.script.xz holds every sample's thread and stack
# (`perf script -F tid,ip,sym`). GPU_PERF=0 times the 5 mm edit without the profiler.
set -u
if [ $# -lt 2 ] || [ ! -f "$1" ]; then echo "usage: tools/gpu_checks.sh BUNDLE.tar.xz OUT_DIR [BASE_AMHV] (BUNDLE from tools/gpu_bundle.sh)" >&2; exit 2; fi
bundle="$1"; out="$2"; base="${3:-}"
if [ -e "$out" ] && [ -n "$(ls -A "$out")" ]; then echo "gpu_checks: $out is not empty; name a new folder" >&2; exit 2; fi
steps=" ${GPU_STEPS:-tests bench b4 b3 b3_5mm} "
tests_s="${GPU_TESTS_S:-150}"; edit10_s="${GPU_EDIT10_S:-60}"; edit5_s="${GPU_EDIT5_S:-215}"; bench_s="${GPU_BENCH_S:-60}"
g=/tmp/g
start=$(date +%s)
elapsed() { echo "[$(( $(date +%s) - start )) s] $*"; }
mkdir -p "$g" "$out" && tar -xJf "$bundle" -C "$g"
[ -n "$base" ] && cp "$base" "$g/bin/amhv_base" && chmod +x "$g/bin/amhv_base"
# The tests look for the binaries and data where the build that made them lay.
src_dir=$(cat "$g/source_dir" 2>/dev/null)
if [ -n "$src_dir" ] && [ ! -e "$src_dir" ]; then mkdir -p "$(dirname "$src_dir")" && ln -s "$PWD" "$src_dir"; fi
# The build folder the tests name (older bundles: the source's build/). Only where nothing lies
# yet: a build already there is left as it is.
build_dir=$(cat "$g/build_dir" 2>/dev/null)
[ -z "$build_dir" ] && [ -n "$src_dir" ] && build_dir="$src_dir/build"
if [ -n "$build_dir" ]; then
  mkdir -p "$build_dir/tools"
  [ -e "$build_dir/amhv" ] || ln -s "$g/bin/amhv" "$build_dir/amhv"
  [ -e "$build_dir/tools/amhv_make_paper_scene" ] || ln -s "$g/bin/amhv_make_paper_scene" "$build_dir/tools/amhv_make_paper_scene"
fi
export LD_LIBRARY_PATH="$g/lib" AMHV_THREE_DIR="$g/three" VK_LAYER_PATH="$g/layers" AMHV_DATA_DIR="$PWD/data"
for icd in /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json /usr/share/vulkan/icd.d/nvidia_icd.json /etc/vulkan/icd.d/nvidia_icd.json; do
  [ -f "$icd" ] && { export VK_DRIVER_FILES="$icd"; break; }
done
bin="$g/bin"

run_tests() {
  local i
  for i in $(seq 0 15); do
    (GTEST_TOTAL_SHARDS=16 GTEST_SHARD_INDEX=$i timeout "$tests_s" "$bin/amhv_tests" --gtest_brief=1 \
       --gtest_filter='-*PaperScene*:*Slurm*:*Shard*' > "/tmp/shard$i.log" 2>&1; echo "shard $i rc $?" >> "/tmp/shard$i.log") &
  done
  wait
  cat /tmp/shard*.log > "$out/tests.log"
  grep -h "rc " /tmp/shard*.log | tr '\n' ' '; echo
  grep -h "PASSED" /tmp/shard*.log | awk '{s += $4} END {print "passed", s}'
  grep -h "^\[  FAILED" /tmp/shard*.log | sort -u | cut -c1-110
}

want() { [[ "$steps" == *" $1 "* ]]; }

# edit BINARY SCENE_DIR LABEL LIMIT LOG [PREFIX...]: one timed `amhv edit` (under PREFIX, a
# profiler, if given), its wall time, peak and stages.
edit() {
  local binary="$1" scene="$2" label="$3" limit="$4" log="$5"
  shift 5
  rm -rf /tmp/gpu_edit_out
  "$bin/time" -f "%e %M" -o /tmp/gpu_edit_time timeout "$limit" "$@" "$bin/$binary" edit "$scene/scene.toml" --out /tmp/gpu_edit_out --no-page > "$log" 2>&1
  echo "$label: rc $? $(tail -1 /tmp/gpu_edit_time 2>/dev/null) $(python3 -c 'import json,sys; t=json.load(open(sys.argv[1]))["timings_s"]; print(" ".join(f"{k} {v:.2f}" for k,v in t.items()))' /tmp/gpu_edit_out/result.json 2>&1 | tail -1)"
}

# The profiler, where the bundle carries one and it can record here (its libraries first, ours after).
profiler=()
profiled=amhv
if [ "${GPU_PERF:-1}" != 0 ] && [ -x "$g/perf/bin/perf" ] && LD_LIBRARY_PATH="$g/perf/lib:$g/lib" "$g/perf/bin/perf" record -q -o /tmp/perf_try.data -- true 2>/dev/null; then
  profiler=(env "LD_LIBRARY_PATH=$g/perf/lib:$g/lib" "$g/perf/bin/perf" record -q -F 199 -o /tmp/perf5.data --)
  if [ -x "$g/bin/amhv_fp" ]; then
    profiled=amhv_fp
    profiler=(env "LD_LIBRARY_PATH=$g/perf/lib:$g/lib" "$g/perf/bin/perf" record -q -F 99 --call-graph fp -o /tmp/perf5.data --)
  fi
fi

# perf_report: the 5 mm edit's samples by library and symbol, and by thread.
perf_report() {
  local perf=(env "LD_LIBRARY_PATH=$g/perf/lib:$g/lib" "$g/perf/bin/perf" report -i /tmp/perf5.data --stdio --no-children -g none)
  { "${perf[@]}" --sort dso 2>/dev/null | grep -v '^#' | grep -v '^$' | head -15
    "${perf[@]}" --sort dso,sym 2>/dev/null | grep -v '^#' | grep -v '^$' | head -80 | cut -c1-170
    "${perf[@]}" --sort pid 2>/dev/null | grep -v '^#' | grep -v '^$' | head -40; } > "$out/perf5.txt"
  if [ "$profiled" = amhv_fp ]; then
    env "LD_LIBRARY_PATH=$g/perf/lib:$g/lib" "$g/perf/bin/perf" script -i /tmp/perf5.data -F tid,ip,sym 2>/dev/null | xz -T0 > "$out/perf5.script.xz"
  fi
}

{
  elapsed "devices"; "$bin/amhv" devices 2>&1
  if want tests; then elapsed "tests: 16 shards"; run_tests; fi
  if want bench; then
    elapsed "B1, B2 (Vulkan)"
    timeout "$bench_s" "$bin/amhv_bench_voxelise" --benchmark_filter=vulkan 2>&1 | grep -E "_(mean|median|stddev) " | cut -c1-100
    timeout "$bench_s" "$bin/amhv_bench_sweep" --benchmark_filter=vulkan 2>&1 | grep -E "_(mean|median|stddev) " | cut -c1-100
  fi
  elapsed "scenes"
  "$bin/amhv_make_paper_scene" /tmp/gpu_s10 > /dev/null && rm -rf /tmp/gpu_s05 && cp -r /tmp/gpu_s10 /tmp/gpu_s05
  sed -i "s/^voxel = .*/voxel = 0.005/; s/^angle_step_deg = .*/angle_step_deg = 1.0/" /tmp/gpu_s05/scene.toml
  if want b4; then
    elapsed "B4, key segment 1"
    "$bin/amhv_bench_growth" --header
    for sampling in "0.01 2" "0.01 1" "0.005 2" "0.005 1"; do
      # shellcheck disable=SC2086
      timeout "$bench_s" "$bin/amhv_bench_growth" /tmp/gpu_s10/scene.toml 1 $sampling | tail -1
    done
  fi
  if want b3; then
    elapsed "B3, 10 mm / 2 deg"
    for run in 1 2; do
      [ -n "$base" ] && edit amhv_base /tmp/gpu_s10 "10 mm, base, run $run" "$edit10_s" /dev/null
      edit amhv /tmp/gpu_s10 "10 mm, run $run" "$edit10_s" /dev/null
    done
    cp /tmp/gpu_edit_out/result.json "$out/result_10mm.json" 2>/dev/null
  fi
  if want b3_5mm; then
    elapsed "B3, 5 mm / 1 deg${profiler:+ (under perf)}"
    edit "$profiled" /tmp/gpu_s05 "5 mm ($profiled)" "$edit5_s" "$out/edit5.log" "${profiler[@]}"
    cp /tmp/gpu_edit_out/result.json "$out/result_5mm.json" 2>/dev/null
    [ ${#profiler[@]} -gt 0 ] && perf_report
  fi
  elapsed "done"
} > "$out/log.txt" 2>&1
