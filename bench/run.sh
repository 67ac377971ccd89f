#!/usr/bin/env bash
# Speed (and accuracy) of the two-view reconstruction against COLMAP, in one run:
#   1. `monomesh eval` on the TUM keyframe pairs (step 1): per-pair time from two images and
#      after keyframe B (A's SIFT precomputed), wall and process CPU, one thread;
#   2. every *_bench Google Benchmark binary in the build (e.g. recon_matcher_bench);
#   3. monomeshd's time to READY and peak RSS over three captures at 640x480 and 1280x720;
#   4. COLMAP (when `colmap` is installed) on the same pairs: feature_extractor,
#      exhaustive_matcher, mapper (init_min_tri_angle 2, intrinsics fixed), one thread, CPU SIFT;
#   5. the walk: `monomesh eval --walk --every-frame` on the 17 TUM keyframes, and COLMAP's
#      incremental mapper on the same 17 images (one thread, CPU SIFT, exhaustive matching,
#      intrinsics fixed): registered keyframes, ATE after a Sim(3) (bench/walk_ate.py), CPU time;
#   6. the walk on hand-held video (walk-video): `monomesh eval --walk` on the 500 frames of
#      ../shared/data/redkitchen_walk_0_499 (the tracker and the gate pick the keyframes, as in
#      the daemon), and COLMAP's incremental mapper on the keyframes it picked (as in 5):
#      segments / models, registered keyframes, ATE and scale drift after a Sim(3), CPU time.
# Prints both and the ratio, and writes everything as JSON. Wall and CPU (user + sys) time are
# both reported: on a shared, loaded machine the CPU time is the fairer comparison.
#
# Usage: bench/run.sh [--build DIR] [--dataset DIR] [--calib FILE] [--json OUT] [--pairs N]
#                     [--only SECTION[,SECTION...]]
#                     (eval, benchmarks, colmap, daemon, walk, walk-video)
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build/default"
dataset="$root/../shared/data/tum_fr3_long_office_household"
calib="$root/data/tum_office/calib.toml"
out="$root/build/bench.json"
max_pairs=16
only="eval,benchmarks,colmap,daemon,walk,walk-video"
video="$root/../shared/data/redkitchen_walk_0_499"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --dataset) dataset="$2"; shift 2 ;;
    --calib) calib="$2"; shift 2 ;;
    --json) out="$2"; shift 2 ;;
    --pairs) max_pairs="$2"; shift 2 ;;
    --only) only="$2"; shift 2 ;;
    *) echo "unknown argument $1" >&2; exit 2 ;;
  esac
done
[[ -d "$dataset" ]] || { echo "bench: no dataset at $dataset" >&2; exit 77; }
for section in ${only//,/ }; do
  case "$section" in
    eval | benchmarks | colmap | daemon | walk | walk-video) ;;
    *) echo "bench: unknown section '$section'" >&2; exit 2 ;;
  esac
done
want() { [[ ",$only," == *",$1,"* ]]; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
has_colmap=0
command -v colmap > /dev/null && has_colmap=1
export QT_QPA_PLATFORM=offscreen
# COLMAP's PINHOLE parameters (fx, fy, cx, cy) from the calibration, for both COLMAP sections.
# The calibration is TOML (fc = [fx, fy]) or Bouguet's Calib_Results.m (fc = [ fx ; fy ]).
pinhole_params() {
  python3 - "$1" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
fc = re.split(r"[,;]", re.search(r"^fc\s*=\s*\[([^\]]*)\]", text, re.M).group(1))
cc = re.split(r"[,;]", re.search(r"^cc\s*=\s*\[([^\]]*)\]", text, re.M).group(1))
print(",".join(str(float(v)) for v in fc + cc if v.strip()))
PY
}
params="$(pinhole_params "$calib")"
# colmap_walk DIR DATASET LIST PARAMS: COLMAP's incremental mapper (bench/colmap_sfm.py, seeded)
# on the images of a TUM list, every model it made converted to text, and the largest one's ATE
# and scale drift (trajectory; depth maps where the dataset has them) against the dataset's
# ground truth (bench/walk_ate.py) printed as JSON; its wall and CPU time in DIR/time.txt.
colmap_walk() {
  local d="$1" data="$2" list pinhole="$4" m t
  list="$(realpath "$3")"
  mkdir -p "$d/images" "$d/sparse" "$d/txt"
  grep -v '^#' "$list" | while read -r _ file; do cp "$data/$file" "$d/images/"; done
  python3 "$root/bench/colmap_sfm.py" "$d" "$pinhole" --random-seed 17 > "$d/time.txt"
  for m in "$d"/sparse/*/; do
    [[ -f "$m/images.bin" ]] || continue
    t="$d/txt/$(basename "$m")"
    mkdir -p "$t"
    colmap model_converter --input_path "$m" --output_path "$t" --output_type TXT \
      >> "$d/log.txt" 2>&1
  done
  local models
  mapfile -t models < <(find "$d/txt" -mindepth 1 -maxdepth 1 -type d | sort)
  python3 "$root/bench/walk_ate.py" --dataset "$data" --list "$list" "${models[@]}"
}
# timed OUT COMMAND...: runs the command and writes "WALL_S CPU_S" to OUT (CPU: user + sys of
# the child, getrusage).
timed() {
  python3 - "$@" <<'PY'
import resource, subprocess, sys, time
start = time.monotonic()
rc = subprocess.run(sys.argv[2:]).returncode
wall = time.monotonic() - start
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
open(sys.argv[1], "w").write(f"{wall:.4f} {ru.ru_utime + ru.ru_stime:.4f}\n")
sys.exit(rc)
PY
}

if want eval; then
  echo "== monomesh eval (one thread)"
  "$build/firmware-app/monomesh" eval --dataset "$dataset" --calib "$calib" \
    --list keyframes_1hz.txt --step 1 --threads 1 --json "$work/monomesh.json" --quiet
fi

if want benchmarks; then
  echo "== Google Benchmarks"
  : > "$work/benchmarks.list"
  while IFS= read -r exe; do
    name="$(basename "$exe")"
    echo "-- $name"
    if [[ "$name" == capture_capture_bench ]]; then
      # Not a Google Benchmark: the capture thread replaying 1280x720 frames per software path,
      # frames dropped and CPU per frame (argument: seconds per path).
      "$exe" 3
      continue
    fi
    "$exe" --benchmark_format=console --benchmark_out="$work/$name.json" \
      --benchmark_out_format=json
    echo "$work/$name.json" >> "$work/benchmarks.list"
  done < <(find "$build" -type f -name '*_bench' -perm -u+x | sort)
fi

colmap_ok=0
if want colmap && [[ $has_colmap == 1 ]]; then
  echo "== COLMAP $(colmap -h 2>/dev/null | grep -m1 -o 'COLMAP [0-9.]*' || true) (one thread, CPU)"
  mapfile -t frames < <(grep -v '^#' "$dataset/keyframes_1hz.txt" | awk '{print $2}')
  : > "$work/colmap.tsv"
  n=0
  for ((i = 0; i + 1 < ${#frames[@]} && n < max_pairs; i++, n++)); do
    d="$work/colmap_$i"
    mkdir -p "$d/images" "$d/sparse"
    cp "$dataset/${frames[$i]}" "$d/images/a.png"
    cp "$dataset/${frames[$((i + 1))]}" "$d/images/b.png"
    # Wall and CPU of the three COLMAP commands; a 2 deg initial pair angle (two images).
    python3 "$root/bench/colmap_sfm.py" "$d" "$params" -- --Mapper.init_min_tri_angle 2 \
      > "$d/time.txt"
    read -r wall cpu < "$d/time.txt"
    registered=0
    [[ -f "$d/sparse/0/images.bin" ]] && registered=1
    printf '%d\t%s\t%s\t%d\n' "$i" "$wall" "$cpu" "$registered" \
      >> "$work/colmap.tsv"
  done
  colmap_ok=1
elif want colmap; then
  echo "== COLMAP not installed (apt-get install colmap; scripts/install-deps.sh bench): skipped"
fi

: > "$work/footprint.tsv"
if want daemon; then
  echo "== monomeshd start-up and footprint (bundled keyframes replayed at 640x480 and 1280x720)"
  # Time from exec to READY (the control socket answers once the camera is open) and the daemon's
  # peak RSS (VmHWM) after three captures reconstructed at that size: the first capture has no
  # frames before A and no preview drawn before it, so the steady state shows from the second.
  captures=3
  for size in 640x480 1280x720; do
    w=${size%x*}; h=${size#*x}
    sx=$(python3 -c "print($w/640)"); sy=$(python3 -c "print($h/480)")
    d="$work/daemon-$size"; mkdir -p "$d"
    python3 - "$root/data/tum_office/calib.toml" "$sx" "$sy" "$w" "$h" > "$d/calib.toml" <<'PY'
import re, sys
text, sx, sy, w, h = open(sys.argv[1]).read(), float(sys.argv[2]), float(sys.argv[3]), sys.argv[4], sys.argv[5]
def scale(key, f):
    global text
    m = re.search(rf"^{key}\s*=\s*\[([^\]]*)\]", text, re.M)
    x, y = (float(v) for v in m.group(1).split(","))
    text = text.replace(m.group(0), f"{key} = [{x * f[0]!r}, {y * f[1]!r}]")
scale("fc", (sx, sy)); scale("cc", (sx, sy))
text = re.sub(r"^image_size\s*=.*$", f"image_size = [{w}, {h}]", text, flags=re.M)
print(text)
PY
    cat > "$d/monomeshd.toml" <<TOML
[camera]
uri = "replay:$root/data/tum_office?rate=realtime&loop=1&width=$w&height=$h"
calibration = "$d/calib.toml"
[control]
socket = "$d/control.sock"
group = ""
[spool]
dir = "$d/spool"
TOML
    start=$(date +%s.%N)
    "$build/firmware-app/monomeshd" --config "$d/monomeshd.toml" 2> "$d/log" &
    pid=$!
    until "$build/firmware-app/monomesh" ctl ping --socket "$d/control.sock" > /dev/null 2>&1; do
      kill -0 $pid 2> /dev/null || { cat "$d/log"; exit 1; }
      sleep 0.005
    done
    ready=$(python3 -c "print($(date +%s.%N) - $start)")
    : > "$d/result.json"
    for ((i = 0; i < captures; i++)); do
      "$build/firmware-app/monomesh" ctl trigger --wait 120 --socket "$d/control.sock" \
        >> "$d/result.json"
    done
    hwm=$(awk '/VmHWM/ {print $2}' /proc/$pid/status)
    kill -TERM $pid; wait $pid || true
    ok=$(grep -c '"ok": true' "$d/result.json" || true)
    printf '%s\t%s\t%s\t%s\t%s\n' "$size" "$ready" "$hwm" "$captures" "$ok" >> "$work/footprint.tsv"
    printf '%s: READY after %.3f s, peak RSS %d MiB (%d MB) over %d captures, %s ok\n' "$size" \
      "$ready" $((hwm / 1024)) $((hwm * 1024 / 1000000)) "$captures" "$ok"
  done
fi

walk_list=keyframes_1hz.txt
if want walk; then
  echo "== monomesh eval --walk --every-frame on $walk_list (one thread)"
  # Wall and CPU (user + sys, getrusage of the child) of the whole process; the JSON holds the
  # walk's own CPU (reading the images and the walk, not the evaluation after it).
  timed "$work/walk_time.txt" "$build/firmware-app/monomesh" eval --walk --every-frame \
    --dataset "$dataset" --calib "$calib" --list "$walk_list" --threads 1 \
    --json "$work/walk.json" --quiet
  if [[ $has_colmap == 1 ]]; then
    echo "== COLMAP incremental mapper on the same keyframes (one thread, CPU)"
    # As the pair section (PINHOLE, intrinsics fixed, one thread, CPU SIFT) but with the mapper's
    # own initialisation angle (16 deg; it relaxes it when no pair passes), seeded.
    colmap_walk "$work/colmap_walk" "$dataset" "$dataset/$walk_list" "$params" \
      > "$work/colmap_walk.json"
    read -r wall cpu < "$work/colmap_walk/time.txt"
    python3 - "$work/colmap_walk.json" "$wall" "$cpu" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
ate = f"ATE {100 * c['ate_rmse_m']:.2f} cm RMSE" if "ate_rmse_m" in c else "no ATE"
print(f"COLMAP: {c['registered']}/{c['total']} registered in the largest of {c['models']} model(s), "
      f"{ate}; {float(sys.argv[2]):.2f} s wall / {float(sys.argv[3]):.2f} s CPU")
PY
  else
    echo "== COLMAP not installed (apt-get install colmap; scripts/install-deps.sh bench): walk skipped"
  fi
fi

if want walk-video && [[ -d "$video" ]]; then
  echo "== monomesh eval --walk on $(basename "$video") (hand-held video; the tracker picks the keyframes; one thread)"
  timed "$work/video_time.txt" "$build/firmware-app/monomesh" eval --walk \
    --dataset "$video" --calib "$video/Calib_Results.m" --threads 1 \
    --json "$work/video.json" --quiet
  # The keyframes it picked, as a TUM list for COLMAP and walk_ate.py.
  python3 - "$work/video.json" "$video" > "$work/video_keyframes.txt" <<'PY'
import json, os, sys
for k in json.load(open(sys.argv[1]))["keyframes"]:
    print(f"{k['timestamp']:.6f} {os.path.relpath(k['image'], sys.argv[2])}")
PY
  if [[ $has_colmap == 1 ]]; then
    echo "== COLMAP incremental mapper on the same keyframes (one thread, CPU)"
    colmap_walk "$work/colmap_video" "$video" "$work/video_keyframes.txt" \
      "$(pinhole_params "$video/Calib_Results.m")" > "$work/colmap_video.json"
  fi
fi

python3 - "$work" "$out" "$colmap_ok" <<'PY'
import json, os, statistics, sys
work, out, colmap_ok = sys.argv[1], sys.argv[2], sys.argv[3] == "1"


def colmap_beside(stem, walk_cpu_s, wall, cpu):
    """COLMAP's walk result (work/STEM.json) with its wall and CPU time (work/STEM/time.txt),
    and its time over monomesh's: the walk's own CPU, the process's CPU and wall."""
    c = json.load(open(f"{work}/{stem}.json"))
    c_wall, c_cpu = (float(v) for v in open(f"{work}/{stem}/time.txt").read().split())
    c.update(wall_s=c_wall, cpu_s=c_cpu)
    return c, {"cpu_walk": c_cpu / walk_cpu_s, "cpu_process": c_cpu / cpu,
               "wall_process": c_wall / wall}


def print_ratios(ratios):
    print(f"ratio COLMAP / monomesh: CPU {ratios['cpu_walk']:.1f}x (walk), "
          f"CPU {ratios['cpu_process']:.1f}x (process), wall {ratios['wall_process']:.1f}x (process)")
result = {}
s = None
if os.path.exists(f"{work}/monomesh.json"):
    mm = json.load(open(f"{work}/monomesh.json"))
    s = mm["summary"]
    result["monomesh"] = {"summary": s,
                          "pairs": [{"a": p["a"], "b": p["b"], "success": p["success"],
                                     "time_s": p["time_s"]} for p in mm["pairs"]]}
if os.path.exists(f"{work}/benchmarks.list"):
    result["benchmarks"] = {}
    for path in open(f"{work}/benchmarks.list").read().split():
        data = json.load(open(path))
        result["benchmarks"][path.rsplit("/", 1)[-1][:-5]] = [
            {"name": b["name"], "real_time": b["real_time"], "cpu_time": b["cpu_time"],
             "time_unit": b["time_unit"]} for b in data["benchmarks"]]
if s or colmap_ok:
    print("\n== Summary (median per pair, one thread)")
if s:
    print(f"monomesh: two images {s['time_s']['median']:.3f} s wall / {s['time_s']['cpu_median']:.3f} s CPU; "
          f"after B {s['time_s']['median_after_b']:.3f} s wall / {s['time_s']['cpu_median_after_b']:.3f} s CPU; "
          f"{s['succeeded']}/{s['pairs']} pairs, rot {s['rot_err_deg']['median']:.3f} deg, "
          f"trans {s['trans_err_deg']['median']:.3f} deg")
if colmap_ok:
    rows = [l.split("\t") for l in open(f"{work}/colmap.tsv").read().splitlines() if l]
    wall = [float(r[1]) for r in rows]
    cpu = [float(r[2]) for r in rows]
    reg = sum(int(r[3]) for r in rows)
    med, med_cpu = statistics.median(wall), statistics.median(cpu)
    result["colmap"] = {"pairs": len(rows), "reconstructed": reg,
                        "time_s": {"median": med, "cpu_median": med_cpu},
                        "per_pair_wall_s": wall, "per_pair_cpu_s": cpu}
    print(f"COLMAP:   {med:.3f} s wall / {med_cpu:.3f} s CPU per pair "
          f"({reg}/{len(rows)} pairs reconstructed)")
    if s:
        ratios = {"wall_two_images": med / s["time_s"]["median"],
                  "cpu_two_images": med_cpu / s["time_s"]["cpu_median"],
                  "cpu_after_b": med_cpu / s["time_s"]["cpu_median_after_b"]}
        result["ratio_colmap_over_monomesh"] = ratios
        print(f"ratio COLMAP / monomesh: wall {ratios['wall_two_images']:.1f}x, "
              f"CPU {ratios['cpu_two_images']:.1f}x (two images), CPU {ratios['cpu_after_b']:.1f}x (after B)")
if os.path.exists(f"{work}/walk.json"):
    # The walk: monomesh's own CPU of the walk (eval's cpu_total_s: images read and walked) and
    # of its whole process (getrusage, with the evaluation after the walk), COLMAP's three commands.
    w = json.load(open(f"{work}/walk.json"))["summary"]["walk"]
    wall, cpu = (float(v) for v in open(f"{work}/walk_time.txt").read().split())
    n = w["frames"]
    # The figures are of the refined map: its refinement after the walk counts with the walk.
    refine_s = w.get("refinement", {}).get("cpu_s", 0.0)
    walk_s = w["cpu_total_s"] + refine_s
    walk = {"monomesh": {**w, "process_wall_s": wall, "process_cpu_s": cpu,
                         "cpu_per_keyframe_s_mean": walk_s / n}}
    print(f"\n== Walk ({n} TUM keyframes, every frame a keyframe, one thread; ATE after Sim(3))")
    print(f"monomesh: {w['registered']}/{n} registered, {w['segments']} segment(s), "
          f"ATE {100 * w['ate_rmse_m']:.2f} cm RMSE; {walk_s:.2f} s CPU walk "
          f"({1e3 * walk_s / n:.0f} ms per keyframe; keyframe median "
          f"{1e3 * w['cpu_per_keyframe_s_median']:.0f} ms, {refine_s:.2f} s the refinement), "
          f"process {wall:.2f} s wall / {cpu:.2f} s CPU")
    if os.path.exists(f"{work}/colmap_walk.json"):
        c, ratios = colmap_beside("colmap_walk", walk_s, wall, cpu)
        c.update(cpu_per_keyframe_s_mean=c["cpu_s"] / c["total"])
        walk["colmap"] = c
        ate = f"ATE {100 * c['ate_rmse_m']:.2f} cm RMSE" if "ate_rmse_m" in c else "no ATE"
        print(f"COLMAP:   {c['registered']}/{c['total']} registered, {c['models']} model(s), {ate}; "
              f"{c['cpu_s']:.2f} s CPU ({c['cpu_s'] / c['total']:.2f} s per keyframe), "
              f"{c['wall_s']:.2f} s wall")
        walk["ratio_colmap_over_monomesh"] = ratios
        print_ratios(ratios)
    result["walk"] = walk
if os.path.exists(f"{work}/video.json"):
    # The walk on hand-held video: the eval's own CPU of the walk (images read, tracked and
    # walked), COLMAP's three commands on the keyframes it picked.
    w = json.load(open(f"{work}/video.json"))["summary"]["walk"]
    wall, cpu = (float(v) for v in open(f"{work}/video_time.txt").read().split())
    # The figures are of the refined map: its refinement after the walk counts with the walk.
    refine_s = w.get("refinement", {}).get("cpu_s", 0.0)
    walk_s = w["cpu_total_s"] + refine_s
    video = {"monomesh": {**w, "process_wall_s": wall, "process_cpu_s": cpu}}
    print(f"\n== Walk on hand-held video ({w['frames']} frames, {w['keyframes']} keyframes picked "
          f"by the tracker; one thread; ATE and scale drift after Sim(3))")
    print(f"monomesh: {w['registered']}/{w['keyframes']} registered, {w['segments']} segment(s), "
          f"ATE {100 * w['ate_rmse_m']:.2f} cm RMSE over {w['path_length_m']:.2f} m "
          f"({100 * w['ate_rmse_m'] / w['path_length_m']:.2f} %), scale drift "
          f"{100 * w['scale_drift']:.1f} % (depth maps {100 * w.get('depth_scale_drift', 0):.1f} %); "
          f"{walk_s:.2f} s CPU walk ({w['cpu_total_s']:.2f} s the walk, keyframe median "
          f"{1e3 * w['cpu_per_keyframe_s_median']:.0f} ms, frame median "
          f"{1e3 * w['cpu_per_frame_s_median']:.1f} ms; {refine_s:.2f} s its refinement), "
          f"process {wall:.2f} s wall / {cpu:.2f} s CPU")
    if os.path.exists(f"{work}/colmap_video.json"):
        c, ratios = colmap_beside("colmap_video", walk_s, wall, cpu)
        video["colmap"] = c
        ate = (f"ATE {100 * c['ate_rmse_m']:.2f} cm RMSE, scale drift "
               f"{100 * c.get('scale_drift', 0):.1f} % (depth maps "
               f"{100 * c.get('depth_scale_drift', 0):.1f} %)") if "ate_rmse_m" in c else "no ATE"
        print(f"COLMAP:   {c['registered']}/{c['total']} registered, {c['models']} model(s), {ate}; "
              f"{c['cpu_s']:.2f} s CPU, {c['wall_s']:.2f} s wall")
        video["ratio_colmap_over_monomesh"] = ratios
        print_ratios(ratios)
    result["walk_video"] = video
result["daemon_footprint"] = [
    {"size": r[0], "time_to_ready_s": float(r[1]), "peak_rss_kib": int(r[2]),
     "captures": int(r[3]), "captures_ok": int(r[4])}
    for r in (l.split("\t") for l in open(f"{work}/footprint.tsv").read().splitlines() if l)]
json.dump(result, open(out, "w"), indent=2)
print(f"written to {out}")
PY
