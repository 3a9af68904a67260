#!/usr/bin/python3
"""Open3D peer for the point queries: RaycastingScene.compute_closest_points and
compute_signed_distance on the mesh and points bench_points wrote.

Reads <data-dir>/<W>_vertices.npy, <W>_triangles.npy, <W>_points.npy (n x 3 float32) and
bench_points' own answers <W>_distance.npy and <W>_signed.npy (float64), and prints one JSON
object:

  {"workload": "A", "open3d": "0.16.1", "n": ..., "mask_shim": true,
   "closest": {"seconds": ..., "cpu_seconds": ..., "mpoints_s": ..., "max_abs_diff": ...},
   "signed": {"seconds": ..., "cpu_seconds": ..., "mpoints_s": ..., "max_abs_diff": ...,
              "sign_agree": ...}}

max_abs_diff compares Open3D's float32 distances with raycastd's double ones. The sign comes from
rays (Open3D counts crossings of one ray per point), so run it with
LD_PRELOAD=<build>/bench/libembree_mask_shim.so (bench/peers/embree_mask_shim.c): Debian's
python3-open3d 0.16.1 leaves the Embree ray mask at 0 and its rays hit nothing otherwise.

Must run under Debian's /usr/bin/python3 (numpy and open3d are Debian packages).
"""

import argparse
import json
import os
import statistics
import sys
import time

import numpy as np
import open3d as o3d


def load(data_dir: str, name: str) -> np.ndarray:
    return np.load(os.path.join(data_dir, name))


def timed(f, reps: int) -> tuple:
    """The median wall seconds of `reps` calls after a warm-up, their median CPU seconds (all
    threads of the process), and the last result."""
    times, cpu, result = [], [], None
    for _ in range(reps + 1):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = f()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return statistics.median(times[1:]), statistics.median(cpu[1:]), result


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", required=True)
    ap.add_argument("--workload", default="A")
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    w = args.workload
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(load(args.data_dir, f"{w}_vertices.npy")),
        o3d.core.Tensor(load(args.data_dir, f"{w}_triangles.npy")),
    )
    points = o3d.core.Tensor(
        np.ascontiguousarray(load(args.data_dir, f"{w}_points.npy"))
    )
    ours = load(args.data_dir, f"{w}_distance.npy")
    ours_signed = load(args.data_dir, f"{w}_signed.npy")
    n = points.shape[0]

    sec_c, cpu_c, closest = timed(
        lambda: scene.compute_closest_points(points), args.reps
    )
    p = closest["points"].numpy().astype(np.float64)
    d = np.linalg.norm(p - points.numpy().astype(np.float64), axis=1)
    sec_s, cpu_s, signed = timed(
        lambda: scene.compute_signed_distance(points), args.reps
    )
    s = signed.numpy().astype(np.float64)
    out = {
        "workload": w,
        "open3d": o3d.__version__,
        "n": int(n),
        "mask_shim": "embree_mask_shim" in os.environ.get("LD_PRELOAD", ""),
        "closest": {
            "seconds": sec_c,
            "cpu_seconds": cpu_c,
            "mpoints_s": n / sec_c * 1e-6,
            "max_abs_diff": float(np.max(np.abs(d - ours))),
        },
        "signed": {
            "seconds": sec_s,
            "cpu_seconds": cpu_s,
            "mpoints_s": n / sec_s * 1e-6,
            "max_abs_diff": float(np.max(np.abs(np.abs(s) - np.abs(ours_signed)))),
            "sign_agree": float(np.mean(np.sign(s) == np.sign(ours_signed))),
        },
    }
    json.dump(out, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
