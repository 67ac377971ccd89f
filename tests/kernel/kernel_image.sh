# Sourced by tests/kernel/run.sh and tests/boot/run.sh: Debian's own kernel for a qemu guest
# and the verdict on its console. Needs $work (the cache folder). Sets kv (the kernel version
# of linux-headers-amd64), pkgver (its package version) and image (the unpacked
# linux-image-<kv>-unsigned); defines fetch PACKAGE[=VERSION], which downloads and unpacks a
# package into $work/<name> once, and guest_verdict (below).
kv="$(dpkg-query -W -f='${Depends}' linux-headers-amd64 | sed -n 's/.*linux-headers-\([0-9][^ ,]*-amd64\).*/\1/p')"
pkgver="$(dpkg-query -W -f='${Version}' "linux-headers-$kv")"

fetch() {  # fetch PACKAGE=VERSION -> unpacked into $work/<name>
  local spec="$1" name="${1%%=*}"
  if [ ! -f "$work/$name/.done" ]; then
    rm -rf "$work/$name" "$work/dl-$name"
    mkdir -p "$work/dl-$name" "$work/$name"
    (cd "$work/dl-$name" && apt-get download -q "$spec" >/dev/null 2>&1) || {
      apt-get update -qq && (cd "$work/dl-$name" && apt-get download -q "$spec" >/dev/null)
    }
    dpkg-deb -x "$work/dl-$name"/*.deb "$work/$name"
    rm -rf "$work/dl-$name"
    touch "$work/$name/.done"
  fi
}
fetch "linux-image-${kv}-unsigned=$pkgver"
image="$work/linux-image-${kv}-unsigned"

# guest_verdict NAME CONSOLE_LOG MIN_PASSES: prints the guest's CHECK and GUEST lines and a count;
# fails when a check failed, fewer than MIN_PASSES passed, or the guest never said "GUEST done".
guest_verdict() {
  local name="$1" out="$2" min="$3" pass fail done_line
  tr -d '\r' < "$out" | grep -E '^(CHECK|GUEST)' || true
  pass=$(tr -d '\r' < "$out" | grep -c '^CHECK .* PASS' || true)
  fail=$(tr -d '\r' < "$out" | grep -c '^CHECK .* FAIL' || true)
  done_line=$(tr -d '\r' < "$out" | grep -c '^GUEST done' || true)
  echo "$name checks: $pass passed, $fail failed"
  if [ "$done_line" -ne 1 ] || [ "$fail" -ne 0 ] || [ "$pass" -lt "$min" ]; then
    echo "$name: FAILED (console log: $out); last lines:" >&2
    tail -n 40 "$out" >&2
    return 1
  fi
}
