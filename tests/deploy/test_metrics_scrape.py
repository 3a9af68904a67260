"""GET /metrics read by Prometheus' own text-format parser (Debian's python3-prometheus-client),
and the JSON request log on stderr: each line names the X-Request-Id its response carried.

Run by CTest as deploy_metrics_scrape, with RAYCASTD_BINARY naming the server binary."""

import json
import os
import subprocess
import tempfile
import time
import unittest
import urllib.error
import urllib.request

try:
    from prometheus_client.parser import text_string_to_metric_families
except ImportError:  # the test says why it did not run
    text_string_to_metric_families = None

SCENE = {
    "objects": [{"type": "sphere", "center": [0, 0, 10], "radius": 2}],
    "lights": [{"type": "point", "position": [5, 5, 0], "intensity": [1, 1, 1]}],
}


class Server:
    """raycastd on a free loopback port, its stderr in a temporary file."""

    def __init__(self, *args: str) -> None:
        self.log = tempfile.TemporaryFile(mode="w+")
        self.proc = subprocess.Popen(
            [os.environ["RAYCASTD_BINARY"], "--port", "0", *args],
            stdout=subprocess.PIPE,
            stderr=self.log,
            text=True,
        )
        line = self.proc.stdout.readline()  # "raycastd listening on http://127.0.0.1:PORT"
        self.url = line.strip().split()[-1]

    def request(self, method: str, path: str, body: object = None, headers: dict = {}) -> tuple:
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.url + path, data=data, method=method)
        req.add_header("Content-Type", "application/json")
        for k, v in headers.items():
            req.add_header(k, v)
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                return r.status, r.headers, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.headers, e.read()

    def log_lines(self) -> list:
        self.log.seek(0)
        return [json.loads(l) for l in self.log if l.startswith("{")]

    def close(self) -> None:
        self.proc.kill()
        self.proc.wait()
        self.proc.stdout.close()
        self.log.close()


@unittest.skipIf(
    text_string_to_metric_families is None,
    "prometheus_client is not installed (Debian: apt-get install python3-prometheus-client)",
)
class MetricsScrape(unittest.TestCase):
    def setUp(self) -> None:
        self.server = Server()

    def tearDown(self) -> None:
        self.server.close()

    def families(self) -> dict:
        status, headers, body = self.server.request("GET", "/metrics")
        self.assertEqual(status, 200)
        self.assertTrue(headers["Content-Type"].startswith("text/plain; version=0.0.4"))
        return {f.name: f for f in text_string_to_metric_families(body.decode())}

    def test_the_scrape_parses_and_moves(self) -> None:
        status, _, body = self.server.request("POST", "/v1/scenes", SCENE)
        self.assertEqual(status, 201, body)
        sid = json.loads(body)["id"]
        rays = {"rays": [{"origin": [0, 0, 0], "direction": [0, 0, 1]}] * 5, "mode": "any"}
        for _ in range(3):
            status, _, body = self.server.request("POST", f"/v1/scenes/{sid}/intersect", rays)
            self.assertEqual(status, 200, body)
        # A request is counted once its answer is written: the client may be a moment ahead.
        deadline = time.monotonic() + 5
        while True:
            f = self.families()
            counted = sum(
                s.value
                for s in f["raycastd_http_request_duration_seconds"].samples
                if s.name.endswith("_count") and s.labels["route"] == "/v1/scenes/{id}/intersect"
            )
            if counted >= 3 or time.monotonic() > deadline:
                break
            time.sleep(0.02)
        # The parser names counters without their _total suffix.
        self.assertEqual(f["raycastd_http_requests"].type, "counter")
        self.assertEqual(f["raycastd_http_request_duration_seconds"].type, "histogram")
        for name in (
            "raycastd_scenes_registered",
            "raycastd_scenes_loaded",
            "process_resident_memory_bytes",
            "raycastd_jobs_queued",
            "raycastd_jobs_running",
        ):
            self.assertEqual(f[name].type, "gauge", name)
        for name in ("raycastd_busy_rejections", "raycastd_request_timeouts", "raycastd_rays"):
            self.assertEqual(f[name].type, "counter", name)
        requests = {
            (s.labels["route"], s.labels["status"]): s.value
            for s in f["raycastd_http_requests"].samples
            if s.name == "raycastd_http_requests_total"
        }
        self.assertEqual(requests[("/v1/scenes/{id}/intersect", "200")], 3)
        self.assertEqual(requests[("/v1/scenes", "201")], 1)
        rays_any = sum(
            s.value
            for s in f["raycastd_rays"].samples
            if s.labels.get("kind") == "any" and s.name == "raycastd_rays_total"
        )
        self.assertEqual(rays_any, 15)
        buckets = [
            s
            for s in f["raycastd_http_request_duration_seconds"].samples
            if s.name.endswith("_bucket") and s.labels["route"] == "/v1/scenes/{id}/intersect"
        ]
        self.assertEqual(buckets[-1].labels["le"], "+Inf")
        self.assertEqual(buckets[-1].value, 3)
        values = [b.value for b in buckets]
        self.assertEqual(values, sorted(values), "buckets are cumulative")
        self.assertGreater(
            next(s.value for s in f["process_resident_memory_bytes"].samples), 1 << 20
        )
        self.assertEqual(next(s.value for s in f["raycastd_scenes_registered"].samples), 1)

    def test_each_log_line_names_its_request_id(self) -> None:
        status, headers, _ = self.server.request("GET", "/v1/health")
        self.assertEqual(status, 200)
        health_id = headers["X-Request-Id"]
        status, headers, _ = self.server.request("GET", "/v1/scenes/sc_missing")
        self.assertEqual(status, 404)
        missing_id = headers["X-Request-Id"]
        # A balancer's id is adopted (and named in the log); one that is not a plain token is not.
        status, headers, _ = self.server.request(
            "GET", "/v1/health", headers={"X-Request-Id": "ngx-42"}
        )
        self.assertEqual(headers["X-Request-Id"], "ngx-42")
        status, headers, _ = self.server.request(
            "GET", "/v1/health", headers={"X-Request-Id": 'a"b'}
        )
        self.assertTrue(headers["X-Request-Id"].startswith("rq_"))
        # A line is written once its answer has been sent, so it may trail the answer a little.
        deadline = time.monotonic() + 5
        while True:
            lines = {l["request_id"]: l for l in self.server.log_lines() if l["msg"] == "request"}
            if {health_id, missing_id, "ngx-42"} <= lines.keys() or time.monotonic() > deadline:
                break
            time.sleep(0.02)
        self.assertEqual(lines[health_id]["route"], "/v1/health")
        self.assertEqual(lines[health_id]["status"], 200)
        self.assertEqual(lines[health_id]["method"], "GET")
        self.assertGreaterEqual(lines[health_id]["duration_ms"], 0)
        self.assertEqual(lines[health_id]["rays"], 0)
        self.assertEqual(lines[missing_id]["route"], "/v1/scenes/{id}")
        self.assertEqual(lines[missing_id]["status"], 404)
        self.assertEqual(lines["ngx-42"]["route"], "/v1/health")


class LogLevels(unittest.TestCase):
    def test_warn_logs_only_server_failures(self) -> None:
        server = Server("--log-level", "warn")
        try:
            self.assertEqual(server.request("GET", "/v1/health")[0], 200)
            self.assertEqual(server.request("GET", "/v1/scenes/sc_missing")[0], 404)
            self.assertEqual(server.request("GET", "/v1/health")[0], 200)
            self.assertEqual([l for l in server.log_lines() if l["msg"] == "request"], [])
        finally:
            server.close()

    def test_a_bad_level_is_refused(self) -> None:
        r = subprocess.run(
            [os.environ["RAYCASTD_BINARY"], "--log-level", "chatty"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        self.assertEqual(r.returncode, 2)
        self.assertIn("--log-level must be error, warn, info or debug", r.stderr)


if __name__ == "__main__":
    unittest.main()
