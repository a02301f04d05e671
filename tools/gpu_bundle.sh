#!/usr/bin/env bash
# Bundles a build's binaries with their shared libraries (and the Vulkan loader, the glvnd
# libraries NVIDIA's Vulkan driver needs, the validation layer and three.js's page files) into one
# tarball, to run the tests and benchmarks on a GPU machine that has a driver but none of
# Debian's packages (how docs/benchmarks.md's H100 figures were taken).
#
#   tools/gpu_bundle.sh BUILD_DIR OUT.tar.xz [PROFILING_AMHV]
#
# PROFILING_AMHV: an `amhv` built with frame pointers (CMAKE_CXX_FLAGS="-fno-omit-frame-pointer
# -mno-omit-leaf-frame-pointer"), carried as bin/amhv_fp; tools/gpu_checks.sh then profiles the
# 5 mm edit with it, call chains and all.
#
# On the GPU machine, from a checkout of the same commit:
#   mkdir -p /tmp/g && tar -xJf OUT.tar.xz -C /tmp/g
#   export LD_LIBRARY_PATH=/tmp/g/lib AMHV_THREE_DIR=/tmp/g/three VK_LAYER_PATH=/tmp/g/layers
#   export VK_DRIVER_FILES=/usr/share/vulkan/icd.d/nvidia_icd.json   # wherever the driver's ICD file is
#   /tmp/g/bin/amhv devices
# or let tools/gpu_checks.sh unpack it and run the prepared device checks.
set -euo pipefail
build="$1"; out="$2"; profiling="${3:-}"
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/bin" "$stage/lib" "$stage/layers"
bins=("$build/amhv" "$build/tools/amhv_bench_voxelise" "$build/tools/amhv_bench_sweep" "$build/tools/amhv_bench_growth"
      "$build/tools/amhv_make_paper_scene" "$build/tests/amhv_tests")
cp "${bins[@]}" "$stage/bin/"
[ -n "$profiling" ] && cp "$profiling" "$stage/bin/amhv_fp"
cp /usr/bin/time "$stage/bin/time"  # GNU time (wall and peak memory); the GPU machine's image has none
# Where the build's source lay: the tests look for the binaries and data there.
sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt" > "$stage/source_dir"
# And where the build lay: the tests run the `amhv` and the scene generator they were built beside.
realpath "$build" > "$stage/build_dir"
for b in "${bins[@]}"; do ldd "$b" | awk '$3 ~ /^\// {print $3}'; done | sort -u |
  grep -v -E '/(libc|libm|libpthread|libdl|librt|ld-linux-x86-64)\.so' | while read -r lib; do cp -L "$lib" "$stage/lib/"; done
lib=/usr/lib/x86_64-linux-gnu
cp -L "$lib/libvulkan.so.1" "$lib/libGLdispatch.so.0" "$lib/libGLX.so.0" "$lib/libEGL.so.1" "$stage/lib/"
cp "$lib/libVkLayer_khronos_validation.so" "$stage/layers/"
sed 's#"library_path": *"[^"]*"#"library_path": "/tmp/g/layers/libVkLayer_khronos_validation.so"#' \
  /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json > "$stage/layers/VkLayer_khronos_validation.json"
# perf and its libraries, apart from the others (tools/gpu_checks.sh profiles the 5 mm edit with it):
# the GPU machine's image has no profiler.
if [ -x /usr/bin/perf ]; then
  mkdir -p "$stage/perf/bin" "$stage/perf/lib"
  cp /usr/bin/perf "$stage/perf/bin/"
  ldd /usr/bin/perf | awk '$3 ~ /^\// {print $3}' | grep -v -E '/(libc|libm|libpthread|libdl|librt|ld-linux-x86-64)\.so' |
    while read -r lib; do cp -L "$lib" "$stage/perf/lib/"; done
fi
three=tools/npm/node_modules/three
mkdir -p "$stage/three/build" "$stage/three/examples/js/loaders" "$stage/three/examples/js/controls"
cp "$three/build/three.min.js" "$stage/three/build/"
cp "$three/examples/js/loaders/GLTFLoader.js" "$stage/three/examples/js/loaders/"
cp "$three/examples/js/controls/OrbitControls.js" "$stage/three/examples/js/controls/"
tar -C "$stage" -cJf "$out" .
echo "wrote $out ($(du -h "$out" | cut -f1))"
