#!/usr/bin/python3
"""raycastd's binary points endpoint for bench_points: the same mesh and points as in-process.

Reads <data-dir>/<W>.ply (the mesh), <W>_points.npy (n x 3 float32) and bench_points' own
in-process answers <W>_distance.npy and <W>_signed.npy, starts the raycastd binary on loopback
(peers/http_peer.py: --port 0, TCP_NODELAY, one keep-alive connection), registers the mesh as a
raw PLY body, and posts all the points in the binary form (docs/api.md):

  POST /v1/scenes/{id}/points?query=closest|signed_distance&dtype=float32
  body n x 3 float32; answer n x 32 bytes (closest: px py pz distance object primitive u v) or
  n x 4 bytes (signed_distance)

The bodies are encoded before the clock starts; each call is timed from the request to the last
byte of the answer (the server's decode, query and encode plus loopback transport), the median of
`reps` calls after a warm-up. The server's CPU seconds over the same calls come from its
/proc/<pid>/stat (utime + stime). The points are float32 values already (bench_points rounds
them), so the server sees exactly the in-process points. Prints one JSON object:

  {"workload": "A", "n": ..., "closest": {"seconds": ..., "server_cpu_seconds": ...,
   "mpoints_s": ..., "max_abs_diff": ...}, "signed": {...}}

max_abs_diff compares the float32 distances of the answer with the in-process ones (float32 too):
the PLY carries float32 vertices (bench_files' write_ply), so the server answers for the mesh
rounded to float and differs from in-process by that rounding (~1e-7), not by the query.
Must run under Debian's /usr/bin/python3 (numpy is a Debian package).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from peers import http_peer  # noqa: E402

CLOSEST_DTYPE = np.dtype(
    [
        ("px", "<f4"),
        ("py", "<f4"),
        ("pz", "<f4"),
        ("distance", "<f4"),
        ("object", "<u4"),
        ("primitive", "<u4"),
        ("u", "<f4"),
        ("v", "<f4"),
    ]
)


def cpu_seconds(pid: int) -> float:
    """utime + stime of process `pid` in seconds (all its threads)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    # After the command's closing parenthesis: state is field 3 of stat(5), utime 14, stime 15.
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def timed(server: http_peer.RaycastdServer, conn, path: str, body: bytes, reps: int):
    """Median wall seconds and median server CPU seconds of `reps` calls after a warm-up, and
    the last answer."""
    walls, cpus, data = [], [], b""
    for _ in range(reps + 1):
        c0, t0 = cpu_seconds(server.proc.pid), time.perf_counter()
        status, data, _ = http_peer.post(conn, path, body, "application/octet-stream")
        walls.append(time.perf_counter() - t0)
        cpus.append(cpu_seconds(server.proc.pid) - c0)
        if status != 200:
            raise RuntimeError(f"POST {path}: {status} {http_peer.error_code(data)}")
    return statistics.median(walls[1:]), statistics.median(cpus[1:]), data


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", required=True)
    ap.add_argument("--binary", required=True, help="the raycastd server binary")
    ap.add_argument("--workload", default="A")
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    w = args.workload
    points = np.ascontiguousarray(
        np.load(os.path.join(args.data_dir, f"{w}_points.npy")), dtype="<f4"
    )
    ours = np.load(os.path.join(args.data_dir, f"{w}_distance.npy"))
    ours_signed = np.load(os.path.join(args.data_dir, f"{w}_signed.npy"))
    with open(os.path.join(args.data_dir, f"{w}.ply"), "rb") as f:
        ply = f.read()
    body = points.tobytes()
    n = points.shape[0]
    server = http_peer.RaycastdServer(
        args.binary, os.path.join(args.data_dir, "raycastd_points.log")
    )
    try:
        conn = server.connect()
        scene = http_peer.register(conn, ply, "application/x-ply").scene_id
        out = {"workload": w, "n": int(n)}
        for key, query in (("closest", "closest"), ("signed", "signed_distance")):
            path = f"/v1/scenes/{scene}/points?query={query}&dtype=float32"
            sec, cpu, data = timed(server, conn, path, body, args.reps)
            if key == "closest":
                d = np.frombuffer(data, dtype=CLOSEST_DTYPE)["distance"]
                diff = np.abs(d.astype(np.float64) - ours)
            else:
                d = np.frombuffer(data, dtype="<f4")
                diff = np.abs(d.astype(np.float64) - ours_signed)
            out[key] = {
                "seconds": sec,
                "server_cpu_seconds": cpu,
                "mpoints_s": n / sec * 1e-6,
                "max_abs_diff": float(np.max(diff)) if n else 0.0,
            }
        conn.close()
    finally:
        server.stop()
    json.dump(out, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
