#!/usr/bin/env bash
# The README's test command: install what is missing, build with warnings as errors, check
# formatting, run every test of the Release tree; then the sanitizer and fuzz tree over the code
# that reads untrusted bytes (scripts/sanitize.sh, scope `input`). `.ci/run` adds the whole suite
# sanitized (scope `all`).
#   SCANBENCH_SANITIZE=0       skips the sanitizer tree
#   SCANBENCH_SAN_SCOPE=all    the whole suite sanitized here too (what .ci/run adds)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
t0=$SECONDS
bash "$here/scripts/setup.sh"
bash "$here/scripts/format.sh" --check
bash "$here/scripts/build.sh" -DSCANBENCH_WERROR=ON
build="${SCANBENCH_BUILD_DIR:-$here/build}"
(cd "$build" && ctest --output-on-failure -j"$(nproc)" --timeout 900)
echo "build-cost: Release tree built and tested: $((SECONDS - t0)) s since the start"
if [ "${SCANBENCH_SANITIZE:-1}" != 0 ]; then
  bash "$here/scripts/sanitize.sh"
fi
echo "build-cost: test command: $((SECONDS - t0)) s wall"
