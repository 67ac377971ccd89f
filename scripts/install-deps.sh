#!/usr/bin/env bash
# Installs the Debian 12 packages monomesh needs to build, test and run. Idempotent:
# packages already present are skipped, so a second run costs one dpkg query.
# Usage: scripts/install-deps.sh [--with-kernel-tests] [--with-cross]
set -euo pipefail

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

pkgs=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang clang-format clang-tidy
  # libraries
  libopencv-dev libeigen3-dev libceres-dev libcgal-dev libgmp-dev libmpfr-dev
  libtomlplusplus-dev libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev libtinygltf-dev libstb-dev
  libgtest-dev libgmock-dev libbenchmark-dev libhwy-dev
  libgpiod-dev libcamera-dev libsystemd-dev libturbojpeg0-dev
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
  # test tools
  assimp-utils
)

missing=()
for p in "${pkgs[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "${#missing[@]}" -gt 0 ]; then
  echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "install-deps: all ${#pkgs[@]} packages present"
fi
