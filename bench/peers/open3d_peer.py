#!/usr/bin/python3
"""Open3D peer: RaycastingScene.cast_rays on the mesh and rays bench_intersect wrote.

Reads <data-dir>/<W>_vertices.npy, <W>_triangles.npy, <W>_<rays>_rays.npy (n x 8 float32 records,
ox oy oz dx dy dz tmin tmax; every tmin is 0 and every tmax beyond the scene, so Open3D's
[0, inf) range is the same) and raw Embree's closest hits <W>_<rays>_ref_{t,primitive}.npy, and
prints one JSON object:

  {"workload": "A", "open3d": "0.16.1", "build_ms": ..., "results": [
     {"rays": "coherent", "n": 1048576, "mrays_s": ..., "seconds": ..., "hits": ...,
      "agree_with_embree": ...}, ...]}

Debian's python3-open3d 0.16.1 leaves the Embree ray mask at 0 while Debian's Embree is built
with ray masks, so every ray misses. Run it with LD_PRELOAD=<build>/bench/libembree_mask_shim.so
(bench/peers/embree_mask_shim.c) for real figures; without it, `hits` shows the failure.

Must run under Debian's /usr/bin/python3 (it has numpy and open3d; a pyenv python does not).
"""

import argparse
import json
import os
import statistics
import sys
import time

import numpy as np
import open3d as o3d

INVALID_ID = np.uint32(0xFFFFFFFF)


def load(data_dir: str, name: str) -> np.ndarray:
    return np.load(os.path.join(data_dir, name))


def agreement(
    t: np.ndarray, prim: np.ndarray, ref_t: np.ndarray, ref_prim: np.ndarray
) -> float:
    """Fraction of rays on which Open3D and raw Embree agree: both miss, or both hit the same
    triangle, or (a neighbour across a shared edge) at the same t."""
    hit = np.isfinite(t)
    ref_hit = np.isfinite(ref_t)
    with np.errstate(
        invalid="ignore"
    ):  # inf − inf on rays both miss; those are settled above
        same_t = np.abs(t - ref_t) <= 1e-4 * np.maximum(1.0, np.abs(ref_t))
    agree = (hit == ref_hit) & (~ref_hit | (prim == ref_prim) | same_t)
    return float(np.count_nonzero(agree)) / max(1, len(t))


def bench_rays(
    scene, data_dir: str, workload: str, rays_name: str, reps: int, limit: int
) -> dict:
    stem = f"{workload}_{rays_name}"
    records = load(data_dir, f"{stem}_rays.npy")
    if limit:
        records = records[:limit]
    rays = o3d.core.Tensor(np.ascontiguousarray(records[:, :6]))
    times = []
    result = None
    for _ in range(reps + 1):  # the first call is a warm-up
        start = time.perf_counter()
        result = scene.cast_rays(rays)
        times.append(time.perf_counter() - start)
    seconds = statistics.median(times[1:])
    t = result["t_hit"].numpy()
    prim = result["primitive_ids"].numpy()
    ref_t = load(data_dir, f"{stem}_ref_t.npy")[: len(t)]
    ref_prim = load(data_dir, f"{stem}_ref_primitive.npy")[: len(t)]
    n = len(t)
    return {
        "rays": rays_name,
        "n": n,
        "seconds": seconds,
        "mrays_s": n / seconds * 1e-6,
        "hits": int(np.count_nonzero(np.isfinite(t))),
        "ref_hits": int(np.count_nonzero(np.isfinite(ref_t))),
        "agree_with_embree": agreement(t, prim, ref_t, ref_prim),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", required=True)
    ap.add_argument(
        "--workload", required=True, help="A or B (Open3D takes triangles only)"
    )
    ap.add_argument("--rays", default="coherent,incoherent")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--limit", type=int, default=0, help="use only the first N rays")
    args = ap.parse_args()

    vertices = load(args.data_dir, f"{args.workload}_vertices.npy")
    triangles = load(args.data_dir, f"{args.workload}_triangles.npy")
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(triangles))
    # Open3D commits the Embree scene (builds the BVH) on the first query; a one-ray query is
    # the closest we can get to timing the build alone.
    one = o3d.core.Tensor(
        np.zeros((1, 6), dtype=np.float32) + np.float32([0, 0, 0, 0, 0, 1])
    )
    start = time.perf_counter()
    scene.cast_rays(one)
    build_ms = (time.perf_counter() - start) * 1e3

    out = {
        "workload": args.workload,
        "open3d": o3d.__version__,
        "build_ms": build_ms,
        "mask_shim": "embree_mask_shim" in os.environ.get("LD_PRELOAD", ""),
        "results": [
            bench_rays(scene, args.data_dir, args.workload, r, args.reps, args.limit)
            for r in args.rays.split(",")
        ],
    }
    json.dump(out, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
