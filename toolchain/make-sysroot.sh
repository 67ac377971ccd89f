#!/usr/bin/env bash
# Builds an arm64 (aarch64) sysroot from Debian packages for the cross builds
# (toolchain/aarch64-linux-gnu.cmake) and the unit tests under qemu-aarch64-static.
#
# Usage: toolchain/make-sysroot.sh [DIR]
#   DIR defaults to $MM_SYSROOT, else ${XDG_CACHE_HOME:-$HOME/.cache}/monomesh/sysroot-arm64.
#   The sysroot is cached: when DIR was built from the same package list, apt sources and
#   fix-ups (a stamp file in DIR records their hash), nothing is done.
#   MM_SYSROOT_FORCE=1 rebuilds anyway.
#
# What goes in: the library packages of scripts/deps/base.txt (every name starting with "lib"
# or ending in "-dev"; the host tools are left out) plus toolchain/sysroot-extra.txt (the C and
# C++ runtime and headers the cross compiler links against), with their dependencies, unpacked
# by `mmdebstrap --variant=extract` (no maintainer scripts run). The apt sources are the host's
# (/etc/apt/sources.list.d/*.sources or /etc/apt/sources.list), so the arm64 versions match the
# amd64 ones the host builds with.
#
# Then three fix-ups (../shared/notes/platform-facts.md):
#   1. absolute symlinks -> relative, so they resolve inside the sysroot and not on the host;
#   2. the BLAS/LAPACK alternative links (libblas.so.3, liblapack.so.3, ...) that
#      update-alternatives would have made in a postinst;
#   3. absolute /usr/lib/aarch64-linux-gnu paths in CeresTargets*.cmake prefixed with
#      ${CMAKE_SYSROOT}, so find_package(Ceres) links the arm64 libraries.
# Needs root (mmdebstrap's root mode) and the host tools of scripts/deps/cross.txt.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root_dir="$(cd "$here/.." && pwd)"

dir="${1:-${MM_SYSROOT:-${XDG_CACHE_HOME:-${HOME:-}/.cache}/monomesh/sysroot-arm64}}"
arch=arm64
triplet=aarch64-linux-gnu
suite=bookworm
fixup_version=2   # bump when the fix-ups below change, to invalidate cached sysroots

# --- the package list -------------------------------------------------------------------------
read_list() {  # prints the packages of a deps file, one per line, comments dropped
  local line p
  while read -r line; do
    line="${line%%#*}"
    for p in $line; do printf '%s\n' "$p"; done
  done < "$1"
}
mapfile -t pkgs < <(
  { read_list "$root_dir/scripts/deps/base.txt" | grep -E '^lib|-dev$' || true
    read_list "$here/sysroot-extra.txt"; } | sort -u)
[ "${#pkgs[@]}" -gt 0 ] || { echo "make-sysroot: empty package list" >&2; exit 2; }

# --- apt sources: the host's ------------------------------------------------------------------
sources=()
for f in /etc/apt/sources.list.d/*.sources /etc/apt/sources.list.d/*.list /etc/apt/sources.list; do
  [ -f "$f" ] || continue
  grep -qE "^[^#]*\b$suite\b" "$f" || continue   # only Debian $suite entries (not third-party repos)
  sources+=("$f")
done
[ "${#sources[@]}" -gt 0 ] || { echo "make-sysroot: no apt sources for $suite on this host" >&2; exit 2; }

stamp_of() {
  { printf '%s\n' "fixups=$fixup_version" "arch=$arch" "suite=$suite" "${pkgs[@]}"
    cat "${sources[@]}"; } | sha256sum | cut -d' ' -f1
}
stamp="$(stamp_of)"
stamp_file="$dir/.monomesh-sysroot-stamp"
if [ -z "${MM_SYSROOT_FORCE:-}" ] && [ -f "$stamp_file" ] && [ "$(cat "$stamp_file")" = "$stamp" ]; then
  echo "make-sysroot: $dir is up to date ($(du -sh "$dir" | cut -f1), ${#pkgs[@]} packages)"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "make-sysroot: needs root (mmdebstrap root mode); run with sudo" >&2
  exit 2
fi
for tool in mmdebstrap; do
  command -v "$tool" >/dev/null || { echo "make-sysroot: $tool missing: scripts/install-deps.sh cross" >&2; exit 2; }
done

start=$SECONDS
echo "make-sysroot: building $dir ($arch, $suite, ${#pkgs[@]} packages + dependencies)"
tmp="$dir.tmp.$$"
rm -rf "$tmp"
mkdir -p "$(dirname "$dir")"
trap 'rm -rf "$tmp"' EXIT

mirror_args=()
for f in "${sources[@]}"; do mirror_args+=("$f"); done
include="$(IFS=,; echo "${pkgs[*]}")"
mmdebstrap --quiet --mode=root --variant=extract --architectures="$arch" \
  --include="$include" "$suite" "$tmp" "${mirror_args[@]}"
t_extract=$((SECONDS - start))

# mmdebstrap leaves apt's state and downloaded lists; none of it is needed to build against.
# The scratch folders go too: qemu -L <sysroot> looks a path up in the sysroot first, so a test
# that lists /tmp would otherwise see the sysroot's (empty) one instead of the host's.
rm -rf "$tmp/var/cache/apt" "$tmp/var/lib/apt/lists" "$tmp/dev" "$tmp/proc" "$tmp/sys" \
  "$tmp/tmp" "$tmp/var/tmp" "$tmp/run"

# 1. absolute symlinks -> relative (e.g. libfoo.so -> /lib/aarch64-linux-gnu/libfoo.so.1).
n_links=0
while IFS= read -r -d '' link; do
  target="$(readlink "$link")"
  case "$target" in
    /*) ln -sfnr "$tmp$target" "$link"; n_links=$((n_links + 1)) ;;
  esac
done < <(find "$tmp" -type l -print0)

# 2. BLAS/LAPACK alternatives: libblas.so.3 etc. normally point via /etc/alternatives into a
#    provider's folder (openblas-pthread/, blis-pthread/, blas/, lapack/). Prefer OpenBLAS, as
#    update-alternatives would by priority.
lib="$tmp/usr/lib/$triplet"
n_alt=0
for name in libblas liblapack; do
  for so in "$name.so.3" "$name.so"; do
    [ -e "$lib/$so" ] && continue
    for provider in openblas-pthread openblas-openmp openblas-serial blis-pthread blis-openmp \
                    blis-serial atlas "${name#lib}"; do
      if [ -e "$lib/$provider/$so" ]; then
        ln -sfnr "$lib/$provider/$so" "$lib/$so"; n_alt=$((n_alt + 1)); break
      fi
    done
  done
done

# 3. CeresTargets*.cmake names its dependencies by absolute host paths; anchor them in the sysroot.
n_ceres=0
while IFS= read -r -d '' f; do
  sed -i -E "s#([\";[:space:]])/usr/lib/$triplet/#\1\${CMAKE_SYSROOT}/usr/lib/$triplet/#g" "$f"
  n_ceres=$((n_ceres + 1))
done < <(find "$tmp/usr/lib/$triplet/cmake" -path '*eres*' -name 'CeresTargets*.cmake' -print0 2>/dev/null)

# Sanity: the pieces the cross build cannot do without.
for f in "usr/include/$triplet/bits/libc-header-start.h" "usr/lib/$triplet/libc.so" \
         "usr/lib/$triplet/libstdc++.so.6" "usr/include/opencv4/opencv2/core.hpp"; do
  [ -e "$tmp/$f" ] || { echo "make-sysroot: $f missing from the sysroot" >&2; exit 1; }
done

echo "$stamp" > "$tmp/.monomesh-sysroot-stamp"
rm -rf "$dir"
mv "$tmp" "$dir"
trap - EXIT
echo "make-sysroot: done in $((SECONDS - start)) s (download + extract ${t_extract} s):" \
  "$(du -sh "$dir" | cut -f1) on disk; fixed $n_links absolute symlinks, $n_alt BLAS/LAPACK links, $n_ceres Ceres target files"
