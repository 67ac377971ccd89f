#!/usr/bin/env bash
# Prints which Highway targets each SIMD kernel test ran, from the output ctest kept of its last
# run (BUILD_DIR/Testing/Temporary/LastTest.log), so that it reaches the CI log even when the
# tests pass (ctest shows a passing test's output only with -V).
#
# Usage: toolchain/simd-targets.sh BUILD_DIR [REQUIRED_TARGET]
#   A line counts when it names Highway/hwy or a Highway target (NEON, SVE, SVE2, SSE4, AVX2,
#   AVX3, EMU128, SCALAR, ...). With REQUIRED_TARGET (e.g. NEON for the cross stage under
#   qemu -cpu cortex-a72), exits 1 if kernel tests printed targets but none names it.
#   No such line at all is reported, not an error (no SIMD kernel test in this build).
set -euo pipefail
build="${1:?usage: simd-targets.sh BUILD_DIR [REQUIRED_TARGET]}"
required="${2:-}"
log="$build/Testing/Temporary/LastTest.log"
[ -f "$log" ] || { echo "simd-targets: no $log (run ctest first)" >&2; exit 2; }

pattern='[Hh]ighway|\bhwy|\bHWY|\b(NEON|NEON_[A-Z0-9]+|SVE|SVE2|SVE_256|SVE2_128|SSSE3|SSE4|AVX2|AVX3|AVX3_DL|AVX3_ZEN4|EMU128|SCALAR|RVV|WASM)\b'
# LastTest.log: "N/M Test: <name>", then "Output:", the test's output, "<end of output>".
lines="$(awk -v pat="$pattern" '
  /^[0-9]+\/[0-9]+ Test: / { name = $3; inout = 0; next }
  /^Output:$/ { inout = 1; next }
  /^<end of output>$/ { inout = 0; next }
  inout && $0 ~ pat && !/^-+$/ {
    key = name ": " $0
    if (!(key in seen) && count[name]++ < 40) { seen[key] = 1; print name ": " $0 }
  }' "$log")"

if [ -z "$lines" ]; then
  echo "simd-targets: no test printed Highway targets (no SIMD kernel test in this build)"
  exit 0
fi
echo "simd-targets: Highway targets the kernel tests ran (from $log):"
printf '%s\n' "$lines" | sed 's/^/  /'
if [ -n "$required" ] && ! printf '%s\n' "$lines" | grep -qw "$required"; then
  echo "simd-targets: expected target $required in the output above, not found" >&2
  exit 1
fi
