#!/usr/bin/env bash
# The sanitizer job: builds amhv, its tests and the fuzz targets (tests/fuzz/) with clang,
# AddressSanitizer and UndefinedBehaviorSanitizer (leak detection on) and libFuzzer's coverage into
# BUILD_DIR (default build-asan, beside the source), then runs the tests that exercise the host code
# on hostile and real inputs, or a fuzz target for a while, any report fatal.
#
#   tools/sanitize.sh [BUILD_DIR] [GTEST_FILTER]          build, then run every selected test
#   tools/sanitize.sh --build BUILD_DIR                   only build (ctest: sanitizers.build)
#   tools/sanitize.sh --run BUILD_DIR FILTER K N          only run shard K of N of the selected
#                                                         tests (ctest: sanitizers.shard_K, which
#                                                         start once the build is done and a core
#                                                         is free)
#   tools/sanitize.sh --fuzz BUILD_DIR TARGET SECONDS     run one fuzz target from its seed corpus
#                                                         (tests/fuzz/corpus/TARGET) for SECONDS
#                                                         (ctest: sanitizers.fuzz_TARGET)
set -euo pipefail
source_dir="$(cd "$(dirname "$0")/.." && pwd)"
mode=all
case "${1:-}" in --build) mode=build; shift ;; --run) mode=run; shift ;; --fuzz) mode=fuzz; shift ;; esac
build="${1:-$source_dir/build-asan}"
filter="${2:-*}"
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -fsanitize=fuzzer-no-link -fsanitize-ignorelist=$source_dir/tools/sanitize.ignore"

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:halt_on_error=1:exitcode=23"
export LSAN_OPTIONS="suppressions=$source_dir/tools/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

# A unity build: on two cores the instrumented build is the longest step of the suite, and most
# of it is parsing the same headers again per file.
if [ "$mode" = build ] || [ "$mode" = all ]; then
  CC=clang CXX=clang++ cmake -S "$source_dir" -B "$build" -DCMAKE_BUILD_TYPE=Sanitize -DCMAKE_CXX_FLAGS_SANITIZE="-O1 -g1" -DAMHV_WERROR=OFF \
    -DAMHV_BUILD_BENCHMARKS=OFF -DAMHV_SANITIZER_TEST=OFF -DAMHV_FUZZ=ON \
    -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" > "$build.configure.log" 2>&1 ||
    { cat "$build.configure.log"; exit 1; }
  cmake --build "$build" -j"$(nproc)" --target amhv amhv_tests amhv_fuzzers > "$build.build.log" 2>&1 || { tail -50 "$build.build.log"; exit 1; }
  [ "$mode" = build ] && { echo "sanitizers: built"; exit 0; }
fi
if [ "$mode" = fuzz ]; then
  target="$2" seconds="$3"
  work="$(mktemp -d)"
  trap 'rm -rf "$work"' EXIT
  # New inputs go to the first folder (a scratch one); the committed seeds are only read. A finding
  # (crash, leak, timeout, out-of-memory) is kept in BUILD_DIR/fuzz-findings/TARGET/.
  set +e
  "$build/tests/fuzz/fuzz_$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="$work/" "$work" "$source_dir/tests/fuzz/corpus/$target" > "$work/log" 2>&1
  status=$?
  set -e
  if [ "$status" -ne 0 ]; then
    grep -E "ERROR|SUMMARY|ALARM|#[0-9]+ .* in amhv" "$work/log" | head -30
    tail -8 "$work/log"
    mkdir -p "$build/fuzz-findings/$target"
    for artifact in "$work"/crash-* "$work"/leak-* "$work"/timeout-* "$work"/oom-*; do
      [ -f "$artifact" ] || continue
      cp "$artifact" "$build/fuzz-findings/$target/"
      echo "sanitizers: finding kept as $build/fuzz-findings/$target/$(basename "$artifact"):"
      head -c 400 "$artifact" | od -c | head -20
    done
    exit "$status"
  fi
  tail -8 "$work/log"
  echo "sanitizers: fuzz_$target ran ${seconds} s with no finding"
  exit 0
fi
if [ "$mode" = run ]; then
  export GTEST_SHARD_INDEX=$(($3 - 1)) GTEST_TOTAL_SHARDS="$4"
fi
# Without the validation layers: the loader unloads them at exit, and their own leaks then come
# from an unknown module no suppression can name. The main job runs every test with them.
export AMHV_VALIDATION=0
"$build/tests/amhv_tests" --gtest_filter="$filter" --gtest_brief=1
echo "sanitizers: no report"
