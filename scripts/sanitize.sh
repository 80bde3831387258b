#!/usr/bin/env bash
# The sanitizer and fuzz tree (docs: hardening), built by clang at -O1 with AddressSanitizer,
# UndefinedBehaviorSanitizer and libFuzzer coverage, as a unity build with precompiled headers
# (cmake/BuildCost.cmake), into build-san/:
#   SCANBENCH_SAN_SCOPE=input  (default; scripts/test.sh) the code that reads untrusted bytes:
#                              core's readers and stage files with the malformed and bad-input
#                              corpora, and a short run of the reader fuzz targets
#   SCANBENCH_SAN_SCOPE=all    (.ci/run) every library, test and fuzz target and the scanbench
#                              binary the end-to-end, corpus and Slurm tests run: the whole test
#                              suite again, sanitized. Reuses the objects an `input` build of the
#                              same tree made (same flags for core/ and tests/).
#   SCANBENCH_FUZZ_CONFIG=1    with `input`, also builds and fuzzes the config loader and the
#                              record readers (fuzz_experiment, fuzz_records: they need the harness)
#   SCANBENCH_FUZZ_SECONDS=N   each fuzz target's time (default 20)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
source "$here/scripts/ccache-env.sh"
san="${SCANBENCH_SAN_BUILD_DIR:-$here/build-san}"
scope="${SCANBENCH_SAN_SCOPE:-input}"
cmake -S "$here" -B "$san" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Sanitize \
  -DSCANBENCH_FUZZ=ON -DSCANBENCH_SANITIZE_SCOPE="$scope" -DSCANBENCH_WERROR=ON \
  -DSCANBENCH_BUILD_BENCH=OFF -DCMAKE_UNITY_BUILD=ON \
  -DSCANBENCH_FUZZ_SECONDS="${SCANBENCH_FUZZ_SECONDS:-20}" >/dev/null
# Third-party runtimes' exit-time allocations (tests/lsan.supp says which and why).
export LSAN_OPTIONS="suppressions=$here/tests/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
ccache_zero
start=$SECONDS
if [ "$scope" = all ]; then
  cmake --build "$san" -j"$(nproc)"
  ccache_report "sanitizer tree ($scope)" $((SECONDS - start))
  (cd "$san" && ctest --output-on-failure -j"$(nproc)" --timeout 1800)
else
  targets=(test_core test_core_io fuzz_readers fuzz_stage_file)
  skip='_NOT_BUILT$|FuzzSmoke.fuzz_experiment|FuzzSmoke.fuzz_records'
  if [ "${SCANBENCH_FUZZ_CONFIG:-0}" = 1 ]; then
    targets+=(fuzz_experiment fuzz_records)
    skip='_NOT_BUILT$'
  fi
  cmake --build "$san" -j"$(nproc)" --target "${targets[@]}"
  ccache_report "sanitizer tree ($scope)" $((SECONDS - start))
  # Only the executables built above have tests here (the others register *_NOT_BUILT).
  (cd "$san" && ctest --output-on-failure -j"$(nproc)" --timeout 900 -E "$skip")
fi
