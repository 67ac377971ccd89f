#!/usr/bin/env bash
# Runs every libFuzzer target of the asan preset (listed in build/asan/fuzz_targets.txt by
# mm_add_fuzzer) for a bounded time, as many at once as there are cores, from its seed corpus
# in the repository. New inputs go to build/asan/corpus/<target>/, crashes to
# build/asan/crashes/<target>/ (the input that crashed is named in the log).
# Usage: scripts/fuzz.sh [seconds per target, default 30]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
list=build/asan/fuzz_targets.txt
[[ -s "$list" ]] || { echo "fuzz: $list is missing or empty (cmake --preset asan)" >&2; exit 2; }

run_one() {
  local name="$1" binary="$2" seeds="$3" seconds="$4"
  local corpus="build/asan/corpus/$name" crashes="build/asan/crashes/$name"
  mkdir -p "$corpus" "$crashes"
  # A fixed seed: the same mutations on the same corpus (MM_FUZZ_SEED=0 lets libFuzzer pick).
  if "$binary" -seed="${MM_FUZZ_SEED:-1}" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
       -print_final_stats=1 -artifact_prefix="$crashes/" "$corpus" "$seeds" \
       >"build/asan/$name.log" 2>&1; then
    local runs
    runs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "build/asan/$name.log" | grep -o '[0-9]*$')
    echo "fuzz: $name ok in ${seconds} s: ${runs:-?} runs, $(ls "$corpus" | wc -l) corpus inputs"
  else
    echo "fuzz: $name FAILED; log build/asan/$name.log:" >&2
    tail -n 40 "build/asan/$name.log" >&2
    return 1
  fi
}
export -f run_one

failed=0
xargs -P "$(nproc)" -L 1 bash -c 'run_one "$0" "$1" "$2" '"$seconds" <"$list" || failed=1
exit "$failed"
