#!/usr/bin/env bash
# Installs the Node test tools (the Khronos glTF validator) pinned by tests/gltf/package-lock.json
# into DIR (default build/node-tools) with `npm ci`. Needs node + npm (Debian) and the npm registry.
# Usage: scripts/install-node-tools.sh [DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
dir="${1:-build/node-tools}"
if [[ -f "$dir/node_modules/gltf-validator/package.json" ]] &&
   cmp -s tests/gltf/package-lock.json "$dir/package-lock.json"; then
  exit 0
fi
mkdir -p "$dir"
cp tests/gltf/package.json tests/gltf/package-lock.json tests/gltf/validate.js "$dir/"
(cd "$dir" && npm ci --no-audit --no-fund --loglevel=error)
