#!/usr/bin/env bash
# Configure and build scanbench (Release) into build/. Extra arguments go to cmake's configure.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SCANBENCH_BUILD_DIR:-$here/build}"
# ccache (when installed) keys on paths relative to the checkout, so clones in other folders share hits.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}"
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$build" -j"$(nproc)"
