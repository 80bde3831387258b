#!/usr/bin/env bash
# Install what is missing, build with warnings as errors, check formatting, run every test; then
# the sanitizer and fuzz tree (README "Hardening"), built by clang at -O1 with AddressSanitizer,
# UndefinedBehaviorSanitizer and libFuzzer coverage, as a unity build (CMAKE_UNITY_BUILD: each
# target's sources compiled in batches of 8, which parses the Eigen, CGAL and OpenVDB headers once
# per batch instead of once per file):
#   SCANBENCH_SAN_SCOPE=all    (default) every library, test and the scanbench binary the
#                              end-to-end, corpus and Slurm tests run: the whole test suite again,
#                              sanitized, and a short run of every fuzz target
#   SCANBENCH_SAN_SCOPE=input  only the code that reads untrusted bytes (core/, harness/, tests/):
#                              core's tests with the malformed and bad-input corpora and a short
#                              run of the reader fuzz targets (a quicker check while developing)
#   SCANBENCH_FUZZ_CONFIG=1    with `input`, also builds and fuzzes the config loader
#   SCANBENCH_SANITIZE=0       skips the sanitizer tree
#   SCANBENCH_FUZZ_SECONDS=N   each fuzz target's time (default 20)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/setup.sh"
bash "$here/scripts/format.sh" --check
bash "$here/scripts/build.sh" -DSCANBENCH_WERROR=ON
build="${SCANBENCH_BUILD_DIR:-$here/build}"
(cd "$build" && ctest --output-on-failure -j"$(nproc)" --timeout 900)

if [ "${SCANBENCH_SANITIZE:-1}" != 0 ]; then
  san="${SCANBENCH_SAN_BUILD_DIR:-$here/build-san}"
  scope="${SCANBENCH_SAN_SCOPE:-all}"
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}"
  cmake -S "$here" -B "$san" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Sanitize \
    -DSCANBENCH_FUZZ=ON -DSCANBENCH_SANITIZE_SCOPE="$scope" -DSCANBENCH_WERROR=ON \
    -DSCANBENCH_BUILD_BENCH=OFF -DCMAKE_UNITY_BUILD=ON \
    -DSCANBENCH_FUZZ_SECONDS="${SCANBENCH_FUZZ_SECONDS:-20}" >/dev/null
  if [ "$scope" = all ]; then
    cmake --build "$san" -j"$(nproc)"
    (cd "$san" && ctest --output-on-failure -j"$(nproc)" --timeout 1800)
  else
    targets=(test_core test_core_io fuzz_readers fuzz_stage_file)
    skip='_NOT_BUILT$|FuzzSmoke.fuzz_experiment'
    if [ "${SCANBENCH_FUZZ_CONFIG:-0}" = 1 ]; then
      targets+=(fuzz_experiment)
      skip='_NOT_BUILT$'
    fi
    cmake --build "$san" -j"$(nproc)" --target "${targets[@]}"
    # Only the executables built above have tests here (the others register *_NOT_BUILT).
    (cd "$san" && ctest --output-on-failure -j"$(nproc)" --timeout 900 -E "$skip")
  fi
fi
