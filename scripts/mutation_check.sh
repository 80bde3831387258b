#!/usr/bin/env bash
# Mutation check of the oracle tests (docs/hardening.md, "Mutation check"): each patch in
# scripts/mutations/ is a deliberate, plausible bug in an algorithm; its oracle test(s) must FAIL
# on the broken code. Not part of ctest or .ci/run (it rebuilds per mutation): a reviewer's tool.
#
#   bash scripts/mutation_check.sh            every mutation
#   bash scripts/mutation_check.sh NAME ...   only these (patch names without .patch)
#   bash scripts/mutation_check.sh --list     the mutations, their tests and what each breaks
#
# How: the tracked and untracked (not ignored) files of this checkout, uncommitted edits
# included, are copied to a scratch tree, $SCANBENCH_MUTATION_DIR (default build-mutation/), and
# built there (scripts/build.sh, Release, -DSCANBENCH_WERROR=ON as the test command builds, so
# ccache shares the objects; the algorithms library is compiled one file per translation unit
# and without -Werror, so a mutation recompiles one file and an unused variable it leaves does
# not stop it). Then:
#   1. baseline: every named test must PASS on the unmutated copy;
#   2. per mutation: apply the patch (patch --fuzz=0: line offsets are fine, changed context is
#      reported as "does not apply"), build its target, run each named test alone
#      (--gtest_filter), expect FAILURE, restore the file.
# Prints a table (mutation, test, expected, result) and exits non-zero if a mutation survives
# (its test passes on the broken code), a baseline test fails, or a patch does not apply or build.
#
# A patch file is a unified diff (a/ b/ paths from the repository root) after three header lines:
#   # breaks: <one line: the bug it introduces>
#   # target: <the test executable, a CMake target in tests/CMakeLists.txt>
#   # tests: <Suite.Name ...: the oracle tests that must fail>
#   SCANBENCH_MUTATION_TIMEOUT  seconds per test run (default 900); a timeout counts as killed
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mdir="$repo/scripts/mutations"
work="${SCANBENCH_MUTATION_DIR:-$repo/build-mutation}"
scratch="$work/src"
build="$scratch/build"  # the same layout as the checkout's build/, so ccache's relative paths match
logs="$work/logs"
timeout_s="${SCANBENCH_MUTATION_TIMEOUT:-900}"

header() {  # header FILE KEY: the value of "# KEY: value"
  sed -n "s/^# $2: //p" "$1" | head -1
}
patched_files() {  # the repository paths a patch changes
  sed -n 's|^+++ b/\([^[:space:]]*\).*|\1|p' "$1"
}

names=()
list=0
for a in "$@"; do
  case "$a" in
    --list) list=1 ;;
    -h | --help)
      sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'
      exit 0
      ;;
    *) names+=("$a") ;;
  esac
done
if ((${#names[@]} == 0)); then
  for f in "$mdir"/*.patch; do names+=("$(basename "$f" .patch)"); done
fi
for n in "${names[@]}"; do
  f="$mdir/$n.patch"
  [[ -f $f ]] || {
    echo "mutation_check: $f: no such mutation (--list shows them)" >&2
    exit 2
  }
  for key in breaks target tests; do
    [[ -n $(header "$f" "$key") ]] || {
      echo "mutation_check: $f: header line '# $key: ...' missing" >&2
      exit 2
    }
  done
done
if ((list)); then
  for n in "${names[@]}"; do
    f="$mdir/$n.patch"
    printf '%s (%s: %s)\n    %s\n' "$n" "$(header "$f" target)" "$(header "$f" tests)" \
      "$(header "$f" breaks)"
  done
  exit 0
fi

# --- the scratch copy: this checkout's files with their modification times (so an unchanged
# file is not recompiled on a second run); the build tree inside it survives between runs.
mkdir -p "$scratch" "$logs"
find "$scratch" -mindepth 1 -maxdepth 1 ! -name build -exec rm -rf {} +
(cd "$repo" && git ls-files -z -co --exclude-standard |
  while IFS= read -r -d '' f; do [[ -e $f ]] && printf '%s\0' "$f"; done |
  tar --null -T - -cf -) | tar -xpf - -C "$scratch"

# The algorithms library one file per translation unit (a mutation recompiles one file), with the
# precompiled headers of a per-file build (SCANBENCH_UNITY=0; the call is copied from
# algorithms/CMakeLists.txt) and without -Werror (a mutation may leave a variable unused): in the
# scratch build only, through a file CMake includes after project(scanbench).
pch=$(grep -o 'scanbench_precompile(scanbench_algorithms[^)]*)' "$scratch/algorithms/CMakeLists.txt" || true)
cat >"$work/per_file.cmake" <<EOF
# Written by scripts/mutation_check.sh for its scratch build.
function(scanbench_mutation_setup)
  set_target_properties(scanbench_algorithms PROPERTIES UNITY_BUILD OFF)
  set_property(TARGET scanbench_algorithms APPEND PROPERTY COMPILE_OPTIONS -Wno-error)
  set(CMAKE_UNITY_BUILD OFF)
  $pch
endfunction()
cmake_language(DEFER CALL scanbench_mutation_setup)
EOF

targets=()
tests_all=()
for n in "${names[@]}"; do
  f="$mdir/$n.patch"
  t=$(header "$f" target)
  [[ " ${targets[*]} " == *" $t "* ]] || targets+=("$t")
  for x in $(header "$f" tests); do
    [[ " ${tests_all[*]} " == *" $t:$x "* ]] || tests_all+=("$t:$x")
  done
done

rows=()  # "mutation|test|expected|result"
bad=0

# run_test TARGET TEST LOG: prints passed | failed | timeout | crashed (signal N) | not found
run_test() {
  local exe="$build/tests/$1" rc=0
  timeout "$timeout_s" "$exe" --gtest_filter="$2" --gtest_color=no >"$3" 2>&1 || rc=$?
  if ((rc == 124)); then
    echo "timeout"
  elif ((rc > 128)); then
    echo "crashed (signal $((rc - 128)))"
  elif ! grep -q "^\[==========\] 1 test from .* ran" "$3"; then
    echo "not found"
  elif ((rc == 0)); then
    echo "passed"
  else
    echo "failed"
  fi
}

# build TARGET... LOG: 0 when the targets built
build_targets() {
  local log=${*: -1} args=()
  for t in "${@:1:$#-1}"; do args+=(--target "$t"); done
  # shellcheck disable=SC2034,SC1091  # `here` is read by ccache-env.sh
  (here=$scratch && source "$scratch/scripts/ccache-env.sh" &&
    cmake --build "$build" -j"$(nproc)" "${args[@]}") >>"$log" 2>&1
}

# --- baseline: configure, rebuild every file a patch touches (a run that stopped mid-mutation
# may have left a mutated object newer than the restored source), every test must pass.
echo "mutation_check: scratch tree $scratch (from $repo)"
start=$SECONDS
for n in "${names[@]}"; do
  while read -r p; do touch "$scratch/$p"; done < <(patched_files "$mdir/$n.patch")
done
: >"$logs/baseline.build.log"
if ! SCANBENCH_BUILD_DIR="$build" SCANBENCH_TARGETS="${targets[*]}" bash "$scratch/scripts/build.sh" \
  -DSCANBENCH_WERROR=ON -DCMAKE_PROJECT_scanbench_INCLUDE="$work/per_file.cmake" \
  >>"$logs/baseline.build.log" 2>&1; then
  tail -30 "$logs/baseline.build.log"
  echo "mutation_check: the unmutated copy does not build (log: $logs/baseline.build.log)" >&2
  exit 1
fi
grep '^build-cost:' "$logs/baseline.build.log" || true
for tt in "${tests_all[@]}"; do
  r=$(run_test "${tt%%:*}" "${tt#*:}" "$logs/baseline.${tt#*:}.log")
  [[ $r == passed ]] || bad=1
  rows+=("(none)|${tt#*:}|pass|$r")
done
if ((bad)); then
  echo "mutation_check: a test fails on the unmutated copy; no mutation is meaningful" >&2
fi

# --- the mutations
for n in "${names[@]}"; do
  ((bad)) && break
  f="$mdir/$n.patch"
  t=$(header "$f" target)
  log="$logs/$n.log"
  : >"$log"
  mapfile -t files < <(patched_files "$f")
  if ! patch -d "$scratch" -p1 --fuzz=0 --no-backup-if-mismatch -s <"$f" >>"$log" 2>&1; then
    rows+=("$n|-|fail|does not apply")
    bad=1
  elif ! build_targets "$t" "$log"; then
    rows+=("$n|-|fail|does not build")
    bad=1
  else
    for x in $(header "$f" tests); do
      r=$(run_test "$t" "$x" "$logs/$n.$x.log")
      case "$r" in
        failed) r="killed" ;;
        timeout | crashed*) r="killed ($r)" ;;
        passed)
          r="SURVIVED"
          bad=1
          ;;
        *) bad=1 ;;
      esac
      rows+=("$n|$x|fail|$r")
    done
  fi
  # Restore the unmutated files; a fresh modification time makes the next build recompile them.
  for p in "${files[@]}"; do cp "$repo/$p" "$scratch/$p"; done
  echo "mutation_check: $n done ($((SECONDS - start)) s)"
done

echo
echo "| mutation | test | expected | result |"
echo "|---|---|---|---|"
for r in "${rows[@]}"; do
  IFS='|' read -r a b c d <<<"$r"
  echo "| $a | $b | $c | $d |"
done
echo
for n in "${names[@]}"; do echo "- $n: $(header "$mdir/$n.patch" breaks)"; done
echo
echo "mutation_check: $(date -u '+%Y-%m-%d %H:%M UTC'), $(nproc) cores, $((SECONDS - start)) s;" \
  "logs in $logs"
if ((bad)); then
  echo "mutation_check: FAILED (a mutation survived, a baseline test failed, or a patch did" \
    "not apply or build)" >&2
  exit 1
fi
echo "mutation_check: every mutation was killed"
