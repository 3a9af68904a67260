#!/usr/bin/python3
"""bench/accuracy_points.py: the point queries' rows of docs/accuracy.md (issue 18), one command.

    bench/accuracy_points.py [--build build/release] [--points 4000]

1. builds points_accuracy (tests/stress) and the Embree mask shim Open3D needs;
2. runs points_accuracy: distances and signed distances through QueryEngine on each suite,
   judged against the quad-precision reference (tests/stress/point_reference.h);
3. runs Open3D's RaycastingScene.compute_distance and compute_signed_distance on the same
   meshes and points (rounded to float32, which is what it takes), with the shim preloaded (its
   sign comes from rays, which hit nothing without it), judged by the same rules;
4. replaces the point-query section of docs/accuracy.md (between its markers) and leaves the
   rest of the file as bench/accuracy wrote it.

Must run under Debian's /usr/bin/python3 (numpy and open3d are Debian packages).
"""

import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BEGIN = "<!-- point queries: written by bench/accuracy_points.py -->"
END = "<!-- end of point queries -->"
U = 2.0**-53


def judge_open3d(out_dir: str, suite: dict) -> dict:
    """Open3D's distance and sign errors on one suite's files."""
    import numpy as np
    import open3d as o3d

    stem = os.path.join(out_dir, suite["stem"])
    vertices = np.fromfile(stem + "_vertices.f64").reshape(-1, 3)
    triangles = np.fromfile(stem + "_triangles.u32", dtype=np.uint32).reshape(-1, 3)
    points = np.fromfile(stem + "_points.f64").reshape(-1, 3)
    ref = np.fromfile(stem + "_ref.f64").reshape(-1, 3)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(triangles)
    )
    query = o3d.core.Tensor(np.ascontiguousarray(points.astype(np.float32)))
    d = scene.compute_distance(query).numpy().astype(np.float64)
    sd = scene.compute_signed_distance(query).numpy().astype(np.float64)
    scale = np.maximum(np.max(np.abs(vertices)), np.max(np.abs(points), axis=1))
    err = np.abs(d - ref[:, 0])
    far = ref[:, 0] >= 0.1 * scale
    ulps = err[far] / np.spacing(ref[far, 0]) if far.any() else None
    judged = ref[:, 2] != 0
    inside = sd <= 0
    truth = ref[:, 1] > 0.5
    return {
        "max_ulps": float(np.max(ulps)) if ulps is not None else None,
        "max_u_scale": float(np.max(err / (U * scale))),
        "sign_errors": int(np.count_nonzero(inside[judged] != truth[judged])),
    }


def open3d_peer(out_dir: str) -> None:
    import open3d as o3d

    report = json.load(open(os.path.join(out_dir, "points_accuracy.json")))
    results = {s["stem"]: judge_open3d(out_dir, s) for s in report["suites"]}
    json.dump(
        {
            "open3d": o3d.__version__,
            "shim": "embree_mask_shim" in os.environ.get("LD_PRELOAD", ""),
            "suites": results,
        },
        sys.stdout,
    )


def fmt(v) -> str:
    """A number in 3 digits; – for none (no point qualified)."""
    return "–" if v is None else f"{v:.3g}"


def section(report: dict, o3d: dict, args) -> list:
    lines = [
        BEGIN,
        "## Point queries (issue 18)",
        "",
        f"Written by `bench/accuracy_points.py --points {args.points}` (do not edit by hand; "
        "`bench/accuracy` keeps this section as it is). Each suite's points go through "
        "`QueryEngine` (`query_points`: `distance` and `signed_distance`; the point BVH of "
        "`engine/accel/point_bvh.h` above 16 primitives, brute force below) and are judged "
        "against the quad-precision reference of `tests/stress/point_reference.h` (`__float128`, "
        "a method other than the engine's; the winding number by the exact sum of solid angles); "
        f"Open3D {o3d['open3d']}'s `RaycastingScene.compute_distance` / "
        f"`compute_signed_distance` (Embree mask shim preloaded: {o3d['shim']}) gets the same "
        "meshes and points rounded to float32, which is what it takes. scale = the largest "
        f"coordinate magnitude of the point and the mesh; u = 2⁻⁵³. Load average at the start: "
        f"{args.load:.1f}.",
        "",
        "- **ulps**: the error of the engine's distance to the primitive it reports against the "
        "quad distance to that primitive, in ulps of the distance, over points at least 0.1·scale "
        "off the surface (closer to a surface the error is a few u·scale however small the "
        "distance: the next column). Open3D's against the mesh's quad distance.",
        "- **u·scale**: the same error over all points, in units of u·scale (the engine's bound "
        "is 16, docs/numerics.md).",
        "- **answer / bound**: |reported distance − the mesh's quad distance| over the reported "
        "bound; up to 2 is the tie rule (a tie within the bounds goes to the lower primitive, "
        "whose distance may be the larger by both bounds).",
        "- **on surface (wrong)**: points reported at distance 0, and of those the ones farther "
        "from the surface than the bound.",
        "- **signs**: judged points (off the surface, and on a `winding` mesh where the exact "
        "winding number is more than 10⁻² from ½) and the wrong ones.",
        "",
        "| suite | triangles | sign | points | ulps | u·scale | answer / bound | on surface "
        "(wrong) | signs judged | sign errors | Open3D ulps | Open3D u·scale | Open3D sign "
        "errors | ns/point |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in report["suites"]:
        o = o3d["suites"].get(s["stem"], {})
        lines.append(
            f"| {s['suite']} | {s['triangles']} | {s['sign']} | {s['points']} | "
            f"{fmt(s['max_ulps'])} | {fmt(s['max_u_scale'])} | "
            f"{fmt(s['max_error_over_bound'])} | {s['on_surface']} ({s['wrong_on_surface']}) | "
            f"{s['judged_signs']} | {s['sign_errors']} | {fmt(o.get('max_ulps'))} | "
            f"{fmt(o.get('max_u_scale'))} | {o.get('sign_errors', '–')} | "
            f"{s['ns_per_point']:.0f} |"
        )
    worst = max(s["max_ulps"] or 0 for s in report["suites"])
    worst_u = max(s["max_u_scale"] for s in report["suites"])
    errors = sum(s["sign_errors"] for s in report["suites"])
    o3d_errors = sum(o.get("sign_errors", 0) for o in o3d["suites"].values())
    lines += [
        "",
        f"Targets: distance within 4 ulps: worst **{fmt(worst)} ulps** (points ≥ 0.1·scale off "
        f"the surface), **{fmt(worst_u)} u·scale** over all points (bound 16); sign errors "
        f"**{errors}** (target 0, closed meshes and hole cases), Open3D {o3d_errors}. "
        "ns/point is the signed-distance batch on this 2-core machine (points beyond 64 S of "
        "the centre are walked in double with balls around the nodes, which cull less than the "
        "float walk's boxes: docs/numerics.md).",
        "",
        "Reproduce: `scripts/setup.sh --bench && bench/accuracy_points.py` (about a minute).",
        END,
    ]
    return lines


def splice(path: str, lines: list) -> None:
    """Replaces the marked section of `path`, or puts it before "## Targets" if it has none."""
    text = open(path).read() if os.path.exists(path) else ""
    block = "\n".join(lines)
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        text = head + block + rest.split(END, 1)[1]
    elif "\n## Targets" in text:
        head, rest = text.split("\n## Targets", 1)
        text = head + "\n" + block + "\n\n## Targets" + rest
    else:
        text += "\n" + block + "\n"
    with open(path, "w") as f:
        f.write(text)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--points", type=int, default=4000, help="points per suite")
    ap.add_argument("--docs", default=os.path.join(ROOT, "docs"))
    ap.add_argument("--open3d-peer", metavar="DIR", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.open3d_peer:
        open3d_peer(args.open3d_peer)
        return 0
    args.load = os.getloadavg()[0]
    out = os.path.join(args.build, "accuracy_points")
    if not os.path.exists(os.path.join(args.build, "CMakeCache.txt")):
        subprocess.run(["cmake", "--preset", "release"], cwd=ROOT, check=True)
    subprocess.run(
        [
            "cmake",
            "--build",
            args.build,
            "--target",
            "points_accuracy",
            "embree_mask_shim",
        ]
        + [f"-j{os.cpu_count() or 2}"],
        check=True,
    )
    tool = os.path.join(args.build, "tests", "stress", "points_accuracy")
    subprocess.run([tool, "--out", out, "--points", str(args.points)], check=True)
    report = json.load(open(os.path.join(out, "points_accuracy.json")))
    shim = os.path.join(args.build, "bench", "libembree_mask_shim.so")
    peer = subprocess.run(
        ["/usr/bin/python3", os.path.abspath(__file__), "--open3d-peer", out],
        env=dict(os.environ, LD_PRELOAD=shim),
        check=True,
        stdout=subprocess.PIPE,
        text=True,
    )
    splice(
        os.path.join(args.docs, "accuracy.md"),
        section(report, json.loads(peer.stdout), args),
    )
    print(f"wrote the point-query section of {os.path.join(args.docs, 'accuracy.md')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
