#!/usr/bin/env bash
# Installs the Debian 12 packages monomesh needs, idempotently: packages already present are
# skipped, so a second run costs one dpkg query per package. sudo is used when not root.
# Usage: scripts/install-deps.sh [--check] [GROUP ...]   (groups: scripts/deps/<GROUP>.txt;
#        base always). --check installs nothing: exit 0 when every package is present, 1 if not.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
check=0
if [ "${1:-}" = "--check" ]; then check=1; shift; fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

pkgs=()
for group in base "$@"; do
  file="$here/deps/$group.txt"
  [ -f "$file" ] || { echo "install-deps: no package group '$group' ($file)" >&2; exit 2; }
  while read -r line; do
    line="${line%%#*}"
    for p in $line; do pkgs+=("$p"); done
  done < "$file"
done

missing=()
for p in "${pkgs[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "$check" -eq 1 ]; then
  [ "${#missing[@]}" -eq 0 ]
  exit
fi
if [ "${#missing[@]}" -gt 0 ]; then
  echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "install-deps: all ${#pkgs[@]} packages present"
fi
