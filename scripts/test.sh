#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine, builds the default preset (in build/default, reusing what
# scripts/demo.sh built) and runs the whole test suite with ctest over every core; tests that
# cannot share the machine (a real-time daemon, timers) are kept apart by their RESOURCE_LOCKs
# (cmake/MonomeshHelpers.cmake). Exits non-zero on any failure. Tests that need
# ../shared/data skip (code 77) without it.
# Usage: scripts/test.sh [--fast]
#   --fast  only the unit tests (ctest label "fast"), and only their targets built
set -euo pipefail
cd "$(dirname "$0")/.."
start=$SECONDS
case "${1:-}" in
  "")     scripts/install-deps.sh test browser
          scripts/build.sh default
          labels=() ;;
  --fast) scripts/build.sh default mm_unit_tests
          labels=(-L fast) ;;
  *)      echo "usage: scripts/test.sh [--fast]" >&2; exit 2 ;;
esac
suite=$SECONDS
ctest --preset default -j"$(nproc)" "${labels[@]}"
echo "test: ctest took $((SECONDS - suite)) s, all $((SECONDS - start)) s"
