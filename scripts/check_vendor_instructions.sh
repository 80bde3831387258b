#!/usr/bin/env bash
# Fails when a library holds an instruction whose result the processor's vendor chooses: the
# approximate reciprocal and reciprocal square root (rcpps, rsqrtps and their 14-bit AVX-512
# forms). A build that used them would give other bits on Intel and AMD processors
# (docs/performance.md, "SIMD width and allocator policy"). Usage: LIBRARY...
set -euo pipefail
status=0
for lib in "$@"; do
  [[ -f "$lib" ]] || { echo "check_vendor_instructions: $lib: no such file" >&2; exit 2; }
  hits=$(objdump -d --no-show-raw-insn -C "$lib" |
    awk '/^[0-9a-f]+ <.*>:$/ { fn = $0 }
         /[ \t]v?(rcp|rsqrt)(14|28)?(ps|ss|pd|sd)[ \t]/ { n++; if (!first) first = fn }
         END { if (n) printf "%d in %s", n, first }')
  if [[ -n "$hits" ]]; then
    echo "$lib: vendor-specific approximation instructions: $hits" >&2
    status=1
  fi
done
exit "$status"
