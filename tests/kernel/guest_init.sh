#!/bin/busybox sh
# /init of the qemu guest of tests/kernel/run.sh: loads the drivers, runs the checks in order
# (v4l2loopback and vivid, gpio-sim, vimc via libcamera, loss, removal and recovery), prints one CHECK line each, powers off.
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sys /sys
mount -t devtmpfs dev /dev
echo "GUEST up $(uname -r)"

load() { modprobe "$@" 2>&1 | sed 's/^/GUEST modprobe: /'; }
LOOPBACK_ARGS='video_nr=10 card_label=monomesh-loopback max_buffers=8'
load v4l2loopback $LOOPBACK_ARGS
load vivid n_devs=1 node_types=0x1 vid_cap_nr=0
sleep 1
# A check that dies without a verdict (a crash, an abort in a library) is a failure too.
run() {
  out=$(/bin/kernel_checks "$@")
  rc=$?
  [ -n "$out" ] && echo "$out"
  echo "$out" | grep -q '^CHECK' || echo "CHECK $1 FAIL exited with status $rc before its verdict"
}

# 1. Loopback: dataset -> feeder -> v4l2loopback -> V4l2Source, bit-exact.
run loopback --device /dev/video10 --format grey --frames /frames
run loopback --device /dev/video10 --format yuyv --frames /frames
# 2. vivid in three formats, and the error texts against a real device.
run vivid --device /dev/video0 --format yuyv
run vivid --device /dev/video0 --format nv12
run vivid --device /dev/video0 --format grey
run errors --device /dev/video0

# 3. gpio-sim: one chip, 8 lines; line 3 is the button.
load gpio-sim-oot  # Pulls configfs (a module in Debian's kernel): mount it afterwards.
mount -t configfs configfs /sys/kernel/config
if [ -d /sys/kernel/config/gpio-sim ]; then
  cfg=/sys/kernel/config/gpio-sim/mm
  mkdir $cfg $cfg/bank0 $cfg/bank0/line3
  echo 8 > $cfg/bank0/num_lines
  echo button > $cfg/bank0/line3/name
  echo 1 > $cfg/live
  chip=$(cat $cfg/bank0/chip_name)
  dev=$(cat $cfg/dev_name)
  run gpio --chip "$chip" --line button --pull /sys/devices/platform/$dev/$chip/sim_gpio3/pull
else
  echo "CHECK gpio-edges FAIL gpio-sim not available"
fi

# 4. vimc through libcamera. udevd runs as on the board (no rules: it keeps the udev database
# libcamera's enumerator reads and sends the add/remove events it watches).
mkdir -p /run/udev
/lib/systemd/systemd-udevd --daemon 2>&1 | sed 's/^/GUEST udevd: /'
load vimc
udevadm trigger --action=add 2>&1 | sed 's/^/GUEST udevadm: /'
udevadm settle --timeout=60
LIBCAMERA_LOG_LEVELS='*:ERROR' run libcamera --camera 'platform/vimc.0 Sensor B'
# vimc unbound and bound again while streaming, and the libcamera worker killed: libcamera
# 0.0.3 runs in mm-libcamera-worker, so its crash on the re-add is a lost camera, not a dead
# process (docs/capture.md).
LIBCAMERA_LOG_LEVELS='*:FATAL' run libcamera-unplug --camera 'platform/vimc.0 Sensor B' \
  --driver /sys/bus/platform/drivers/vimc --name vimc.0

# 5. Removal while streaming and recovery without a restart.
run stall --device /dev/video10 --frames /frames
run remove --device /dev/video10 --frames /frames --remove 'rmmod v4l2loopback' \
  --add "modprobe v4l2loopback $LOOPBACK_ARGS"
run unplug --device /dev/video0 --driver /sys/bus/platform/drivers/vivid --name vivid.0

# 6. The appliance: a dataset fed into v4l2loopback by `monomesh feed` (which logs when each
# frame went in), monomeshd reading the device as its camera, a trigger, a spool entry, and its
# pose evaluated against the dataset's ground truth by `monomesh eval --spool`. The feeder holds
# the first frame (the robot standing still) until the daemon has been triggered, then walks.
# Usage: appliance NAME DATASET (DATASET/check.conf: fps max_rot max_trans parallax calibration).
appliance() {
  name=$1 ds=$2
  read fps max_rot max_trans parallax calib < $ds/check.conf
  d=/tmp/mm-$name
  mkdir -p $d/spool
  printf '[camera]\nuri = "v4l2:/dev/video10?format=yuyv"\ncalibration = "%s"\n[control]\nsocket = "%s"\ngroup = ""\n[keyframes]\nparallax_deg = %s\n[spool]\ndir = "%s"\n' \
    "$ds/$calib" $d/control.sock "$parallax" $d/spool > $d/monomeshd.toml
  monomesh feed --device /dev/video10 --dataset $ds --fps "$fps" --format yuyv --once \
    --hold-first --log $d/feed.log 2> $d/feed.err &
  feeder=$!
  for i in $(seq 50); do [ -f $d/feed.log ] && [ "$(wc -l < $d/feed.log)" -ge 2 ] && break; sleep 0.2; done
  monomeshd --config $d/monomeshd.toml 2> $d/monomeshd.log &
  daemon=$!
  for i in $(seq 150); do monomesh ctl ping --socket $d/control.sock > /dev/null 2>&1 && break; sleep 0.2; done
  t0=$(date +%s)
  monomesh ctl trigger --wait 240 --socket $d/control.sock > $d/result.json 2> $d/trigger.err &
  trigger=$!
  sleep 1
  kill -USR1 $feeder
  wait $trigger
  t1=$(date +%s)
  monomesh eval --dataset $ds --spool $d/spool --feed-log $d/feed.log > $d/eval.txt 2>&1
  kill $daemon $feeder 2> /dev/null
  wait $daemon
  wait $feeder
  summary=$(tail -n 1 $d/eval.txt)
  line=$(grep -v '^entries' $d/eval.txt | head -n 1)
  # "entries: 1, evaluated 1; rot err median X max Y deg; trans dir err median A max B deg"
  verdict=$(echo "$summary" | awk -v mr="$max_rot" -v mt="$max_trans" '{
    ev = $4 + 0; rot = $10 + 0; tr = $18 + 0;
    print (ev >= 1 && rot <= mr && tr <= mt) ? "PASS" : "FAIL" }')
  echo "CHECK $name $verdict $((t1 - t0)) s from trigger to entry; $line; $summary (limits $max_rot / $max_trans deg)"
  if [ "$verdict" != PASS ]; then
    for f in result.json trigger.err feed.err monomeshd.log eval.txt; do
      echo "GUEST $f:"; tail -n 15 $d/$f | sed 's/^/GUEST   /'
    done
  fi
}
appliance appliance-loopback /dataset
# Real hand-held video (SUN3D, 30 Hz) when ../shared/data has it: the same path, real motion.
[ -f /dataset_video/check.conf ] && appliance appliance-loopback-real-video /dataset_video

echo "GUEST done"
poweroff -f
