#!/usr/bin/env bash
# Configures and builds one CMake preset (default: "default") after installing what it needs;
# with targets, only those (and what they link), e.g. `scripts/build.sh default monomeshd`.
# Prints how long each step took.
# Usage: scripts/build.sh [preset [target ...]]
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-default}"
shift || true
targets=()
if [ "$#" -gt 0 ]; then targets=(--target "$@"); fi

step() {  # step NAME COMMAND...: runs it, then prints its time
  local name="$1" start=$SECONDS; shift
  "$@"
  echo "build: $name took $((SECONDS - start)) s"
}
step "packages (scripts/install-deps.sh)" scripts/install-deps.sh
configure() { cmake --preset "$preset" >/dev/null; }
step "configure ($preset)" configure
step "compile ($preset${*:+: $*})" cmake --build --preset "$preset" -j"$(nproc)" "${targets[@]}"
