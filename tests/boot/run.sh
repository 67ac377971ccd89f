#!/usr/bin/env bash
# The installed package, booted: a Debian 12 root file system (mmdebstrap, minbase + systemd)
# with the .deb built from BUILD installed as apt installs it, booted under qemu (TCG) with
# systemd as PID 1 and the whole tree as the initramfs (no disk driver needed). In the guest
# mm-boot-check.service (tests/boot/guest_check.sh) waits for monomeshd.service, enabled as the
# README's board section says (the package does not start it on a first install), and, as user `operator` in group monomesh (not root), presses capture with
# the installed example config (the replay camera on the demo data) and checks the entry in the
# configured spool. One "CHECK <name> PASS|FAIL" line per check; exits non-zero on a failure
# or when the guest does not finish. systemd-nspawn -b does not work on these machines (the
# host's PID 1 is not systemd), hence the guest.
# Usage: tests/boot/run.sh [build dir]   (default build/default, configured and built)
# Environment: MM_BOOT_WORK (default build/boot); the kernel is shared with tests/kernel/run.sh
# through MM_KERNEL_WORK (default build/kernel).
set -euo pipefail
cd "$(dirname "$0")/../.."
repo="$PWD"
build="$(cd "${1:-build/default}" && pwd)"
boot="${MM_BOOT_WORK:-$repo/build/boot}"
work="${MM_KERNEL_WORK:-$repo/build/kernel}"
mkdir -p "$boot" "$work"
boot="$(cd "$boot" && pwd)"
work="$(cd "$work" && pwd)"
t0=$SECONDS
log() { echo "boot: $* ($((SECONDS - t0)) s)"; }

scripts/install-deps.sh kernel boot >/dev/null
. tests/kernel/kernel_image.sh
log "kernel $kv"

rm -rf "$boot/deb" && mkdir -p "$boot/deb"
(cd "$build" && cpack -G DEB -B "$boot/deb" >/dev/null)
deb=$(ls "$boot"/deb/monomesh_*.deb)
log "package $(basename "$deb")"

# The root: what apt installs for the package (its Depends) on a minimal Debian with systemd.
# Documentation and locales are left out of the guest (the package test checks them).
root="$boot/root"
rm -rf "$root"
mmdebstrap --quiet --variant=minbase --mode=root \
  --include=systemd,systemd-sysv,dbus,procps,findutils,curl${MM_BOOT_DEBUG:+,gdb} --include="$deb" \
  --hook-dir=/usr/share/mmdebstrap/hooks/file-mirror-automount \
  --dpkgopt='path-exclude=/usr/share/man/*' --dpkgopt='path-exclude=/usr/share/locale/*' \
  --dpkgopt='path-exclude=/usr/share/doc/*' --dpkgopt='path-include=/usr/share/doc/monomesh/*' \
  --customize-hook='chroot "$1" useradd --create-home --no-user-group --groups monomesh operator' \
  --customize-hook='chroot "$1" systemctl enable monomeshd.service monomesh-web.service' \
  --customize-hook='chroot "$1" systemctl mask serial-getty@ttyS0.service getty@tty1.service systemd-timesyncd.service apt-daily.timer apt-daily-upgrade.timer' \
  bookworm "$root" >/dev/null
log "root file system $(du -sh "$root" | cut -f1)"

install -m 0755 tests/boot/guest_check.sh "$root/usr/local/bin/mm-boot-check"
cat > "$root/etc/systemd/system/mm-boot-check.service" <<'UNIT'
[Unit]
Description=monomesh booted-unit check (tests/boot)
After=multi-user.target monomeshd.service
Wants=monomeshd.service

[Service]
Type=oneshot
ExecStart=/usr/local/bin/mm-boot-check
StandardOutput=tty
StandardError=tty
TTYPath=/dev/ttyS0
UNIT
mkdir -p "$root/etc/systemd/system/multi-user.target.wants"
ln -sf /etc/systemd/system/mm-boot-check.service "$root/etc/systemd/system/multi-user.target.wants/"
echo monomesh-boot > "$root/etc/hostname"
if [ -n "${MM_BOOT_DEBUG:-}" ]; then
  # A crash of the daemon leaves a core in its StateDirectory; the check prints its backtrace.
  mkdir -p "$root/etc/systemd/system/monomeshd.service.d" "$root/etc/sysctl.d"
  printf '[Service]\nLimitCORE=infinity\n' > "$root/etc/systemd/system/monomeshd.service.d/core.conf"
  echo 'kernel.core_pattern=/var/lib/monomesh/core.%p' > "$root/etc/sysctl.d/50-core.conf"
fi

(cd "$root" && find . -xdev | cpio -o -H newc --quiet | zstd -q -1 -T0 > "$boot/root.cpio.zst")
log "initramfs $(du -h "$boot/root.cpio.zst" | cut -f1)"

# A CPU model without AVX: under TCG with -cpu max, Mesa llvmpipe's JIT code for the preview
# crashed the daemon (SIGSEGV under glReadBuffer; qemu 7.2), with Nehalem it renders.
out="$boot/console.log"
set +e
timeout 1200 qemu-system-x86_64 -accel tcg -cpu "${MM_BOOT_CPU:-Nehalem}" -smp 1 -nographic -no-reboot -nic none -m 4096 \
  -kernel "$image/boot/vmlinuz-$kv" -initrd "$boot/root.cpio.zst" \
  -append "console=ttyS0 rdinit=/lib/systemd/systemd panic=-1 quiet loglevel=3 systemd.show_status=0" \
  > "$out" 2>&1
qrc=$?
set -e
log "qemu exit $qrc"
guest_verdict boot "$out" 25
