#!/usr/bin/env bash
# Builds the Debian package from a build tree and checks it: the exact file list, the
# dependencies found by dpkg-shlibdeps, the conffile and maintainer script, that the packaged
# daemon runs, that `systemd-analyze verify` accepts the packaged unit without a warning, and
# that `systemd-analyze security` rates its exposure at most 2.0.
# Usage: check_deb.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build="$1"; src="$2"
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT

(cd "$build" && cpack -G DEB -B "$work/out" >/dev/null)
deb=$(ls "$work"/out/monomesh_*.deb)
echo "package: $(basename "$deb") ($(du -k "$deb" | cut -f1) KiB)"

dpkg-deb -c "$deb" | awk '$1 !~ /^d/ {print $6}' | sed 's#^\./#/#' | sort > "$work/files.txt"
if ! diff -u "$src/tests/package/expected_files.txt" "$work/files.txt"; then
  echo "FAIL: file list differs from tests/package/expected_files.txt"; exit 1
fi
echo "ok: file list ($(wc -l < "$work/files.txt") files)"

depends=$(dpkg-deb -f "$deb" Depends)
for need in systemd libopencv-core406 libsystemd0 libtomlplusplus3; do
  case "$depends" in *"$need"*) ;; *) echo "FAIL: Depends lacks $need: $depends"; exit 1 ;; esac
done
echo "ok: Depends: $depends"

dpkg-deb -e "$deb" "$work/control"
grep -qx "/etc/monomesh/monomeshd.toml" "$work/control/conffiles" || { echo "FAIL: conffiles"; exit 1; }
[ -x "$work/control/postinst" ] || { echo "FAIL: postinst missing"; exit 1; }
echo "ok: conffiles and postinst"

dpkg-deb -x "$deb" "$work/root"
"$work/root/usr/bin/monomeshd" --help >/dev/null
"$work/root/usr/bin/monomesh" --help >/dev/null
echo "ok: packaged programs run"

# verify needs the ExecStart binary to exist: point the unit at the extracted one.
sed "s#/usr/bin/monomeshd#$work/root/usr/bin/monomeshd#" \
  "$work/root/usr/lib/systemd/system/monomeshd.service" > "$work/monomeshd.service"
out=$(systemd-analyze verify "$work/monomeshd.service" 2>&1) || { echo "$out"; echo "FAIL: systemd-analyze verify"; exit 1; }
if [ -n "$out" ]; then echo "$out"; echo "FAIL: systemd-analyze verify warned"; exit 1; fi
echo "ok: systemd-analyze verify accepts monomeshd.service"

security=$(systemd-analyze security --offline=true "$work/monomeshd.service" 2>&1) ||
  { echo "$security"; echo "FAIL: systemd-analyze security"; exit 1; }
exposure=$(printf '%s\n' "$security" | sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p')
[ -n "$exposure" ] || { echo "$security"; echo "FAIL: no exposure figure"; exit 1; }
if ! awk -v e="$exposure" 'BEGIN { exit !(e <= 2.0) }'; then
  printf '%s\n' "$security" | grep '✗'
  echo "FAIL: systemd-analyze security: exposure $exposure > 2.0"; exit 1
fi
echo "ok: systemd-analyze security: exposure $exposure (<= 2.0)"
