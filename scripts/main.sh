#!/usr/bin/env bash
# The main job on a fresh Debian 12 machine: install what is missing, build, run the main job.
set -euo pipefail
t0=$SECONDS
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$here/scripts/setup.sh"
# Only what the main job runs: the scanbench binary and the libraries it loads (no tests, no
# Google Benchmark suites).
SCANBENCH_TARGETS=scanbench bash "$here/scripts/build.sh"
sb="${SCANBENCH_BUILD_DIR:-$here/build}/harness/scanbench"
"$sb" --version
"$sb" list
# The default experiment (configs/default.json): scans, algorithm runs, metrics, tables, report.
out="${SCANBENCH_RESULTS:-$here/results/default-$(date -u +%Y%m%d-%H%M%S)}"
"$sb" run "$here/configs/default.json" -o "$out" --jobs 1
"$sb" report "$out"
echo "build-cost: main job: $((SECONDS - t0)) s wall"
