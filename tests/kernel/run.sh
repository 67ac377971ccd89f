#!/usr/bin/env bash
# Kernel in the loop: boots Debian's own kernel under qemu (TCG, no KVM needed) with a busybox
# initramfs holding vivid, v4l2loopback, vimc and gpio-sim, the project's check binary and the
# appliance (monomeshd, monomesh), runs the checks inside and prints one line per check ("CHECK <name> PASS|FAIL <detail>"). Exits
# non-zero when any check fails or the guest does not finish.
# Usage: tests/kernel/run.sh [build dir]   (default build/default, must hold tests_kernel_checks)
# Environment: MM_KERNEL_WORK (default build/kernel): downloads and module builds are cached there.
set -euo pipefail
cd "$(dirname "$0")/../.."
repo="$PWD"
build="$(cd "${1:-build/default}" && pwd)"
work="${MM_KERNEL_WORK:-$repo/build/kernel}"
mkdir -p "$work"
work="$(cd "$work" && pwd)"
t0=$SECONDS
log() { echo "kernel: $* ($((SECONDS - t0)) s)"; }

scripts/install-deps.sh kernel >/dev/null
checks="$build/tests/tests_kernel_checks"
prepare="$build/tests/tests_kernel_prepare"
daemon="$build/firmware-app/monomeshd"
cli="$build/firmware-app/monomesh"
worker="$build/capture/mm-libcamera-worker"
for exe in "$checks" "$prepare" "$daemon" "$cli" "$worker"; do
  [ -x "$exe" ] || { echo "kernel: build $build first ($(basename "$exe") is missing)" >&2; exit 2; }
done

# The kernel version of linux-headers-amd64; image and source pinned to the same package version.
. tests/kernel/kernel_image.sh
headers="/usr/src/linux-headers-$kv"
log "kernel $kv ($pkgver)"
fetch v4l2loopback-dkms
fetch "linux-source-6.1=$pkgver"
log "packages fetched"

# Out-of-tree modules: v4l2loopback (its dkms source) and gpio-sim (+ irq_sim) from linux-source.
mods="$work/mods"
mkdir -p "$mods"
if [ ! -f "$mods/v4l2loopback.ko" ]; then
  src="$(echo "$work"/v4l2loopback-dkms/usr/src/v4l2loopback-*)"
  rm -rf "$work/v4l2loopback-build" && cp -r "$src" "$work/v4l2loopback-build"
  make -s -C "$headers" M="$work/v4l2loopback-build" modules >/dev/null
  cp "$work/v4l2loopback-build/v4l2loopback.ko" "$mods/"
fi
if [ ! -f "$mods/gpio-sim-oot.ko" ]; then
  gs="$work/gpio-sim-build"
  rm -rf "$gs" && mkdir -p "$gs"
  tar -xJf "$work"/linux-source-6.1/usr/src/linux-source-6.1.tar.xz -C "$gs" --strip-components=1 \
    --wildcards '*/drivers/gpio/gpio-sim.c' '*/drivers/gpio/gpiolib.h' '*/kernel/irq/irq_sim.c'
  cp "$gs/drivers/gpio/gpio-sim.c" "$gs/drivers/gpio/gpiolib.h" "$gs/"
  # irq_to_desc() is not exported: use generic_handle_irq() (platform-facts.md).
  sed 's/handle_simple_irq(irq_to_desc(\([^)]*\)))/generic_handle_irq(\1)/' "$gs/kernel/irq/irq_sim.c" > "$gs/irq_sim.c"
  printf 'obj-m := gpio-sim-oot.o\ngpio-sim-oot-y := gpio-sim.o irq_sim.o\n' > "$gs/Kbuild"
  make -s -C "$headers" M="$gs" modules >/dev/null
  cp "$gs/gpio-sim-oot.ko" "$mods/"
fi
if [ ! -f "$mods/vimc.ko" ]; then
  vb="$work/vimc-build"
  rm -rf "$vb" && mkdir -p "$vb"
  tar -xJf "$work"/linux-source-6.1/usr/src/linux-source-6.1.tar.xz -C "$vb" --strip-components=5 \
    --wildcards '*/drivers/media/test-drivers/vimc/*'
  printf 'obj-m := vimc.o\nvimc-y := vimc-core.o vimc-common.o vimc-streamer.o vimc-capture.o vimc-debayer.o vimc-scaler.o vimc-sensor.o vimc-lens.o\n' > "$vb/Kbuild"
  rm -f "$vb/Makefile"
  make -s -C "$headers" M="$vb" modules >/dev/null
  cp "$vb/vimc.ko" "$mods/"
fi
log "modules built"

# Initramfs: busybox, the modules (vivid and its dependencies from Debian's image, ours in
# extra/), the check binary with its libraries, the dataset frames as PPM.
root="$work/root"
rm -rf "$root" && mkdir -p "$root"/{bin,proc,sys,dev,tmp,frames,lib/modules/$kv/extra}
cp /bin/busybox "$root/bin/busybox"
kmods="$image/lib/modules/$kv"
cp "$kmods"/modules.builtin* "$kmods"/modules.order "$root/lib/modules/$kv/" 2>/dev/null || true
want=(vivid)
for m in "$mods"/*.ko; do want+=($(modinfo -F depends "$m" | tr ',' ' ')); done
declare -A seen=()
while [ ${#want[@]} -gt 0 ]; do
  m="${want[0]}"; want=("${want[@]:1}")
  [ -n "${seen[$m]:-}" ] && continue
  seen[$m]=1
  f="$(find "$kmods/kernel" -name "$m.ko*" -o -name "${m//_/-}.ko*" | head -1)"
  [ -n "$f" ] || continue
  rel="${f#"$kmods"/}"
  mkdir -p "$root/lib/modules/$kv/$(dirname "$rel")"
  case "$f" in
    *.xz) xz -dc "$f" > "$root/lib/modules/$kv/${rel%.xz}" ;;
    *.zst) zstd -qdc "$f" > "$root/lib/modules/$kv/${rel%.zst}" ;;
    *) cp "$f" "$root/lib/modules/$kv/$rel" ;;
  esac
  deps="$(modinfo -F depends "$f" | tr ',' ' ')"
  for d in $deps; do want+=("$d"); done
done
cp "$mods"/*.ko "$root/lib/modules/$kv/extra/"
depmod -b "$root" "$kv"
cp "$checks" "$root/bin/kernel_checks"
# The appliance itself (debug info stripped: the guest holds the initramfs in RAM).
strip -o "$root/bin/monomeshd" "$daemon"
strip -o "$root/bin/monomesh" "$cli"
# libcamera runs in this worker, found next to the program that starts it.
strip -o "$root/bin/mm-libcamera-worker" "$worker"
# libcamera's IPA modules (vimc's pipeline needs its IPA) and their configuration.
lcdir=/usr/lib/x86_64-linux-gnu/libcamera
mkdir -p "$root$lcdir" "$root/usr/share/libcamera"
cp -a "$lcdir"/. "$root$lcdir/"
cp -a /usr/share/libcamera/. "$root/usr/share/libcamera/"
# udevd (a multi-call udevadm), no rules: it keeps the udev database and sends the events
# libcamera's device enumerator watches for hotplug.
mkdir -p "$root/lib/systemd" "$root/etc/udev"
cp /bin/udevadm "$root/bin/udevadm"
ln -s /bin/udevadm "$root/lib/systemd/systemd-udevd"
for bin in "$checks" "$daemon" "$cli" "$worker" "$lcdir"/*.so "$lcdir"/*_proxy /bin/udevadm; do
  for lib in $(ldd "$bin" | awk '/=>/ {print $3} /^\t\/lib/ {print $1}' | sort -u); do
    [ -e "$root$lib" ] && continue
    mkdir -p "$root$(dirname "$lib")"
    cp -L "$lib" "$root$lib"
  done
done
"$prepare" "$repo/data/tum_office" "$root/frames" 6 >/dev/null
# The dataset the appliance check feeds into v4l2loopback (TUM format with ground truth). By
# default a `monomesh synth` L-corridor walk (exact ground truth; docs/synth.md) through a
# distorted 320x240 board camera, played at 30 fps; MM_KERNEL_DATASET plays another folder
# (e.g. data/tum_office with MM_KERNEL_DATASET_FPS=1).
if [ -n "${MM_KERNEL_DATASET:-}" ]; then
  appliance_data="$MM_KERNEL_DATASET"
  conf="${MM_KERNEL_DATASET_FPS:-1} ${MM_KERNEL_MAX_ROT_ERR_DEG:-1.0} ${MM_KERNEL_MAX_TRANS_ERR_DEG:-10} ${MM_KERNEL_PARALLAX_DEG:-2.0} calib.toml"
else
  appliance_data="$work/corridor"
  rm -rf "$appliance_data"
  # 150 frames: 5 s and 5 m of walking, the gate at its default angle.
  "$cli" synth --scene l-corridor --out "$appliance_data" --frames 150 --fps 30 \
    --calib tests/support/board_camera.toml --seed 1 --path walk >/dev/null
  conf="30 ${MM_KERNEL_MAX_ROT_ERR_DEG:-0.5} ${MM_KERNEL_MAX_TRANS_ERR_DEG:-3} 2.0 calib.toml"
  log "corridor generated"
fi
mkdir -p "$root/dataset"
cp -r "$appliance_data"/rgb "$appliance_data"/rgb.txt "$appliance_data"/groundtruth.txt \
  "$appliance_data"/calib.toml "$root/dataset/"
echo "$conf" > "$root/dataset/check.conf"
# The walk checks' dataset: tests/integration/daemon_walk_test's corridor walk (seed 2) through
# the board camera at 10 fps, 100 frames 10 cm apart; the guest gets its second half (from 5 m
# down the first leg, round the corner, 1.4 m into the second) and plays it a frame at a time as
# the walk takes them (guest_init.sh's step_feed), repeating each at MM_KERNEL_WALK_FPS.
walk_data="$work/corridor_walk"
rm -rf "$walk_data"
"$cli" synth --scene l-corridor --out "$walk_data" --frames 100 --fps 10 \
  --calib tests/support/board_camera.toml --seed 2 --path walk >/dev/null
log "corridor walk generated"
mkdir -p "$root/dataset_walk/rgb"
awk '/^#/ || $1 >= 1005.0' "$walk_data/rgb.txt" > "$root/dataset_walk/rgb.txt"
grep -v '^#' "$root/dataset_walk/rgb.txt" | while read -r t f; do cp "$walk_data/$f" "$root/dataset_walk/rgb/"; done
cp "$walk_data"/groundtruth.txt "$walk_data"/calib.toml "$root/dataset_walk/"
# fps max_ate_percent min_keyframes min_path_m calibration. Measured under TCG, fed a frame at a
# time (two runs): 15 keyframes, all registered in one segment, ATE RMSE 0.240 % of a 4.62 m path
# both times (natively, `monomesh eval --walk` on the same 50 frames: 0.177 %; fed at a fixed
# 1 fps, skipping frames, it had been 0.165-0.174 %); the issue's bound is 0.5 %. 4 m of path:
# past the corner's end.
echo "${MM_KERNEL_WALK_FPS:-2} 0.3 10 4.0 calib.toml" > "$root/dataset_walk/check.conf"
# Real hand-held video for the same check when ../shared/data has it (SUN3D study room, 30 Hz;
# its SfM ground truth is interpolated between every 5th frame, hence the looser limits).
video="$repo/../shared/data/sun3d_studyroom_continuous"
if [ -d "$video" ]; then
  mkdir -p "$root/dataset_video"
  cp -r "$video"/rgb "$video"/rgb.txt "$video"/groundtruth.txt "$video"/Calib_Results.m \
    "$root/dataset_video/"
  echo "30 2.0 15 2.0 Calib_Results.m" > "$root/dataset_video/check.conf"
fi
cp tests/kernel/guest_init.sh "$root/init"
chmod +x "$root/init"
(cd "$root" && find . | cpio -o -H newc --quiet | zstd -q -1 -T0 > "$work/initrd.zst")
log "initramfs $(du -h "$work/initrd.zst" | cut -f1)"

# Boot; the guest powers off when done (panic=-1 + -no-reboot end qemu on a crash).
out="$work/console.log"
set +e
timeout 900 qemu-system-x86_64 -accel tcg -cpu max -smp 1 -nographic -no-reboot -nic none -m 1536 \
  -kernel "$image/boot/vmlinuz-$kv" -initrd "$work/initrd.zst" \
  -append "console=ttyS0 quiet loglevel=3 panic=-1" > "$out" 2>&1
qrc=$?
set -e
log "qemu exit $qrc"
guest_verdict kernel "$out" 1
