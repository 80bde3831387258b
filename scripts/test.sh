#!/usr/bin/env bash
# Install what is missing, build with warnings as errors, check formatting, run every test; then
# the sanitizer and fuzz tree (README "Hardening"): clang at -O1 with AddressSanitizer,
# UndefinedBehaviorSanitizer and libFuzzer coverage, on the code that reads untrusted bytes (core's
# readers and the experiment-config loader): core's tests, the bad-input corpus and a short fuzz
# run of every libFuzzer target. SCANBENCH_SANITIZE=0 skips that tree; SCANBENCH_FUZZ_SECONDS
# (default 20) is each target's fuzz time.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/setup.sh"
bash "$here/scripts/format.sh" --check
bash "$here/scripts/build.sh" -DSCANBENCH_WERROR=ON
build="${SCANBENCH_BUILD_DIR:-$here/build}"
(cd "$build" && ctest --output-on-failure -j"$(nproc)" --timeout 900)

if [ "${SCANBENCH_SANITIZE:-1}" != 0 ]; then
  san="${SCANBENCH_SAN_BUILD_DIR:-$here/build-san}"
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}"
  cmake -S "$here" -B "$san" -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Sanitize \
    -DSCANBENCH_FUZZ=ON -DSCANBENCH_SANITIZE_SCOPE=input -DSCANBENCH_WERROR=ON \
    -DSCANBENCH_BUILD_BENCH=OFF \
    -DSCANBENCH_FUZZ_SECONDS="${SCANBENCH_FUZZ_SECONDS:-20}" >/dev/null
  cmake --build "$san" -j"$(nproc)" --target test_core test_core_io fuzz_readers \
    fuzz_stage_file fuzz_experiment
  # Only the executables built above have tests here (the others register *_NOT_BUILT).
  (cd "$san" && ctest --output-on-failure -j"$(nproc)" --timeout 900 -E '_NOT_BUILT$')
fi
