#!/usr/bin/env bash
# Install what is missing, build with warnings as errors, check formatting, run every test.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/setup.sh"
bash "$here/scripts/format.sh" --check
bash "$here/scripts/build.sh" -DSCANBENCH_WERROR=ON
cd "${SCANBENCH_BUILD_DIR:-$here/build}"
ctest --output-on-failure -j"$(nproc)" --timeout 900
