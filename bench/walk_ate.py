#!/usr/bin/env python3
"""Absolute trajectory error of a COLMAP model against a TUM ground truth, as `monomesh eval --walk`.

Reads the text models (images.txt of each `colmap model_converter --output_type TXT` folder),
takes the one with the most registered images, matches the image names to the list's
timestamps, and aligns the camera centres to the ground truth by a Sim(3) (Umeyama 1991: least
squares rotation, translation and scale; the rotation found here by Horn's 1987 quaternion
method, which solves the same problem, so that no numpy is needed). Ground truth at a keyframe:
linear interpolation of the two bracketing poses, the nearest one within 0.1 s at the ends (as
Trajectory::WorldFromCamAt). Scale drift as `monomesh eval --walk`: |s_last / s_first - 1| of
the Sim(3) scales fitted to the first and to the last third of the keyframes; where the dataset
has depth maps (depth.txt, value / 5000 m, within 0.02 s of a keyframe), the same from them
(`depth_scale_drift`): per image the median of depth-map depth / model depth at its
observations, the median of that over each third. Prints JSON.

Usage: bench/walk_ate.py --dataset DIR --list FILE MODEL_TXT_DIR...
       bench/walk_ate.py --self-test
"""
import argparse
import bisect
import json
import math
import os
import random
import sys

MAX_GT_DT_S = 0.1  # As WalkEvalOptions::max_gt_dt_s.
MAX_DEPTH_DT_S = 0.02  # As WalkEvalOptions::max_depth_dt_s.


def read_list(path):
    """{image file name: timestamp} of a TUM list (`timestamp path` lines)."""
    names = {}
    for line in open(path):
        f = line.split()
        if not f or f[0].startswith("#"):
            continue
        names[os.path.basename(f[1])] = float(f[0])
    return names


def read_groundtruth(path):
    rows = []
    for line in open(path):
        f = line.replace(",", " ").split()
        if not f or f[0].startswith("#"):
            continue
        rows.append((float(f[0]), [float(v) for v in f[1:4]]))
    rows.sort()
    return rows


def position_at(gt, t):
    times = [r[0] for r in gt]
    i = bisect.bisect_left(times, t)
    if i == 0 or i == len(gt):
        near = gt[0] if i == 0 else gt[-1]
        return near[1] if abs(near[0] - t) <= MAX_GT_DT_S else None
    (ta, a), (tb, b) = gt[i - 1], gt[i]
    s = (t - ta) / (tb - ta) if tb > ta else 0.0
    return [(1 - s) * x + s * y for x, y in zip(a, b)]


def quat_to_rot(w, x, y, z):
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]


def read_images_txt(path):
    """{name: (R, t, [(x, y, point3D id)])} of an images.txt: R, t cam_from_world from QW QX QY
    QZ TX TY TZ, and the image's 2-D points from the line after it (possibly none)."""
    images = {}
    lines = [l for l in open(path).read().split("\n") if not l.startswith("#")]
    i = 0
    while i < len(lines):
        f = lines[i].split()
        if len(f) < 10:
            i += 1
            continue
        qw, qx, qy, qz, tx, ty, tz = (float(v) for v in f[1:8])
        o = lines[i + 1].split() if i + 1 < len(lines) else []
        points = [(float(o[j]), float(o[j + 1]), int(o[j + 2])) for j in range(0, len(o) - 2, 3)]
        images[" ".join(f[9:])] = (quat_to_rot(qw, qx, qy, qz), (tx, ty, tz), points)
        i += 2
    return images


def centre_of(image):
    """Camera centre C = -R^T t of an images.txt entry."""
    r, t, _ = image
    return [-sum(r[k][j] * t[k] for k in range(3)) for j in range(3)]


def read_points3d(model_dir):
    """{point3D id: [X, Y, Z]} of a text model's points3D.txt."""
    points = {}
    for line in open(os.path.join(model_dir, "points3D.txt")):
        f = line.split()
        if f and not f[0].startswith("#"):
            points[int(f[0])] = [float(v) for v in f[1:4]]
    return points


def model_depths(points, image):
    """[(x, y, depth in the camera)] of an image's observations of the model's `points`."""
    r, t, observations = image
    out = []
    for x, y, pid in observations:
        p = points.get(pid)
        if p is not None:
            out.append((x, y, sum(r[2][k] * p[k] for k in range(3)) + t[2]))
    return out


def median(values):
    """The upper median (base/stats.h's MedianOf); None for no values."""
    values = sorted(values)
    return values[len(values) // 2] if values else None


def depth_scale(dataset, depth_list, t, obs):
    """Median of depth-map depth / model depth at the observations; None without a depth map."""
    from PIL import Image  # Only with depth maps (python3-pil, scripts/deps/bench.txt).
    near = min(depth_list, key=lambda d: abs(d[0] - t), default=None)
    if near is None or abs(near[0] - t) > MAX_DEPTH_DT_S:
        return None
    depth = Image.open(os.path.join(dataset, near[1]))
    ratios = []
    for x, y, z in obs:
        u, v = round(x), round(y)
        if z <= 0 or not (0 <= u < depth.width and 0 <= v < depth.height):
            continue
        d = depth.getpixel((u, v)) / 5000.0
        if d > 0:
            ratios.append(d / z)
    return median(ratios)


def jacobi_eigen(a):
    """Eigenvalues and eigenvectors (columns) of a small symmetric matrix, cyclic Jacobi."""
    n = len(a)
    a = [row[:] for row in a]
    v = [[float(i == j) for j in range(n)] for i in range(n)]
    for _ in range(100):
        off = sum(a[i][j] ** 2 for i in range(n) for j in range(n) if i != j)
        if off < 1e-30:
            break
        for p in range(n):
            for q in range(p + 1, n):
                if abs(a[p][q]) < 1e-300:
                    continue
                theta = (a[q][q] - a[p][p]) / (2 * a[p][q])
                t = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1))
                c = 1 / math.sqrt(t * t + 1)
                s = t * c
                for k in range(n):  # A <- A J
                    akp, akq = a[k][p], a[k][q]
                    a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(n):  # A <- J^T A
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
                for k in range(n):  # V <- V J
                    vkp, vkq = v[k][p], v[k][q]
                    v[k][p], v[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    return [a[i][i] for i in range(n)], v


def align_sim3(src, dst):
    """Scale c, rotation R, translation t minimising sum |c R src + t - dst|^2 (Umeyama 1991)."""
    n = len(src)
    ms = [sum(p[k] for p in src) / n for k in range(3)]
    md = [sum(p[k] for p in dst) / n for k in range(3)]
    xs = [[p[k] - ms[k] for k in range(3)] for p in src]
    xd = [[p[k] - md[k] for k in range(3)] for p in dst]
    m = [[sum(a[i] * b[j] for a, b in zip(xs, xd)) for j in range(3)] for i in range(3)]
    (sxx, sxy, sxz), (syx, syy, syz), (szx, szy, szz) = m
    # Horn 1987: the unit quaternion maximising sum d . R s is N's top eigenvector.
    big_n = [[sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
             [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
             [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
             [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz]]
    values, vectors = jacobi_eigen(big_n)
    top = max(range(4), key=lambda i: values[i])
    r = quat_to_rot(*(vectors[k][top] for k in range(4)))
    # Umeyama's scale: tr(DS) / sigma_src^2, and tr(DS) = max sum d . R s = N's top eigenvalue.
    c = values[top] / sum(v * v for p in xs for v in p)
    t = [md[i] - c * sum(r[i][k] * ms[k] for k in range(3)) for i in range(3)]
    return c, r, t


def ate(src, dst):
    c, r, t = align_sim3(src, dst)
    err = [math.dist([c * sum(r[i][k] * s[k] for k in range(3)) + t[i] for i in range(3)], d)
           for s, d in zip(src, dst)]
    return math.sqrt(sum(e * e for e in err) / len(err)), max(err), c


def self_test():
    rng = random.Random(17)
    dst = [[rng.uniform(-2, 2) for _ in range(3)] for _ in range(17)]
    a = rng.uniform(0, math.pi)
    axis = [rng.gauss(0, 1) for _ in range(3)]
    norm = math.sqrt(sum(v * v for v in axis))
    w, (x, y, z) = math.cos(a / 2), (math.sin(a / 2) * v / norm for v in axis)
    r = quat_to_rot(w, x, y, z)
    # src = R^T (dst - t) / 3: dst = 3 R src + t, exactly.
    src = [[sum(r[k][i] * (d[k] - [0.5, -1, 2][k]) for k in range(3)) / 3 for i in range(3)]
           for d in dst]
    rmse, worst, c = ate(src, dst)
    assert rmse < 1e-9 and abs(c - 3) < 1e-9, (rmse, c)
    # A mirrored trajectory has no exact rotation: the error must stay large.
    assert ate([[-p[0], p[1], p[2]] for p in src], dst)[0] > 0.1
    print("walk_ate self-test: ok")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dataset")
    ap.add_argument("--list")
    ap.add_argument("--self-test", action="store_true")
    ap.add_argument("models", nargs="*")
    args = ap.parse_args()
    if args.self_test:
        return self_test()
    names = read_list(os.path.join(args.dataset, args.list))
    models = [read_images_txt(os.path.join(d, "images.txt")) for d in args.models]
    best_index = max(range(len(models)), key=lambda i: len(models[i])) if models else None
    best = models[best_index] if models else {}
    gt = read_groundtruth(os.path.join(args.dataset, "groundtruth.txt"))
    src, dst, order = [], [], []
    for name in sorted((n for n in best if n in names), key=names.get):
        p = position_at(gt, names[name])
        if p is not None:
            src.append(centre_of(best[name]))
            dst.append(p)
            order.append(name)
    out = {"total": len(names), "models": len(models), "registered": len(best),
           "evaluated": len(src)}
    if len(src) >= 3:
        rmse, worst, c = ate(src, dst)
        out.update(ate_rmse_m=rmse, ate_max_m=worst, sim3_scale=c,
                   path_length_m=sum(math.dist(a, b) for a, b in zip(dst, dst[1:])))
        # Scale drift as the eval's: the Sim(3) scales of the first and the last third.
        third = len(src) // 3
        if third >= 3:
            first = align_sim3(src[:third], dst[:third])[0]
            last = align_sim3(src[-third:], dst[-third:])[0]
            out.update(scale_drift=abs(last / first - 1))
        depth_txt = os.path.join(args.dataset, "depth.txt")
        if third >= 3 and os.path.exists(depth_txt):
            depth_list = [(float(f[0]), f[1]) for f in (l.split() for l in open(depth_txt))
                          if len(f) >= 2 and not f[0].startswith("#")]
            points = read_points3d(args.models[best_index])
            scales = [depth_scale(args.dataset, depth_list, names[n],
                                  model_depths(points, best[n])) for n in order]

            def third_median(values):
                values = [v for v in values if v is not None]
                return median(values) if len(values) >= 3 else None

            first, last = third_median(scales[:third]), third_median(scales[-third:])
            if first and last:
                out.update(depth_scale_drift=abs(last / first - 1))
    json.dump(out, sys.stdout)
    print()


if __name__ == "__main__":
    main()
