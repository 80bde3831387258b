#!/usr/bin/env bash
# Install what is missing, build with warnings as errors, check formatting, run every test; then
# the sanitizer and fuzz tree (README "Hardening"): the whole test suite again, built by clang at
# -O1 with AddressSanitizer, UndefinedBehaviorSanitizer and libFuzzer coverage on every library,
# test and the scanbench binary the end-to-end tests run, plus a short run of each fuzz target.
#   SCANBENCH_SANITIZE=0       skips the sanitizer tree
#   SCANBENCH_SAN_SCOPE=input  sanitizes only the code that reads untrusted bytes (core/, harness/,
#                              tests/) and runs only core's tests and the reader fuzz targets there:
#                              a quicker local check, not what CI runs
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
    -DSCANBENCH_BUILD_BENCH=OFF \
    -DSCANBENCH_FUZZ_SECONDS="${SCANBENCH_FUZZ_SECONDS:-20}" >/dev/null
  if [ "$scope" = all ]; then
    cmake --build "$san" -j"$(nproc)"
    (cd "$san" && ctest --output-on-failure -j"$(nproc)" --timeout 1800)
  else
    cmake --build "$san" -j"$(nproc)" --target test_core test_core_io fuzz_readers fuzz_stage_file
    # Only the executables built above have tests here (the others register *_NOT_BUILT).
    (cd "$san" && ctest --output-on-failure -j"$(nproc)" --timeout 900 \
      -E '_NOT_BUILT$|FuzzSmoke.fuzz_experiment')
  fi
fi
