#!/usr/bin/python3
"""COLMAP's feature_extractor, exhaustive_matcher and mapper on DIR/images, one thread on the
CPU, with a PINHOLE camera whose intrinsics stay fixed (bench/run.sh's peer, the same settings
for its pair and walk sections). Writes the model under DIR/sparse, the commands' output to
DIR/log.txt, and prints "WALL_S CPU_S": wall time and the CPU (user + sys, getrusage) of the
three commands.

  bench/colmap_sfm.py DIR "fx,fy,cx,cy" [--random-seed N] [-- MAPPER_OPTION ...]
"""
import argparse
import resource
import subprocess
import time


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir")
    parser.add_argument("params", help="PINHOLE fx,fy,cx,cy")
    parser.add_argument("--random-seed", type=int, help="passed to every command")
    parser.add_argument("mapper_options", nargs="*", help="more options of `colmap mapper`")
    args = parser.parse_args()
    d = args.dir
    cmds = [
        ["colmap", "feature_extractor", "--database_path", f"{d}/db.db",
         "--image_path", f"{d}/images", "--ImageReader.camera_model", "PINHOLE",
         "--ImageReader.single_camera", "1", "--ImageReader.camera_params", args.params,
         "--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads", "1"],
        ["colmap", "exhaustive_matcher", "--database_path", f"{d}/db.db",
         "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", "1"],
        ["colmap", "mapper", "--database_path", f"{d}/db.db", "--image_path", f"{d}/images",
         "--output_path", f"{d}/sparse", "--Mapper.num_threads", "1",
         "--Mapper.ba_refine_focal_length", "0", "--Mapper.ba_refine_principal_point", "0",
         "--Mapper.ba_refine_extra_params", "0"] + args.mapper_options,
    ]
    seed = ["--random_seed", str(args.random_seed)] if args.random_seed is not None else []
    start = time.monotonic()
    with open(f"{d}/log.txt", "w") as log:
        for c in cmds:
            if subprocess.run(c + seed, stdout=log, stderr=subprocess.STDOUT).returncode != 0:
                break
    wall = time.monotonic() - start
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"{wall:.4f} {ru.ru_utime + ru.ru_stime:.4f}")


if __name__ == "__main__":
    main()
