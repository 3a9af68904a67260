#!/usr/bin/python3
"""Runs every benchmark side by side in one run and writes docs/benchmarks.md.

    bench/run_all.py            full size (1M rays; ~80k and ~1M triangles; 1000 spheres)
    bench/run_all.py --quick    small sizes; writes <build>/bench/benchmarks-quick.md

Builds nothing: it runs what `cmake --build build/release` made (bench_intersect, bench_points,
bench_http_load, libembree_mask_shim.so, server/raycastd) and the Open3D peer. In order:
  1. bench_intersect: raw Embree (the ceiling) and the engine in-process; writes the meshes,
     rays and raw Embree's hits to <build>/bench/data-<preset>/ (never committed);
  2. raycastd over HTTP on loopback: the real binary with --port 0, meshes registered as raw
     PLY bodies, binary float32 requests of the whole ray set and JSON requests of 10k rays on
     one keep-alive connection; then many one-ray requests on 16 keep-alive connections;
  3. Open3D's RaycastingScene.cast_rays with the Embree mask shim preloaded (and once without,
     on a sample, to show why the shim is needed);
  4. (issue 6's run time against error per precision is bench/accuracy, a command of its own;
     the report points to its docs/accuracy.md);
  5. bench_points (issue 18): the topology's share of a registration, and closest points and
     signed distances in-process, over the binary endpoint and through Open3D on A, B and shells
     about them (it runs its peers itself).
Must run under Debian's /usr/bin/python3 (numpy and open3d are Debian packages).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
import traceback

import numpy as np

BENCH_DIR = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(BENCH_DIR)
sys.path.insert(0, BENCH_DIR)

import report_md  # noqa: E402
from peers import http_peer  # noqa: E402

PRESETS = {
    # http_budget_s: per HTTP measurement; json_rays: most rays sent as JSON per ray set;
    # load_s: duration of the small-request test.
    "full": {"flag": [], "http_budget_s": 6.0, "json_rays": 200_000, "load_s": 5.0},
    "quick": {
        "flag": ["--quick"],
        "http_budget_s": 1.5,
        "json_rays": 20_000,
        "load_s": 2.0,
    },
}
JSON_BATCH = 10_000
LOAD_CONNECTIONS = 16
SMALL_REQUEST_RUNS = 3  # median of this many load runs
MESH_WORKLOADS = ("A", "B")  # Open3D takes triangles only


def log(msg: str) -> None:
    print(f"[run_all {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def need(path: str) -> str:
    if not os.path.exists(path):
        sys.exit(
            f"run_all: {path} is missing; build first: "
            "cmake --preset release && cmake --build build/release -j2"
        )
    return path


def machine_info() -> dict:
    model = "unknown CPU"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    git = subprocess.run(
        ["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
        capture_output=True,
        text=True,
    ).stdout.strip()
    dirty = (
        subprocess.run(
            ["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
        ).stdout.strip()
        != ""
    )
    return {
        "cpu": model,
        "cores": os.cpu_count(),
        "kernel": platform.release(),
        "python": platform.python_version(),
        "commit": git,
        "dirty": dirty,
        "loadavg_start": os.getloadavg(),
    }


def wait_for_quiet(minutes: float) -> None:
    deadline = time.time() + 60 * minutes
    while time.time() < deadline and os.getloadavg()[0] >= 1.0:
        log(f"load average {os.getloadavg()[0]:.2f}: waiting for a quieter machine")
        time.sleep(15)


# --- 1. raw Embree and the engine in-process ---------------------------------------------------


def run_inprocess(build: str, preset: str, data_dir: str) -> dict:
    out_json = os.path.join(data_dir, "inproc.json")
    cmd = [
        need(os.path.join(build, "bench", "bench_intersect")),
        *PRESETS[preset]["flag"],
        "--data-dir",
        data_dir,
        "--json",
        out_json,
    ]
    log(" ".join(cmd))
    proc = subprocess.run(cmd)
    if proc.returncode != 0 and not os.path.exists(out_json):
        sys.exit(f"run_all: bench_intersect failed ({proc.returncode})")
    with open(out_json) as f:
        doc = json.load(f)
    doc["meta"]["exit_code"] = proc.returncode
    return doc


# --- 2. raycastd over HTTP ---------------------------------------------------------------------


def load_rays(data_dir: str, workload: str, rays: str) -> tuple[np.ndarray, dict]:
    stem = os.path.join(data_dir, f"{workload}_{rays}")
    records = np.load(stem + "_rays.npy")
    ref = {k: np.load(f"{stem}_ref_{k}.npy") for k in ("t", "object", "primitive")}
    return records, ref


def scene_body(data_dir: str, workload: str) -> tuple[bytes, str]:
    ply = os.path.join(data_dir, f"{workload}.ply")
    if os.path.exists(ply):
        with open(ply, "rb") as f:
            return f.read(), "application/x-ply"
    with open(os.path.join(data_dir, f"{workload}_scene.json"), "rb") as f:
        return f.read(), "application/json"


def trace_row(workload: str, rays: str, variant: str, t: http_peer.Timing) -> dict:
    return {
        "kind": "trace",
        "workload": workload,
        "rays": rays,
        "peer": "http",
        "variant": variant,
        "mode": "closest",
        "precision": "fast",
        "mrays_s": t.mrays_s,
        "measured_rays": t.rays,
        "total_rays": t.total,
        "sampled": t.sampled,
        "hits_per_ray": t.hits / max(1, t.rays),
        "agree_with_embree": t.agree,
        "answered_precision": t.precision,
    }


def unavailable(workload: str, rays: str, peer: str, variant: str, reason: str) -> dict:
    log(f"{workload} {rays} {peer} {variant}: not available ({reason})")
    return {
        "kind": "unavailable",
        "workload": workload,
        "rays": rays,
        "peer": peer,
        "variant": variant,
        "reason": reason,
    }


def run_http(
    build: str, preset: str, data_dir: str, workloads: list[str]
) -> tuple[list, dict]:
    cfg = PRESETS[preset]
    rows: list[dict] = []
    load: dict = {}
    server = http_peer.RaycastdServer(
        need(os.path.join(build, "server", "raycastd")),
        os.path.join(data_dir, "raycastd.log"),
    )
    log(f"raycastd on port {server.port}")
    conn = None
    try:
        conn = server.connect()
        scene_ids = {}
        for w in workloads:
            body, content_type = scene_body(data_dir, w)
            try:
                reg = http_peer.register(conn, body, content_type)
            # The server may not load this form yet: note it and go on without it.
            except Exception as e:
                rows.append(unavailable(w, "-", "http", "POST /v1/scenes", str(e)))
                conn = server.connect()
                continue
            scene_ids[w] = reg.scene_id
            rows.append(
                {
                    "kind": "build",
                    "workload": w,
                    "peer": "http",
                    "variant": f"POST /v1/scenes ({content_type}), wall clock",
                    "ms": reg.seconds * 1e3,
                }
            )
            rows.append(
                {
                    "kind": "build",
                    "workload": w,
                    "peer": "http",
                    "variant": "server-reported build_ms",
                    "ms": reg.build_ms,
                }
            )
            before = measure_ceiling(build, preset, w)
            traced, conn = trace_over_http(server, conn, w, reg.scene_id, data_dir, cfg)
            rows += paired(traced, before, measure_ceiling(build, preset, w))
        if "A" in scene_ids:
            load = run_small_requests(
                build, server.port, scene_ids["A"], data_dir, cfg["load_s"]
            )
    finally:
        # An open keep-alive connection holds a server worker until it times out: close it first.
        if conn is not None:
            conn.close()
        server.stop()
    return rows, load


def trace_over_http(
    server: http_peer.RaycastdServer,
    conn,
    w: str,
    scene_id: str,
    data_dir: str,
    cfg: dict,
) -> tuple[list[dict], object]:
    """Binary and JSON closest-hit requests for both ray sets of workload w. Returns the rows
    and the connection to go on with (a new one after an error broke the old)."""
    rows = []
    for r in report_md.RAYS:
        records, ref = load_rays(data_dir, w, r)
        for variant, fn, kwargs in (
            ("binary float32 curl", http_peer.bench_binary_curl, {}),
            ("binary float32", http_peer.bench_binary, {}),
            (
                "JSON",
                http_peer.bench_json,
                {"batch": JSON_BATCH, "max_rays": cfg["json_rays"]},
            ),
        ):
            try:
                t = fn(conn, scene_id, records, ref, cfg["http_budget_s"], **kwargs)
            except http_peer.NotAvailable as e:
                rows.append(unavailable(w, r, "http", variant, str(e)))
                continue
            except Exception as e:
                rows.append(unavailable(w, r, "http", variant, f"error: {e}"))
                conn = server.connect()
                continue
            rows.append(trace_row(w, r, variant, t))
            log(
                f"{w} {r} http {variant}: {t.mrays_s:.3f} Mrays/s "
                f"({t.rays} rays, agree {t.agree:.4f})"
            )
    return rows, conn


def measure_ceiling(build: str, preset: str, workload: str) -> dict[str, float]:
    """Raw rtcIntersect1 Mrays/s per ray set of `workload`, timed now (bench_intersect
    --ceiling-only; a few seconds). Empty if it fails."""
    cmd = [
        os.path.join(build, "bench", "bench_intersect"),
        *PRESETS[preset]["flag"],
        "--ceiling-only",
        "--workloads",
        workload,
        "--json",
        os.path.join(build, "bench", f"data-{preset}", "ceiling.json"),
    ]
    if subprocess.run(cmd, capture_output=True).returncode != 0:
        return {}
    with open(cmd[-1]) as f:
        doc = json.load(f)
    return {r["rays"]: r["mrays_s"] for r in doc["rows"] if r["kind"] == "trace"}


def paired(rows: list[dict], before: dict, after: dict) -> list[dict]:
    """Gives each trace row the ceiling timed right before and after it (their mean), so that
    its ratio compares figures taken under the same load on this shared machine."""
    for r in rows:
        if r["kind"] == "trace" and r["rays"] in before and r["rays"] in after:
            r["paired_ceiling_mrays_s"] = 0.5 * (before[r["rays"]] + after[r["rays"]])
    return rows


def run_small_requests(
    build: str, port: int, scene_id: str, data_dir: str, seconds: float
) -> dict:
    """One ray per request (a camera ray that hits), JSON, 16 keep-alive connections."""
    records, ref = load_rays(data_dir, "A", "coherent")
    i = int(np.argmax(np.isfinite(ref["t"])))
    body_path = os.path.join(data_dir, "small_request.json")
    with open(body_path, "wb") as f:
        f.write(http_peer.json_body(records[i : i + 1], "closest", "fast"))
    cmd = [
        need(os.path.join(build, "bench", "bench_http_load")),
        "--port",
        str(port),
        "--path",
        f"/v1/scenes/{scene_id}/intersect",
        "--body-file",
        body_path,
        "--connections",
        str(LOAD_CONNECTIONS),
        "--seconds",
        str(seconds),
    ]
    log(" ".join(cmd))
    # Three runs, the median kept (as for the binary requests): one run on this shared 2-core
    # machine moved by ±20% from run to run. Every run's figure is kept in "runs".
    runs = []
    for _ in range(SMALL_REQUEST_RUNS):
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            return {"error": proc.stderr.strip()}
        runs.append(json.loads(proc.stdout))
        log(f"small requests: {runs[-1]['req_s']:.0f} req/s ({runs[-1]['statuses']})")
    result = sorted(runs, key=lambda r: r["req_s"])[len(runs) // 2]
    result["runs"] = [r["req_s"] for r in runs]
    return result


# --- 3. Open3D ---------------------------------------------------------------------------------


def run_open3d(
    build: str, preset: str, data_dir: str, workloads: list[str]
) -> tuple[list, dict]:
    peer = os.path.join(BENCH_DIR, "peers", "open3d_peer.py")
    shim = need(os.path.join(build, "bench", "libembree_mask_shim.so"))
    rows: list[dict] = []
    check: dict = {}
    for w in workloads:
        if w not in MESH_WORKLOADS:
            continue
        env = dict(os.environ, LD_PRELOAD=shim)
        before = measure_ceiling(build, preset, w)
        proc = subprocess.run(
            ["/usr/bin/python3", peer, "--data-dir", data_dir, "--workload", w],
            env=env,
            capture_output=True,
            text=True,
        )
        if proc.returncode != 0:
            reason = (proc.stderr.strip().splitlines() or ["failed"])[-1]
            rows.append(unavailable(w, "-", "open3d", "cast_rays", reason))
            continue
        doc = json.loads(proc.stdout)
        after = measure_ceiling(build, preset, w)
        rows.append(
            {
                "kind": "build",
                "workload": w,
                "peer": "open3d",
                "variant": "first cast_rays of 1 ray (BVH build)",
                "ms": doc["build_ms"],
            }
        )
        for res in doc["results"]:
            rows += paired(
                [
                    {
                        "kind": "trace",
                        "workload": w,
                        "rays": res["rays"],
                        "peer": "open3d",
                        "variant": "cast_rays",
                        "mode": "closest",
                        "precision": "-",
                        "mrays_s": res["mrays_s"],
                        "measured_rays": res["n"],
                        "total_rays": res["n"],
                        "sampled": False,
                        "hits_per_ray": res["hits"] / max(1, res["n"]),
                        "agree_with_embree": res["agree_with_embree"],
                    }
                ],
                before,
                after,
            )
            log(
                f"{w} {res['rays']} open3d: {res['mrays_s']:.3f} Mrays/s, hits {res['hits']} "
                f"(Embree {res['ref_hits']}), agree {res['agree_with_embree']:.4f}"
            )
        check["version"] = doc["open3d"]
    # The trap the shim works around, shown on a sample: without it Open3D finds no hits.
    if "A" in workloads:
        proc = subprocess.run(
            [
                "/usr/bin/python3",
                peer,
                "--data-dir",
                data_dir,
                "--workload",
                "A",
                "--rays",
                "coherent",
                "--limit",
                "10000",
                "--reps",
                "1",
            ],
            capture_output=True,
            text=True,
        )
        if proc.returncode == 0:
            res = json.loads(proc.stdout)["results"][0]
            check["without_shim"] = {
                "rays": res["n"],
                "hits": res["hits"],
                "ref_hits": res["ref_hits"],
            }
            log(
                f"open3d without shim: {res['hits']} hits of {res['n']} "
                f"(Embree: {res['ref_hits']})"
            )
    return rows, check


# --- 4. the accuracy bench (issue 6) -----------------------------------------------------------


# --- 5. point queries (issue 18) -----------------------------------------------------------------


def run_points(build: str, preset: str, data_dir: str, skip_peers: bool) -> dict:
    """bench_points: the registration's topology share, and 1M points (full) against A, its
    shell, B and B's shell, in-process side by side with the binary endpoint and Open3D (which it
    runs itself). Its JSON, or {"unavailable": why}."""
    out_json = os.path.join(data_dir, "points.json")
    if os.path.exists(out_json):
        os.remove(out_json)
    cmd = [
        need(os.path.join(build, "bench", "bench_points")),
        *PRESETS[preset]["flag"],
        "--json",
        out_json,
    ]
    if skip_peers:
        cmd.append("--registration-only")
    log(" ".join(cmd))
    proc = subprocess.run(cmd, stdout=subprocess.DEVNULL if preset == "quick" else None)
    if not os.path.exists(out_json):
        return {"unavailable": f"bench_points exited {proc.returncode} without its JSON"}
    with open(out_json) as f:
        doc = json.load(f)
    doc["exit_code"] = proc.returncode
    return doc


def accuracy_section() -> str:
    """Hook for issue 6, "run time against error" per precision mode. That bench is its own
    command, bench/accuracy (it builds its stress targets and writes docs/accuracy.md and
    docs/accuracy.png); run_all.py does not run it, and points to its output."""
    if os.path.exists(os.path.join(REPO, "docs", "accuracy.md")):
        return (
            "Measured by its own command, `bench/accuracy`: see [accuracy.md](accuracy.md) "
            "(Mrays/s and error against a quad-precision reference for `fast`, `refined` and "
            "`exact` on the stress ray sets, with Open3D alongside) and `accuracy.png`."
        )
    if os.path.exists(os.path.join(BENCH_DIR, "accuracy")):
        return (
            "Measured by its own command, `bench/accuracy`, which writes `docs/accuracy.md` and "
            "`docs/accuracy.png`; it has not been run in this tree yet."
        )
    return (
        "Not measured yet: the accuracy bench of issue 6 (Mrays/s and error against a "
        "high-precision reference for each precision mode, on a stress ray set) is to write "
        "`docs/accuracy.md`; this section then points to it."
    )


# --- the report --------------------------------------------------------------------------------


def render_only(results_path: str, out: str | None) -> int:
    with open(results_path) as f:
        results = json.load(f)
    accuracy = accuracy_section()
    default = "benchmarks-quick.md" if results["preset"] == "quick" else None
    out = out or (
        os.path.join(os.path.dirname(results_path), "..", default)
        if default
        else os.path.join(REPO, "docs", "benchmarks.md")
    )
    with open(out, "w") as f:
        f.write(report_md.render(results, accuracy))
    log(f"wrote {out} from {results_path}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--quick", action="store_true", help="small sizes, for a check in a minute"
    )
    ap.add_argument("--build-dir", default=os.path.join(REPO, "build", "release"))
    ap.add_argument(
        "--out",
        help="Markdown output (default: docs/benchmarks.md for the full "
        "run, <build>/bench/benchmarks-quick.md with --quick)",
    )
    ap.add_argument("--skip-http", action="store_true")
    ap.add_argument("--skip-open3d", action="store_true")
    ap.add_argument(
        "--wait-quiet",
        type=float,
        default=0.0,
        metavar="MINUTES",
        help="first wait up to MINUTES for the 1-minute load average to fall below "
        "1 (the machine is shared with compiles); the run notes the load anyway",
    )
    ap.add_argument(
        "--render-only",
        metavar="RESULTS_JSON",
        help="measure nothing: re-render the Markdown from a results.json of an earlier run",
    )
    args = ap.parse_args()
    if args.render_only:
        return render_only(args.render_only, args.out)

    preset = "quick" if args.quick else "full"
    build = os.path.abspath(args.build_dir)
    data_dir = os.path.join(build, "bench", f"data-{preset}")
    os.makedirs(data_dir, exist_ok=True)
    out = args.out or (
        os.path.join(build, "bench", "benchmarks-quick.md")
        if args.quick
        else os.path.join(REPO, "docs", "benchmarks.md")
    )
    # Every binary up front: a missing one found at step 5 would lose the whole run.
    need(os.path.join(build, "bench", "bench_points"))
    wait_for_quiet(args.wait_quiet)
    started = time.time()
    machine = machine_info()

    inproc = run_inprocess(build, preset, data_dir)
    rows = list(inproc["rows"])
    workloads = list(inproc["meta"]["workloads"].keys())
    load: dict = {}
    open3d: dict = {}
    if not args.skip_http:
        try:
            http_rows, load = run_http(build, preset, data_dir, workloads)
            rows += http_rows
        except Exception as e:
            traceback.print_exc()
            rows.append(unavailable("-", "-", "http", "raycastd", f"error: {e}"))
    if not args.skip_open3d:
        o3d_rows, open3d = run_open3d(build, preset, data_dir, workloads)
        rows += o3d_rows
    points = run_points(build, preset, data_dir, args.skip_open3d and args.skip_http)
    accuracy = accuracy_section()

    machine["loadavg_end"] = os.getloadavg()
    machine["run_seconds"] = time.time() - started
    results = {
        "meta": inproc["meta"],
        "machine": machine,
        "rows": rows,
        "small_requests": load,
        "open3d": open3d,
        "points": points,
        "preset": preset,
    }
    with open(os.path.join(data_dir, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    text = report_md.render(results, accuracy)
    with open(out, "w") as f:
        f.write(text)
    print(text)
    log(
        f"wrote {out} and {os.path.join(data_dir, 'results.json')} "
        f"in {machine['run_seconds']:.0f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
