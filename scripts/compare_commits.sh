#!/usr/bin/env bash
# Accuracy of two commits side by side: builds each commit's scanbench in a detached worktree
# OUTSIDE this checkout, runs CONFIG (a path inside the repository, read from EACH commit's own tree,
# with "repeats": 1, since timing is not compared) and prints `scanbench compare OLD NEW --no-timing`.
#
#   bash scripts/compare_commits.sh OLD NEW CONFIG [compare options, e.g. --rel 0 --abs 0]
#   e.g. bash scripts/compare_commits.sh 5466683 main configs/nightly.json
# Environment (defaults in brackets):
#   WORKDIR   worktrees, builds and results [/tmp/scanbench-compare]: WORKDIR/<sha>/{src,results}
#   JOBS      `scanbench run --jobs` [nproc]
#   SCANBENCH_DATA  the classic meshes [this checkout's data/, filled by scripts/setup.sh]
#   LOCK      a file to flock around each build and run (shared machines) [none]
# A worktree or results folder already in WORKDIR is reused (delete it to rebuild or rerun).
# Exit code: compare's (0: no accuracy or status regression; 1: a regression; 2: bad input).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ $# -ge 3 ] || { sed -n '2,15p' "$0" >&2; exit 2; }
old=$1 new=$2 config=$3
shift 3
work="${WORKDIR:-/tmp/scanbench-compare}"
case "$work" in "$here" | "$here"/*) echo "compare_commits: WORKDIR must be outside the checkout" >&2; exit 2 ;; esac
export SCANBENCH_DATA="${SCANBENCH_DATA:-$here/data}"
locked() { if [ -n "${LOCK:-}" ]; then flock "$LOCK" "$@"; else "$@"; fi; }

# build_and_run REV: prints the results folder of REV's run of CONFIG.
build_and_run() {
  local sha src out
  sha=$(git -C "$here" rev-parse --verify "$1^{commit}")
  src="$work/$sha/src" out="$work/$sha/results"
  [ -d "$src" ] || git -C "$here" worktree add --detach "$src" "$sha" >&2
  [ -f "$src/$config" ] || { echo "compare_commits: $config not in $1 ($sha)" >&2; exit 2; }
  # Plain Release build of the one binary (no -Werror: old trees need not build warning-free
  # with today's compiler); ccache hits across worktrees through CCACHE_BASEDIR.
  CCACHE_BASEDIR="$src" locked sh -c "cmake -S '$src' -B '$src/build' -DCMAKE_BUILD_TYPE=Release \
    -DSCANBENCH_BUILD_TESTS=OFF -DSCANBENCH_BUILD_BENCH=OFF >/dev/null &&
    cmake --build '$src/build' --target scanbench -j$(nproc) >/dev/null" >&2
  python3 -c 'import json, sys; c = json.load(open(sys.argv[1])); c["repeats"] = 1
json.dump(c, open(sys.argv[2], "w"), indent=1)' "$src/$config" "$work/$sha/config.json"
  [ -f "$out/runs.jsonl" ] ||
    locked "$src/build/harness/scanbench" run "$work/$sha/config.json" -o "$out" \
      --jobs "${JOBS:-$(nproc)}" >&2
  echo "$out"
}

mkdir -p "$work"
old_out=$(build_and_run "$old")
new_out=$(build_and_run "$new")
exec "$work/$(git -C "$here" rev-parse "$new^{commit}")/src/build/harness/scanbench" \
  compare "$old_out" "$new_out" --no-timing "$@"
