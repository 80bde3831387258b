#!/usr/bin/env bash
# Configure and build scanbench (Release) into build/. Extra arguments go to cmake's configure.
#   SCANBENCH_TARGETS="a b"  build only these targets (scripts/main.sh: scanbench); default all
#   SCANBENCH_UNITY=0        one translation unit per source file (default 1: unity batches, see
#                            cmake/BuildCost.cmake), for a developer's incremental rebuilds
# Prints ccache's hits and misses of this build at the end, so a slow build says why.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SCANBENCH_BUILD_DIR:-$here/build}"
source "$here/scripts/ccache-env.sh"
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_UNITY_BUILD="$([ "${SCANBENCH_UNITY:-1}" = 0 ] && echo OFF || echo ON)" "$@" >/dev/null
targets=()
for t in ${SCANBENCH_TARGETS:-}; do targets+=(--target "$t"); done
ccache_zero
start=$SECONDS
cmake --build "$build" -j"$(nproc)" "${targets[@]}"
ccache_report "build ($build${SCANBENCH_TARGETS:+, ${SCANBENCH_TARGETS}})" $((SECONDS - start))
