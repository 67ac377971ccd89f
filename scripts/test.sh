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
  "")     # The build's packages first (present after scripts/demo.sh). The test-only groups
          # (test, browser: readers, lintian, Chromium) are needed by ctest alone, so apt
          # installs them while the tests compile.
          scripts/install-deps.sh
          if [ "$(id -u)" -ne 0 ] && ! scripts/install-deps.sh --check test browser &&
             ! sudo -n true 2>/dev/null; then
            sudo -v  # asks for the password here, not in the middle of the compiler's output
          fi
          mkdir -p build
          deps_log=build/install-deps-test.log
          echo "test: installing the test packages (groups test, browser) while compiling;" \
               "apt's output: $deps_log"
          (deps_start=$SECONDS
           scripts/install-deps.sh test browser
           echo "took $((SECONDS - deps_start)) s") >"$deps_log" 2>&1 &
          deps=$!
          scripts/build.sh default
          deps_wait=$SECONDS
          if ! wait "$deps"; then
            cat "$deps_log" >&2
            echo "test: installing the test packages failed (above)" >&2
            exit 1
          fi
          echo "test: test packages: $(grep '^install-deps:' "$deps_log" | tail -n 1)," \
               "$(tail -n 1 "$deps_log") (waited $((SECONDS - deps_wait)) s after the compile)"
          labels=() ;;
  --fast) scripts/build.sh default mm_unit_tests
          labels=(-L fast) ;;
  *)      echo "usage: scripts/test.sh [--fast]" >&2; exit 2 ;;
esac
suite=$SECONDS
# The order ctest starts the tests in is their COST (cmake/MonomeshHelpers.cmake), chosen so
# that the two cores stay busy; the times ctest measured on an earlier run would replace it.
rm -f build/default/Testing/Temporary/CTestCostData.txt
ctest --preset default -j"$(nproc)" "${labels[@]}"
echo "test: ctest took $((SECONDS - suite)) s, all $((SECONDS - start)) s"
