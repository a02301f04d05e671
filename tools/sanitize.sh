#!/usr/bin/env bash
# The sanitizer job: builds amhv and its tests with AddressSanitizer and UndefinedBehaviorSanitizer
# into BUILD_DIR (default build-asan, beside the source), then runs the tests that exercise the
# host code on hostile and real inputs, with leak detection on (tools/lsan.supp names the leaks of
# libraries we do not own) and any report fatal.
#
#   tools/sanitize.sh [BUILD_DIR] [GTEST_FILTER]          build, then run every selected test
#   tools/sanitize.sh --build BUILD_DIR                   only build (ctest: sanitizers.build)
#   tools/sanitize.sh --run BUILD_DIR FILTER K N          only run shard K of N of the selected
#                                                         tests (ctest: sanitizers.shard_K, which
#                                                         start once the build is done and a core
#                                                         is free)
set -euo pipefail
source_dir="$(cd "$(dirname "$0")/.." && pwd)"
mode=all
case "${1:-}" in --build) mode=build; shift ;; --run) mode=run; shift ;; esac
build="${1:-$source_dir/build-asan}"
filter="${2:-*}"
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"

# A unity build: on two cores the instrumented build is the longest step of the suite, and most
# of it is parsing the same headers again per file (the main job builds file by file, so a missing
# include still shows there).
if [ "$mode" != run ]; then
  cmake -S "$source_dir" -B "$build" -DCMAKE_UNITY_BUILD=ON -DCMAKE_BUILD_TYPE=Sanitize -DCMAKE_CXX_FLAGS_SANITIZE="-O1 -g1" -DAMHV_WERROR=OFF -DAMHV_BUILD_BENCHMARKS=OFF \
    -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" > "$build.configure.log" 2>&1 || { cat "$build.configure.log"; exit 1; }
  cmake --build "$build" -j"$(nproc)" --target amhv amhv_tests > "$build.build.log" 2>&1 || { tail -50 "$build.build.log"; exit 1; }
  [ "$mode" = build ] && { echo "sanitizers: built"; exit 0; }
fi
if [ "$mode" = run ]; then
  export GTEST_SHARD_INDEX=$(($3 - 1)) GTEST_TOTAL_SHARDS="$4"
fi
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:halt_on_error=1:exitcode=23"
export LSAN_OPTIONS="suppressions=$source_dir/tools/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Without the validation layers: the loader unloads them at exit, and their own leaks then come
# from an unknown module no suppression can name. The main job runs every test with them.
export AMHV_VALIDATION=0
"$build/tests/amhv_tests" --gtest_filter="$filter" --gtest_brief=1
echo "sanitizers: no report"
