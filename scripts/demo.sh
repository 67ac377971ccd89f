#!/usr/bin/env bash
# The main job on its embedded default: builds the two programs it runs (monomeshd, monomesh and
# the libraries they link; not the tests, which scripts/test.sh adds to the same build folder),
# starts monomeshd with the replay camera on the bundled TUM keyframes, presses capture over the
# control socket, waits for the spool entry, prints where the mesh and its report are, and stops
# the daemon. Says what it is doing and how long each step took.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
start=$SECONDS
say() { echo "demo [$((SECONDS - start)) s]: $*"; }

say "installing packages if missing, configuring and compiling monomeshd and monomesh (build/default)"
scripts/build.sh default monomeshd monomesh

demo="$root/build/demo"
spool="$root/build/demo/spool"
mkdir -p "$demo"
cat > "$demo/monomeshd.toml" <<TOML
# Written by scripts/demo.sh: the bundled dataset as a camera at 1x speed, a local spool.
[camera]
uri = "replay:$root/data/tum_office?rate=realtime&loop=1"
calibration = "$root/data/tum_office/calib.toml"
[control]
socket = "$demo/control.sock"
group = ""
[spool]
dir = "$spool"
TOML

bin="$root/build/default/firmware-app"
say "starting monomeshd (replay camera on data/tum_office)"
"$bin/monomeshd" --config "$demo/monomeshd.toml" 2> "$demo/monomeshd.log" &
daemon=$!
trap 'kill -TERM $daemon 2>/dev/null || true; wait $daemon 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  "$bin/monomesh" ctl ping --socket "$demo/control.sock" >/dev/null 2>&1 && break
  kill -0 $daemon 2>/dev/null || { cat "$demo/monomeshd.log"; exit 1; }
  sleep 0.1
done

say "monomeshd is running (log: $demo/monomeshd.log); pressing capture..."
capture_start=$SECONDS
result=$("$bin/monomesh" ctl trigger --wait 120 --socket "$demo/control.sock") || {
  echo "$result"; cat "$demo/monomeshd.log"; exit 1; }
entry=$(printf '%s\n' "$result" | sed -n 's/.*"entry": "\(.*\)".*/\1/p')
say "capture to entry took $((SECONDS - capture_start)) s"
echo
echo "spool entry: $entry"
echo "  mesh:   $entry/mesh.obj (+ mesh.mtl, texture.jpg), $entry/mesh.ply"
echo "  report: $entry/report.json"
echo "  preview: $entry/preview.png, the scene for a viewer: $entry/mesh.glb"
brief=$("$bin/monomesh" report "$entry")
printf '%s\n' "$brief" | grep -E '^(points|mesh_mode|mesh_vertices|mesh_triangles|inliers|gate_track_inliers|b_tries|total_recon_s) ' | sed 's/^/    /'
# The default mesh is the dense one; a fall-back to the sparse mesh says why and fails the demo.
printf '%s\n' "$brief" | grep -q '^mesh_mode dense ' || {
  echo "demo: the entry did not get the dense mesh"; exit 1; }
echo
say "done: first entry $((SECONDS - start)) s after the start"
