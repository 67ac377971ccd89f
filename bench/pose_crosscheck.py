#!/usr/bin/env python3
"""How far the ground truth of an RGB-D sequence can be trusted for a relative pose.

For each pair (A, B) of a TUM-format RGB-D sequence, three relative rotations cam_b_from_cam_a:
  - the ground truth (groundtruth.txt, poses world_from_cam as TUM: t then q xyzw);
  - ours: `monomesh recon A B` (SIFT, RANSAC F, E, BA; images.txt of the output);
  - an RGB-D pose without epipolar geometry: OpenCV SIFT matches from A to B (ratio 0.8), A's
    depth lifting them to metres, solvePnPRansac (1.5 px) and solvePnPRefineLM.
and the three pairwise angles. If the errors were independent, each method's and the ground
truth's share follows from the three (s_gt^2 = (d_og^2 + d_pg^2 - d_op^2) / 2, and so on).
Needs python3-opencv and numpy (Debian packages), not part of the build or CI.

Usage: bench/pose_crosscheck.py --dataset DIR --calib FILE --monomesh BIN --pairs A:B[,A:B...]
       (A and B as rgb.txt timestamps) [--work DIR]
"""
import argparse
import os
import subprocess
import sys

import cv2
import numpy as np


def rotation_from_quaternion(w, x, y, z):
    n = np.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def angle_deg(r):
    return float(np.degrees(np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1))))


def read_list(path):
    """timestamp -> file, from a TUM list (rgb.txt, depth.txt)."""
    out = {}
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        t, f = line.split()[:2]
        out[t] = f
    return out


def read_ground_truth(path):
    """timestamp -> rotation world_from_cam."""
    out = {}
    for line in open(path):
        if line.startswith('#') or not line.strip():
            continue
        v = line.split()
        qx, qy, qz, qw = map(float, v[4:8])
        out[round(float(v[0]), 6)] = rotation_from_quaternion(qw, qx, qy, qz)
    return out


def ours(monomesh, image_a, image_b, calib, out):
    """cam_b_from_cam_a from `monomesh recon` (images.txt: cam_from_world per image)."""
    if not os.path.exists(os.path.join(out, 'images.txt')):
        subprocess.run([monomesh, 'recon', image_a, image_b, '--calib', calib, '--out', out,
                        '--mesh-mode', 'sparse'], capture_output=True, check=False)
    path = os.path.join(out, 'images.txt')
    if not os.path.exists(path):
        return None
    rotations = []
    for line in open(path):
        v = line.split()
        if line.startswith('#') or len(v) != 10:
            continue
        rotations.append(rotation_from_quaternion(*map(float, v[1:5])))
    return rotations[1] @ rotations[0].T


def rgbd_pnp(image_a, image_b, depth_a, k, depth_scale):
    sift = cv2.SIFT_create()
    gray_a = cv2.imread(image_a, cv2.IMREAD_GRAYSCALE)
    gray_b = cv2.imread(image_b, cv2.IMREAD_GRAYSCALE)
    depth = cv2.imread(depth_a, cv2.IMREAD_UNCHANGED).astype(float) / depth_scale
    kp_a, desc_a = sift.detectAndCompute(gray_a, None)
    kp_b, desc_b = sift.detectAndCompute(gray_b, None)
    pairs = cv2.BFMatcher().knnMatch(desc_a, desc_b, k=2)
    obj, img = [], []
    for pair in pairs:
        if len(pair) < 2 or pair[0].distance >= 0.8 * pair[1].distance:
            continue
        u, v = kp_a[pair[0].queryIdx].pt
        z = depth[int(round(v)), int(round(u))]
        if z <= 0:
            continue
        obj.append([(u - k[0, 2]) / k[0, 0] * z, (v - k[1, 2]) / k[1, 1] * z, z])
        img.append(kp_b[pair[0].trainIdx].pt)
    obj, img = np.array(obj), np.array(img)
    ok, rvec, tvec, inliers = cv2.solvePnPRansac(obj, img, k, None, reprojectionError=1.5,
                                                 iterationsCount=1000, confidence=0.999)
    if not ok:
        return None, 0
    rvec, tvec = cv2.solvePnPRefineLM(obj[inliers[:, 0]], img[inliers[:, 0]], k, None, rvec, tvec)
    return cv2.Rodrigues(rvec)[0], len(inliers)


def read_k(calib):
    """fc and cc from a Bouguet Calib_Results.m."""
    values = {}
    for line in open(calib):
        line = line.strip()
        for name in ('fc', 'cc'):
            if line.startswith(name + ' = [') and name not in values:
                inner = line[line.index('[') + 1:line.index(']')].replace(';', ' ')
                values[name] = [float(x) for x in inner.split()]
    return np.array([[values['fc'][0], 0, values['cc'][0]], [0, values['fc'][1], values['cc'][1]],
                     [0, 0, 1]])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--dataset', required=True)
    parser.add_argument('--calib', required=True, help='Calib_Results.m of the sequence')
    parser.add_argument('--monomesh', required=True)
    parser.add_argument('--pairs', required=True)
    parser.add_argument('--depth-scale', type=float, default=5000.0)
    parser.add_argument('--work', default='/tmp/pose_crosscheck')
    args = parser.parse_args()
    rgb = read_list(os.path.join(args.dataset, 'rgb.txt'))
    depth = read_list(os.path.join(args.dataset, 'depth.txt'))
    truth = read_ground_truth(os.path.join(args.dataset, 'groundtruth.txt'))
    k = read_k(args.calib)
    rows = []
    for pair in args.pairs.split(','):
        a, b = pair.split(':')
        image_a, image_b = (os.path.join(args.dataset, rgb[t]) for t in (a, b))
        gt = truth[round(float(b), 6)].T @ truth[round(float(a), 6)]
        est = ours(args.monomesh, image_a, image_b, args.calib,
                   os.path.join(args.work, f'{a}_{b}'))
        pnp, inliers = rgbd_pnp(image_a, image_b, os.path.join(args.dataset, depth[a]), k,
                                args.depth_scale)
        if est is None or pnp is None:
            print(f'{a} -> {b}: {"ours" if est is None else "RGB-D PnP"} failed')
            continue
        row = (angle_deg(est @ gt.T), angle_deg(pnp @ gt.T), angle_deg(est @ pnp.T))
        rows.append(row)
        print(f'{a} -> {b}: rotation {angle_deg(gt):.2f} deg; ours-gt {row[0]:.3f}, '
              f'pnp-gt {row[1]:.3f}, ours-pnp {row[2]:.3f} deg ({inliers} PnP inliers)')
    if not rows:
        return 1
    og, pg, op = (float(np.median([r[i] for r in rows])) for i in range(3))
    share = lambda x, y, z: float(np.sqrt(max((x * x + y * y - z * z) / 2, 0)))
    print(f'medians over {len(rows)} pairs: ours-gt {og:.3f}, pnp-gt {pg:.3f}, ours-pnp {op:.3f} '
          f'deg; as independent errors: ground truth {share(og, pg, op):.2f}, ours '
          f'{share(og, op, pg):.2f}, RGB-D PnP {share(pg, op, og):.2f} deg')
    return 0


if __name__ == '__main__':
    sys.exit(main())
