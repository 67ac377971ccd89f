#!/usr/bin/env bash
# Sets up a fresh Debian 12 machine, builds the default preset and runs the whole test suite.
# Exits non-zero on any failure. Tests that need ../shared/data skip (code 77) without it.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh default
scripts/install-deps.sh browser
ctest --preset default -j"$(nproc)"
