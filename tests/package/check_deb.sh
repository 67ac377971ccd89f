#!/usr/bin/env bash
# Builds the Debian package from a build tree and checks it: the exact file list, the
# dependencies found by dpkg-shlibdeps, the conffile and maintainer scripts, the long
# description and changelog, that the packaged programs run and report the package's version,
# that `systemd-analyze verify` accepts the packaged units without a warning, that
# `systemd-analyze security` rates their exposure at most 2.0 (monomeshd) and 2.5
# (monomesh-web), and that lintian reports no error
# and no warning (its pedantic and informational tags are printed, not failed on).
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
for need in systemd libjs-three libcpp-httplib0.11 libzip4 libopencv-core406 libsystemd0 libtomlplusplus3; do
  case "$depends" in *"$need"*) ;; *) echo "FAIL: Depends lacks $need: $depends"; exit 1 ;; esac
done
echo "ok: Depends: $depends"

dpkg-deb -e "$deb" "$work/control"
grep -qx "/etc/monomesh/monomeshd.toml" "$work/control/conffiles" || { echo "FAIL: conffiles"; exit 1; }
for script in postinst prerm postrm; do
  [ -x "$work/control/$script" ] || { echo "FAIL: $script missing"; exit 1; }
done
grep -q "deb-systemd-invoke stop monomesh-web.service monomeshd.service" "$work/control/prerm" ||
  { echo "FAIL: prerm does not stop the service"; exit 1; }
grep -q "for unit in monomeshd.service monomesh-web.service" "$work/control/postrm" ||
  { echo "FAIL: postrm does not disable the service"; exit 1; }
echo "ok: conffiles, postinst, prerm, postrm"

version=$(dpkg-deb -f "$deb" Version)
long=$(dpkg-deb -f "$deb" Description | tail -n +2)
[ "$(printf '%s\n' "$long" | wc -l)" -ge 3 ] || { echo "FAIL: long description: $long"; exit 1; }
echo "ok: long description ($(printf '%s\n' "$long" | wc -l) lines)"

dpkg-deb -x "$deb" "$work/root"
"$work/root/usr/bin/monomeshd" --help >/dev/null
"$work/root/usr/bin/monomesh" --help >/dev/null
"$work/root/usr/bin/monomesh-web" --help >/dev/null
for program in monomeshd monomesh monomesh-web; do
  got=$("$work/root/usr/bin/$program" --version)
  [ "$got" = "$program $version" ] || { echo "FAIL: $program --version: '$got', package $version"; exit 1; }
  # The man page shows the program's own options (help2man ran its --help).
  LC_ALL=C MANWIDTH=100 man -l "$work/root/usr/share/man/man1/$program.1.gz" 2>&1 |
    grep -q -- "-V,--version" || { echo "FAIL: man page of $program lacks its options"; exit 1; }
done
changelog_version=$(dpkg-parsechangelog -l "$src/systemd/debian/changelog" -S Version)
[ "$changelog_version" = "$version" ] ||
  { echo "FAIL: changelog's version $changelog_version, package $version"; exit 1; }
echo "ok: packaged programs run, --version and changelog say $version, man pages"

# verify needs the ExecStart binary to exist: point each unit at the extracted one. Exposure
# bounds: monomeshd 2.0, monomesh-web 2.5 (it needs the network).
for unit_bound in monomeshd:2.0 monomesh-web:2.5; do
  unit="${unit_bound%%:*}"; bound="${unit_bound##*:}"
  sed "s#/usr/bin/$unit #$work/root/usr/bin/$unit #" \
    "$work/root/usr/lib/systemd/system/$unit.service" > "$work/$unit.service"
  # Documentation=man:... is checked against the packaged man page.
  out=$(MANPATH="$work/root/usr/share/man" systemd-analyze verify "$work/$unit.service" 2>&1) ||
    { echo "$out"; echo "FAIL: systemd-analyze verify $unit.service"; exit 1; }
  if [ -n "$out" ]; then echo "$out"; echo "FAIL: systemd-analyze verify $unit.service warned"; exit 1; fi
  echo "ok: systemd-analyze verify accepts $unit.service"

  security=$(systemd-analyze security --offline=true "$work/$unit.service" 2>&1) ||
    { echo "$security"; echo "FAIL: systemd-analyze security $unit.service"; exit 1; }
  exposure=$(printf '%s\n' "$security" | sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p')
  [ -n "$exposure" ] || { echo "$security"; echo "FAIL: no exposure figure for $unit"; exit 1; }
  if ! awk -v e="$exposure" -v b="$bound" 'BEGIN { exit !(e <= b) }'; then
    printf '%s\n' "$security" | grep '✗'
    echo "FAIL: systemd-analyze security: $unit.service exposure $exposure > $bound"; exit 1
  fi
  echo "ok: systemd-analyze security: $unit.service exposure $exposure (<= $bound)"
done

# lintian: errors and warnings fail; the pedantic and informational tags are shown.
lint=$(lintian --pedantic --display-info --tag-display-limit 0 "$deb" 2>&1 | grep -v '^running with root privileges' || true)
[ -n "$lint" ] && printf '%s\n' "$lint"
if printf '%s\n' "$lint" | grep -q '^[EW]: '; then echo "FAIL: lintian reports errors or warnings"; exit 1; fi
echo "ok: lintian: no errors, no warnings ($(printf '%s\n' "$lint" | grep -c '^[IPX]: ' || true) pedantic/info tags)"
