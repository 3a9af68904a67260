#!/usr/bin/env python3
"""raycastd scaled out on loopback: nginx (Debian's, with deploy/nginx.conf) in front of three
replicas sharing one --data-dir. Scenes are registered through nginx; clients then query them
through nginx with 1, 2 and 3 replicas behind it (throughput of each), and with three, one
replica is killed with SIGKILL mid-load. Every answer is compared byte for byte with the
reference taken before the load: the run fails on any failed request or differing answer.

    tests/scale/run.py --quick --server build/release/server/raycastd      # CTest: about 30 s
    tests/scale/run.py --server build/release/server/raycastd              # 20 s per phase
    tests/scale/run.py --server ... --phase-s 60 --clients 16 --json out.json

It also checks that X-Request-Id passes through nginx both ways, that an async render job is
found again through nginx with ?scene=<id>, and that the scenes of the killed replica are
answered by the others from the shared store. Exits 0 when everything held, 1 otherwise, 77
(CTest's skip) when nginx is not installed.
"""

import argparse
import http.client
import http.server
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import nginx_local  # noqa: E402

SKIP = 77


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def scene_doc(seed: int, spheres: int = 300) -> dict:
    """A scene of spheres on a slanted grid, different for each seed."""
    objects = []
    for i in range(spheres):
        x, y = i % 20, i // 20
        objects.append(
            {
                "type": "sphere",
                "center": [x - 10 + 0.1 * seed, y - 7.5, 20 + 0.3 * x + 0.05 * seed],
                "radius": 0.45,
            }
        )
    return {"objects": objects}


def rays_doc(seed: int, n: int) -> dict:
    """n rays from the origin fanning over the grid (a fixed set per seed)."""
    rays = []
    for i in range(n):
        u = ((i * 37 + seed * 11) % 97) / 97 - 0.5
        v = ((i * 53 + seed * 7) % 89) / 89 - 0.5
        rays.append({"origin": [0, 0, 0], "direction": [u, v * 0.8, 1]})
    return {"rays": rays, "precision": "refined"}


class Replica:
    def __init__(self, binary: str, data_dir: Path, log: Path) -> None:
        self.log = open(log, "w")
        self.proc = subprocess.Popen(
            [
                binary,
                "--port",
                "0",
                "--data-dir",
                str(data_dir),
                "--log-level",
                "warn",
                "--threads",
                "64",
            ],
            stdout=subprocess.PIPE,
            stderr=self.log,
            text=True,
        )
        line = self.proc.stdout.readline()
        if "listening on" not in line:
            raise RuntimeError(f"replica did not start: {line!r} (log {log})")
        self.port = int(line.strip().rsplit(":", 1)[1])

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()
        self.proc.stdout.close()
        self.log.close()


class Nginx:
    def __init__(self, nginx: str, work: Path, ports: list) -> None:
        self.work = work
        self.port = free_port()
        work.mkdir(parents=True, exist_ok=True)
        conf = work / "nginx.conf"
        conf.write_text(nginx_local.local_conf(work, self.port, ports))
        self.proc = subprocess.Popen(
            [
                nginx,
                "-p",
                str(work),
                "-e",
                str(work / "logs" / "error.log"),
                "-c",
                str(conf),
                "-g",
                "daemon off;",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 10
        while True:
            try:
                status, _, _ = request(self.port, "GET", "/v1/health")
                if status == 200:
                    return
            except OSError:
                pass
            if self.proc.poll() is not None:
                raise RuntimeError("nginx exited: " + self.proc.stderr.read())
            if time.monotonic() > deadline:
                raise RuntimeError("nginx did not answer /v1/health")
            time.sleep(0.05)

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.proc.stderr.close()


def request(
    port: int,
    method: str,
    path: str,
    body: object = None,
    headers: dict = None,
    conn: http.client.HTTPConnection = None,
) -> tuple:
    """(status, headers, body bytes); a fresh connection unless one is given."""
    own = conn is None
    c = conn or http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    try:
        data = (
            None
            if body is None
            else (body if isinstance(body, bytes) else json.dumps(body).encode())
        )
        h = {"Content-Type": "application/json"}
        h.update(headers or {})
        c.request(method, path, body=data, headers=h)
        r = c.getresponse()
        return r.status, r.headers, r.read()
    finally:
        if own:
            c.close()


# An answer cut short: its replica died while writing it (nginx had passed its header on, so it
# cannot send the request to another replica, docs/deploy.md), or the connection to nginx broke.
CUT = (http.client.IncompleteRead, http.client.RemoteDisconnected, ConnectionResetError)


class Load:
    """Clients querying through nginx until stopped; each answer checked against its reference.

    A query whose answer is cut short is sent once more (the queries are pure), as the Python
    client does (clients/python/raycastd/client.py); `cut` counts them, and a second failure is
    a failure."""

    def __init__(self, port: int, queries: list, clients: int) -> None:
        self.port, self.queries, self.clients = port, queries, clients
        self.ok = 0
        self.cut = 0
        self.failed = []
        self.rays = 0
        self.lock = threading.Lock()
        self.stop = threading.Event()

    def client(self, k: int) -> None:
        conn = None
        i = k
        while not self.stop.is_set():
            path, body, expected, n = self.queries[i % len(self.queries)]
            i += self.clients
            cut = 0
            for attempt in (0, 1):
                try:
                    conn = conn or http.client.HTTPConnection("127.0.0.1", self.port, timeout=60)
                    status, _, got = request(self.port, "POST", path, body, conn=conn)
                    good = status == 200 and got == expected
                    why = None if good else f"{path}: {status} {got[:200]!r}"
                except (OSError, http.client.HTTPException) as e:
                    good, why = False, f"{path}: {type(e).__name__} {e}"
                    if conn is not None:
                        conn.close()
                    conn = None
                    if attempt == 0 and isinstance(e, CUT):
                        cut = 1
                        continue
                break
            with self.lock:
                self.cut += cut
                if good:
                    self.ok += 1
                    self.rays += n
                else:
                    self.failed.append(why)

    def run(self, seconds: float, during=None) -> float:
        threads = [threading.Thread(target=self.client, args=(k,)) for k in range(self.clients)]
        t0 = time.monotonic()
        for t in threads:
            t.start()
        if during:
            during()
        time.sleep(max(0.0, seconds - (time.monotonic() - t0)))
        self.stop.set()
        for t in threads:
            t.join()
        return time.monotonic() - t0


def load_sends_a_cut_answer_again() -> tuple:
    """(cut, failed) of a one-client Load against a server that cuts its first answer short
    (its header promises more than it sends) and answers the rest whole."""
    answer, served = b'{"hits":[]}', []

    class Cutter(http.server.BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"

        def do_POST(self) -> None:  # noqa: N802 (http.server's name)
            self.rfile.read(int(self.headers.get("Content-Length", 0)))
            served.append(1)
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(answer)))
            self.end_headers()
            if len(served) == 1:
                self.wfile.write(answer[:4])
                self.close_connection = True
            else:
                self.wfile.write(answer)

        def log_message(self, *args: object) -> None:
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Cutter)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        load = Load(httpd.server_address[1], [("/v1/intersect", b"{}", answer, 1)], 1)
        load.run(0.2)
    finally:
        httpd.shutdown()
        httpd.server_close()
    return load.cut, load.failed


def main() -> int:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--server", default=os.environ.get("RAYCASTD_BINARY"), help="raycastd binary")
    p.add_argument("--quick", action="store_true", help="CTest: 3 s per phase, 6 s kill phase")
    p.add_argument("--phase-s", type=float, help="seconds per throughput phase (default 20)")
    p.add_argument("--clients", type=int, default=8, help="concurrent clients (default 8)")
    p.add_argument("--rays", type=int, default=64, help="rays per request (default 64)")
    p.add_argument("--scenes", type=int, default=6, help="scenes registered (default 6)")
    p.add_argument("--json", metavar="FILE", help="write the figures as JSON")
    p.add_argument("--keep-tmp", action="store_true", help="keep the data dir and logs")
    a = p.parse_args()
    nginx = shutil.which("nginx") or (
        "/usr/sbin/nginx" if os.path.exists("/usr/sbin/nginx") else None
    )
    if not nginx:
        print("scale: SKIP: nginx is not installed (Debian: apt-get install nginx)")
        return SKIP
    if not a.server:
        p.error("--server (or $RAYCASTD_BINARY) is needed")
    phase_s = a.phase_s or (3.0 if a.quick else 20.0)
    kill_s = 2 * phase_s
    work = Path(tempfile.mkdtemp(prefix="raycastd_scale_"))
    data = work / "data"
    replicas, proxies, failures = [], [], []
    results = {
        "clients": a.clients,
        "rays_per_request": a.rays,
        "phase_s": phase_s,
        "cpus": os.cpu_count(),
        "throughput": {},
    }

    def check(ok: bool, what: str) -> None:
        print(("ok   " if ok else "FAIL ") + what)
        if not ok:
            failures.append(what)

    try:
        cut, failed = load_sends_a_cut_answer_again()
        check(
            cut == 1 and not failed,
            f"the load client sends a query whose answer was cut short once more: "
            f"{cut} cut, {len(failed)} failed",
        )
        replicas = [Replica(a.server, data, work / f"replica{k}.log") for k in range(3)]
        ports = [r.port for r in replicas]
        front = Nginx(nginx, work / "nginx3", ports)
        proxies.append(front)
        # Register through nginx (spread at random over the replicas: no id in the URI).
        ids = []
        for s in range(a.scenes):
            status, _, body = request(front.port, "POST", "/v1/scenes", scene_doc(s))
            check(status in (200, 201), f"register scene {s} through nginx: {status}")
            ids.append(json.loads(body)["id"])
        # The references: each query asked once, directly of replica 0, which loads from the
        # shared store the scenes the others saved.
        queries = []
        for k, sid in enumerate(ids):
            for seed in range(3):
                path = f"/v1/scenes/{sid}/intersect"
                body = json.dumps(rays_doc(seed + 3 * k, a.rays)).encode()
                status, _, ref = request(ports[0], "POST", path, body)
                check(status == 200, f"reference answer for {sid[:12]}… seed {seed} from replica 0")
                queries.append((path, body, ref, a.rays))
        # X-Request-Id through nginx: a client's comes back; without one, nginx's own.
        _, h, _ = request(front.port, "GET", "/v1/health", headers={"X-Request-Id": "scale-1"})
        check(h["X-Request-Id"] == "scale-1", "a client's X-Request-Id passes through nginx")
        _, h, _ = request(front.port, "GET", "/v1/health")
        check(
            len(h["X-Request-Id"] or "") == 32,
            f"nginx's $request_id reaches raycastd: {h['X-Request-Id']}",
        )
        # An async job, found again through nginx by its scene.
        status, h, body = request(
            front.port,
            "POST",
            f"/v1/scenes/{ids[0]}/render",
            {"width": 16, "height": 8, "async": True},
        )
        job = json.loads(body).get("job") if status == 202 else None
        check(job is not None, f"async render through nginx: {status}")
        state = None
        for _ in range(200):
            status, _, body = request(front.port, "GET", f"/v1/jobs/{job}?scene={ids[0]}")
            state = json.loads(body).get("state") if status == 200 else status
            if state == "done":
                break
            time.sleep(0.05)
        check(state == "done", f"the job is found through nginx with ?scene=: {state}")
        status, h, _ = request(front.port, "GET", f"/v1/jobs/{job}/image?scene={ids[0]}")
        check(
            status == 200 and h["Content-Type"] == "image/png", f"its image through nginx: {status}"
        )
        front.stop()
        proxies.clear()

        # Throughput with 1, 2 and 3 replicas behind nginx.
        for n in (1, 2, 3):
            proxy = Nginx(nginx, work / f"nginx{n}", ports[:n])
            proxies.append(proxy)
            load = Load(proxy.port, queries, a.clients)
            seconds = load.run(phase_s)
            proxy.stop()
            proxies.clear()
            rps = load.ok / seconds
            results["throughput"][n] = {
                "requests_per_s": round(rps, 1),
                "rays_per_s": round(load.rays / seconds),
                "failed": len(load.failed),
                "cut": load.cut,
            }
            print(
                f"     {n} replica(s): {rps:8.1f} requests/s, {load.rays / seconds / 1e3:8.1f} krays/s, "
                f"{len(load.failed)} failed, {load.cut} cut short"
            )
            check(
                not load.failed and not load.cut,
                f"{n} replica(s): no failed, cut or differing answer"
                + (f" (first: {load.failed[0]})" if load.failed else ""),
            )

        # Three replicas, one killed with SIGKILL a third of the way in.
        proxy = Nginx(nginx, work / "nginx_kill", ports)
        proxies.append(proxy)
        load = Load(proxy.port, queries, a.clients)
        victim = replicas[1]

        def kill_one() -> None:
            time.sleep(kill_s / 3)
            victim.kill()

        seconds = load.run(kill_s, during=kill_one)
        results["kill"] = {
            "requests": load.ok + len(load.failed),
            "failed": len(load.failed),
            "cut": load.cut,
            "requests_per_s": round(load.ok / seconds, 1),
        }
        print(
            f"     kill -9 of one of 3 mid-load: {load.ok} answered, {len(load.failed)} failed, "
            f"{load.cut} cut short and sent again"
        )
        check(victim.proc.poll() is not None, "the victim is dead")
        check(
            load.ok > 0 and not load.failed,
            "kill -9 mid-load: every request answered, same answers"
            + (f" (first: {load.failed[0]})" if load.failed else ""),
        )
        # Only answers on the wire at the kill can be cut: at most one a client.
        check(
            load.cut <= a.clients,
            f"kill -9 mid-load: {load.cut} answers cut short (at most {a.clients}, one a client)",
        )
        # Every scene still answers through nginx, identically (the victim's from the store).
        same = all(request(proxy.port, "POST", q[0], q[1])[2] == q[2] for q in queries)
        check(same, "after the kill every scene answers as before")
    except Exception as e:  # a broken set-up is a failure with its reason, not a traceback
        failures.append(f"{type(e).__name__}: {e}")
        print(f"FAIL {type(e).__name__}: {e}")
    finally:
        for proxy in proxies:
            proxy.stop()
        for r in replicas:
            r.kill()
        if a.json:
            Path(a.json).write_text(json.dumps(results, indent=1))
        if a.keep_tmp or failures:
            print(f"scale: logs and data kept in {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    t = results["throughput"]
    if len(t) == 3:
        print(
            "scale: throughput (requests/s) with 1, 2, 3 replicas: "
            + ", ".join(str(t[n]["requests_per_s"]) for n in (1, 2, 3))
            + f" on {os.cpu_count()} CPUs shared by the clients, nginx and every replica"
        )
    print(f"scale: {'FAILED: ' + '; '.join(failures) if failures else 'passed'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
