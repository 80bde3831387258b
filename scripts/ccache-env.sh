# Sourced by scripts/build.sh and scripts/test.sh: ccache settings for every scanbench build, and
# the hit/miss line printed after a build.
# ccache (when installed) keys on paths relative to the checkout, so clones in other folders share
# hits; the precompiled headers (cmake/BuildCost.cmake) need the pch_defines and time_macros
# sloppiness to be cached at all (ccache manual, "Precompiled headers"), and clang's PCH is
# written without a timestamp (-fno-pch-timestamp in cmake/BuildCost.cmake).
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$here}"
export CCACHE_SLOPPINESS="${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}"
# A cold build of both trees fills about 3 GB; ccache's default of 5 GB would evict the Release
# tree while the sanitizer tree builds.
export CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-12G}"

ccache_zero() {
  if command -v ccache >/dev/null && [ "${CCACHE_DISABLE:-}" = "" ]; then ccache --zero-stats >/dev/null; fi
}

# ccache_report LABEL SECONDS: one line with the wall time and ccache's hits and misses since
# ccache_zero (ccache --print-stats counters).
ccache_report() {
  local label=$1 secs=$2
  if ! command -v ccache >/dev/null || [ "${CCACHE_DISABLE:-}" != "" ]; then
    echo "build-cost: $label: ${secs} s wall, ccache off"
    return
  fi
  ccache --print-stats | awk -v label="$label" -v secs="$secs" '
    $1 == "direct_cache_hit" || $1 == "preprocessed_cache_hit" { hits += $2 }
    $1 == "cache_miss" { misses += $2 }
    $1 == "could_not_use_precompiled_header" { nopch += $2 }
    END {
      printf "build-cost: %s: %d s wall, ccache %d hits, %d misses", label, secs, hits, misses
      if (nopch) printf ", %d uncacheable (precompiled header)", nopch
      printf "\n"
    }'
}
