"""Hostile inputs: a battery by class. Every class prints
`class: N sent, statuses {...}, expected ...`; a request that kills the server is counted as a
crash of its class, reported with the exit signal, and the server is restarted for the rest."""

import base64
import collections
import json
import os
import random
import socket
import struct
import threading
import time

import expected as X
import harness
import reference as R

SUITE = "hostile"
IDLE_WAIT = 4.0  # how long the idle-sockets class waits for its health answer (expected: 2 s)


class Battery:
    def __init__(self, opts, ledger, d):
        self.opts = opts
        self.ledger = ledger
        self.d = d
        self.quick = opts.mode == "quick"
        self.rng = R.rng_for(opts.seed, "hostile")
        self.server = harness.ServerProcess(opts.server, data_dir=os.path.join(d, "data"),
                                            scene_root=opts.models, log_dir=d, name="hostile")
        self.client = self.server.client(timeout=30)
        self.crashes = []  # (class, exit, stderr tail)
        self.summary = collections.OrderedDict()
        r = self.client.post("/v1/scenes", R.tutorial_scene())
        self.scene_id = r.json()["id"] if r.status in (200, 201) else None

    # --- sending, counting, crash detection ---
    def alive_or_restart(self, cls):
        """True if the server was alive; else records the crash and restarts it."""
        if self.server.alive():
            return True
        how = self.server.exit_description()
        tail = self.server.stderr_tail(400)
        self.crashes.append((cls, how, tail))
        print("  CRASH during %s: server %s; stderr: %s" % (cls, how, tail.strip()[-300:] or "(empty)"),
              flush=True)
        self.client.close()
        self.server.start()
        self.client = self.server.client(timeout=30)
        return False

    def send(self, cls, counter, method, path, body=None, content_type=None, headers=None):
        r = self.client.request(method, path, body=body, content_type=content_type, headers=headers)
        label = r.label()
        if r.status is None:
            time.sleep(0.05)  # let a dying server finish dying before asking
            if not self.alive_or_restart(cls):
                label = "crash (%s)" % self.crashes[-1][1]
        counter[label] += 1
        return r, label

    def finish(self, cls, key, counter, ok_fn=None, note=""):
        """Prints the class line and makes its check."""
        sent = sum(counter.values())
        statuses, codes, _ = X.EXPECTED[key]
        if ok_fn is None:
            def ok_fn(label):
                st, _, code = label.partition(" ")
                if not st.isdigit():
                    return False
                return X.matches(key, int(st), code or None)
        bad = {k: v for k, v in counter.items() if not ok_fn(k)}
        print("  %s: %d sent, statuses %s, expected %s%s"
              % (cls, sent, dict(counter), X.describe(key), (" — " + note) if note else ""), flush=True)
        self.summary[cls] = {"sent": sent, "statuses": dict(counter), "expected": X.describe(key),
                             "ok": not bad, "note": note}
        self.ledger.check(SUITE, cls, not bad and sent > 0,
                          "unexpected: %s of %d" % (bad, sent) if bad else "%d sent" % sent)

    def raw(self, cls, counter, data, timeout=X.ANSWER_WITHIN, half_close=False):
        """A raw exchange; counts '400' / 'no answer in 2 s' / 'crash (...)'."""
        try:
            got, secs, timed_out = harness.raw_exchange(self.server.port, data, timeout=timeout,
                                                        half_close=half_close)
        except OSError as e:
            got, secs, timed_out = b"", 0.0, False
            if not self.alive_or_restart(cls):
                counter["crash (%s)" % self.crashes[-1][1]] += 1
                return None, 0.0, b""
            counter["connect error %r" % e] += 1
            return None, 0.0, b""
        status, headers, body = harness.parse_raw_response(got)
        if status is None:
            if timed_out:
                label = "no answer within %.0f s" % timeout
            else:
                label = "closed without an answer"
            if not self.alive_or_restart(cls):
                label = "crash (%s)" % self.crashes[-1][1]
        else:
            label = str(status)
        counter[label] += 1
        return status, secs, body

    # --- classes ---
    def deep_json(self):
        n = 100000
        c = collections.Counter()
        arrays = "[" * n + "]" * n
        objects = '{"a":' * n + "1" + "}" * n
        bodies = [
            ("/v1/scenes", '{"objects":[],"x":%s}' % arrays),
            ("/v1/scenes", '{"objects":[],"x":%s}' % objects),
            ("/v1/intersect", '{"scene":{"objects":[],"x":%s},"rays":[{"origin":[0,0,0],"direction":[0,0,1]}]}' % arrays),
            ("/v1/intersect", '{"scene":{"objects":[],"x":%s},"rays":[{"origin":[0,0,0],"direction":[0,0,1]}]}' % objects),
            ("/v1/explain", '{"scene":{"objects":[],"x":%s},"ray":{"origin":[0,0,0],"direction":[0,0,1]}}' % arrays),
        ]
        for path, body in bodies:
            self.send("deep_json", c, "POST", path, body)
        self.finish("deep_json", "hostile.deep_json", c)

    def _number_bodies(self, v):
        """Request bodies with the literal v (a string) in every numeric slot that matters."""
        ray = '{"origin":[0,0,0],"direction":[0,0,1]}'
        sphere = '{"type":"sphere","center":[0,0,10],"radius":2}'
        out = [
            ("/v1/intersect", '{"scene":{"objects":[{"type":"sphere","center":[0,0,10],"radius":%s}]},"rays":[%s]}' % (v, ray)),
            ("/v1/intersect", '{"scene":{"objects":[{"type":"sphere","center":[%s,0,10],"radius":2}]},"rays":[%s]}' % (v, ray)),
            ("/v1/intersect", '{"scene":{"objects":[%s]},"rays":[{"origin":[0,%s,0],"direction":[0,0,1]}]}' % (sphere, v)),
            ("/v1/intersect", '{"scene":{"objects":[%s]},"rays":[{"origin":[0,0,0],"direction":[0,0,%s]}]}' % (sphere, v)),
            ("/v1/intersect", '{"scene":{"objects":[%s]},"rays":[{"origin":[0,0,0],"direction":[0,0,1],"tmax":%s}]}' % (sphere, v)),
            ("/v1/scenes", '{"objects":[{"type":"triangle","vertices":[[0,0,5],[%s,0,5],[0,1,5]]}]}' % v),
            ("/v1/explain", '{"scene":{"objects":[%s]},"ray":{"origin":[0,0,0],"direction":[%s,0,1]}}' % (sphere, v)),
        ]
        if self.scene_id:
            out.append(("/v1/scenes/%s/render" % self.scene_id, '{"width":8,"height":8,"camera":{"position":[0,0,%s],"look_at":[0,0,10],"up":[0,1,0],"fov_y_deg":45}}' % v))
        return out

    def numbers(self):
        for cls, key, values in (
                ("nan_inf_literal", "hostile.nan_inf_literal", ["NaN", "Infinity", "-Infinity", "nan", "inf"]),
                ("overflowing_number", "hostile.overflowing_number", ["1e999", "-1e999", "1e400"]),
                ("huge_finite", "hostile.huge_finite",
                 ["1e308", "-1.7976931348623157e308", "1e-320", "123456789012345678901234567890"])):
            c = collections.Counter()
            for v in values:
                for path, body in self._number_bodies(v):
                    self.send(cls, c, "POST", path, body)
            self.finish(cls, key, c)

    def binary_nan_inf(self):
        c = collections.Counter()
        if not self.scene_id:
            self.ledger.skip(SUITE, "binary_nan_inf", "no registered scene")
            return
        bad_values = [float("nan"), float("inf"), -float("inf")]
        for dtype, fmt in (("float32", "<8f"), ("float64", "<8d")):
            for slot, name in ((0, "origin"), (4, "direction")):
                for v in bad_values:
                    rays = [[0, 0, 0, 0, 0, 1, 0, float("inf")] for _ in range(10)]
                    rays[7][slot] = v
                    body = b"".join(struct.pack(fmt, *r) for r in rays)
                    self.send("binary_nan_inf", c, "POST",
                              "/v1/scenes/%s/intersect?dtype=%s" % (self.scene_id, dtype), body,
                              content_type="application/octet-stream")
            rays = [[0, 0, 0, 0, 0, 1, 0, float("inf")] for _ in range(10)]
            rays[3][3:6] = [0, 0, 0]  # a zero direction
            body = b"".join(struct.pack(fmt, *r) for r in rays)
            self.send("binary_nan_inf", c, "POST",
                      "/v1/scenes/%s/intersect?dtype=%s" % (self.scene_id, dtype), body,
                      content_type="application/octet-stream")
        self.finish("binary_nan_inf", "hostile.binary_nan_inf", c)

    def garbage_model(self):
        c = collections.Counter()
        sizes = [1, 7, 12, 20, 100, 1000, 10000, 100000]
        if not self.quick:
            sizes += [self.rng.randint(1, 200000) for _ in range(40)]
        for n in sizes:
            junk = bytes(self.rng.getrandbits(8) for _ in range(n))
            self.send("garbage_model", c, "POST", "/v1/scenes", junk, content_type="model/gltf-binary")
            # the GLB magic, version 2 and a length, then garbage
            glb = b"glTF" + struct.pack("<II", 2, n + 12) + junk
            self.send("garbage_model", c, "POST", "/v1/scenes", glb, content_type="model/gltf-binary")
            if n <= 10000:
                doc = {"objects": [{"type": "mesh", "format": "glb",
                                    "data_base64": base64.b64encode(glb).decode()}]}
                self.send("garbage_model", c, "POST", "/v1/scenes", doc)
        self.finish("garbage_model", "hostile.garbage_model", c)

    def truncated_glb(self):
        files = []
        if self.opts.models:
            for rel in ("Box/glTF-Binary/Box.glb", "Duck/glTF-Binary/Duck.glb"):
                p = os.path.join(self.opts.models, rel)
                if os.path.isfile(p):
                    with open(p, "rb") as f:
                        files.append((rel, f.read()))
        if not files:
            why = "no models folder (--shared DIR with data/models/Box and Duck)"
            print("  truncated_glb: skipped: %s" % why, flush=True)
            self.ledger.skip(SUITE, "truncated_glb", why)
            self.summary["truncated_glb"] = {"sent": 0, "skipped": why}
            return
        c = collections.Counter()
        h = collections.Counter()
        per_file = 15 if self.quick else 150
        for rel, data in files:
            json_len = struct.unpack_from("<I", data, 12)[0]
            cuts = {12, 16, 20, 20 + json_len - 1, 20 + json_len, 20 + json_len + 8, len(data) - 1}
            while len(cuts) < per_file:
                cuts.add(self.rng.randint(13, len(data) - 1))
            for n in sorted(x for x in cuts if 12 <= x < len(data)):
                self.send("truncated_glb", c, "POST", "/v1/scenes", data[:n],
                          content_type="model/gltf-binary")
            for n in (2, 4, 8, 11):
                self.send("truncated_glb_header", h, "POST", "/v1/scenes", data[:n],
                          content_type="model/gltf-binary")
            for n in sorted(self.rng.sample(range(13, len(data)), 3)):
                doc = {"objects": [{"type": "mesh", "format": "glb",
                                    "data_base64": base64.b64encode(data[:n]).decode()}]}
                self.send("truncated_glb", c, "POST", "/v1/scenes", doc)
        self.finish("truncated_glb", "hostile.truncated_glb", c, note=", ".join(r for r, _ in files))
        self.finish("truncated_glb_header", "hostile.truncated_glb_header", h)

    def bad_json_misc(self):
        c = collections.Counter()
        bodies = [b"", b"{", b'{"objects": [', b"[]", b"42", b'"a string"', b"null", b"true",
                  b'{"objects":[]}x', b'{"objects":[]} {"objects":[]}', b"{'objects':[]}",
                  b'{"objects":[],/* c */"x":1}', b'{"objects":[],"name":"\xff\xfe"}',
                  b'\xef\xbb\xbf{"objects":[}', b'{"objects":[{"type":"sphere","center":[0,0,1],"radius":2,}]}',
                  b'{"objects":"many"}', b'{"objects":[{"type":"sphere"}]}', b"\x00" * 16]
        paths = ["/v1/scenes", "/v1/intersect", "/v1/explain"]
        if self.scene_id:
            paths += ["/v1/scenes/%s/intersect" % self.scene_id, "/v1/scenes/%s/trace" % self.scene_id]
        for path in paths:
            for b in bodies:
                if path.endswith(("/trace", "/intersect")) and b == b'{"objects":[]}x':
                    pass
                self.send("bad_json_misc", c, "POST", path, b)
        self.finish("bad_json_misc", "hostile.bad_json_misc", c)

    def mutated_docs(self):
        c = collections.Counter()
        with open(os.path.join(os.path.dirname(__file__), "..", "..", "clients", "examples",
                               "tutorial-q1.json"), "rb") as f:
            q1 = f.read()
        seeds = [("/v1/intersect", q1),
                 ("/v1/scenes", json.dumps(R.random_small_scene(self.rng)).encode()),
                 ("/v1/explain", json.dumps({"scene": R.tutorial_scene(),
                                             "ray": {"origin": [0, 0, 0], "direction": [0, 0, 1]}}).encode())]
        if self.scene_id:
            seeds += [("/v1/scenes/%s/render" % self.scene_id,
                       b'{"width": 16, "height": 12, "spp": 1, "max_depth": 3, "shading": "phong"}'),
                      ("/v1/scenes/%s/trace" % self.scene_id,
                       b'{"ray": {"origin": [0, 0, 0], "direction": [0, 0, 1]}, "max_depth": 5}'),
                      ("/v1/scenes/%s/intersect" % self.scene_id,
                       b'{"rays": [{"origin": [0, 0, 0], "direction": [0, 0, 1], "tmin": 0, "tmax": 1e30}],'
                       b' "mode": "all", "precision": "fast"}')]
        alphabet = b'{}[]",:0123456789.-+eE \\nNaIfty\x00\xff'
        n = 150 if self.quick else 2000
        for k in range(n):
            path, seed = seeds[k % len(seeds)]
            b = bytearray(seed)
            for _ in range(self.rng.randint(1, 5)):
                op = self.rng.random()
                i = self.rng.randrange(len(b))
                if op < 0.4:
                    b[i] = self.rng.choice(alphabet)
                elif op < 0.7:
                    b.insert(i, self.rng.choice(alphabet))
                elif len(b) > 1:
                    del b[i]
            self.send("mutated_docs", c, "POST", path, bytes(b))
        self.finish("mutated_docs", "hostile.mutated_docs", c)

    def long_url(self):
        c = collections.Counter()
        pad = "a" * 100000
        reqs = [("GET", "/v1/health?q=" + pad, None), ("GET", "/v1/scenes/sc_" + pad, None),
                ("DELETE", "/v1/scenes/sc_" + pad, None), ("GET", "/" + pad, None),
                ("POST", "/v1/intersect?x=" + pad, open_q1())]
        for method, path, body in reqs:
            r, label = self.send("long_url", c, method, path, body)
            if r.status == 414 and r.code() is None:
                c[label] -= 1
                c["414 without a JSON error body"] += 1
        self.finish("long_url", "hostile.long_url", c)

    def content_length(self):
        """Lying Content-Length headers, sent at once on separate sockets (each may be held up
        to 2 s), then judged one by one."""
        jobs = []
        for cls, values in (("content_length_negative", ["-5"]),
                            ("content_length_23_digits",
                             ["12345678901234567890123", "99999999999999999999999"])):
            for v in values:
                for path in ("/v1/intersect", "/v1/scenes"):
                    jobs.append((cls, ("POST %s HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                       "Content-Type: application/json\r\nContent-Length: %s\r\n\r\n{}"
                                       % (path, v)).encode()))
        for lengths in (("2", "5"), ("5", "2"), ("2, 5",)):
            hdrs = "".join("Content-Length: %s\r\n" % x for x in lengths)
            jobs.append(("content_length_twice",
                         ("POST /v1/intersect HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                          "Content-Type: application/json\r\n%s\r\n{}xyz" % hdrs).encode()))
        results = [None] * len(jobs)

        def one(i, data):
            try:
                results[i] = harness.raw_exchange(self.server.port, data, timeout=X.ANSWER_WITHIN)
            except OSError as e:
                results[i] = e

        threads = [threading.Thread(target=one, args=(i, data), daemon=True)
                   for i, (_, data) in enumerate(jobs)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=X.ANSWER_WITHIN + 10)
        counters = collections.OrderedDict((k, collections.Counter()) for k in
                                           ("content_length_negative", "content_length_23_digits",
                                            "content_length_twice"))
        for (cls, _), res in zip(jobs, results):
            if isinstance(res, Exception) or res is None:
                label = "connect error %r" % (res,)
            else:
                got, secs, timed_out = res
                status, _, _ = harness.parse_raw_response(got)
                if status is not None:
                    label = str(status)
                elif timed_out:
                    label = "no answer within %.0f s" % X.ANSWER_WITHIN
                else:
                    label = "closed without an answer"
            counters[cls][label] += 1
        if not self.alive_or_restart("content_length"):
            counters["content_length_negative"]["crash (%s)" % self.crashes[-1][1]] += 1
        for cls, c in counters.items():
            self.finish(cls, "hostile." + cls, c,
                        note="answered within %.0f s or counted as no answer" % X.ANSWER_WITHIN)

    def idle_sockets(self):
        c = collections.Counter()
        rounds = 1 if self.quick else 3
        delays = []
        for _ in range(rounds):
            socks = []
            try:
                for _ in range(64):
                    s = socket.create_connection((harness.HOST, self.server.port), timeout=5)
                    s.sendall(b"GET /v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\n")  # no blank line
                    socks.append(s)
                time.sleep(0.2)
                t0 = time.monotonic()
                got, secs, timed_out = harness.raw_exchange(
                    self.server.port, b"GET /v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n",
                    timeout=IDLE_WAIT)
                status, _, _ = harness.parse_raw_response(got)
                took = time.monotonic() - t0
                delays.append(took)
                if status is not None and took <= X.ANSWER_WITHIN:
                    c[str(status)] += 1
                elif status is not None:
                    c["%d after %.1f s" % (status, took)] += 1
                else:
                    c["no answer in %.0f s" % IDLE_WAIT] += 1
            finally:
                for s in socks:
                    s.close()
            self.alive_or_restart("idle_sockets")
        self.finish("idle_sockets", "hostile.idle_sockets", c,
                    note="GET /v1/health took %s s with 64 idle sockets open"
                    % ", ".join("%.2f" % d for d in delays))

    def half_close(self):
        c = collections.Counter()
        body = open_q1()
        req = (b"POST /v1/intersect HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
               b"Content-Length: %d\r\n\r\n" % len(body)) + body
        for _ in range(20):
            got, secs, timed_out = harness.raw_exchange(self.server.port, req, timeout=5, half_close=True)
            status, _, rbody = harness.parse_raw_response(got)
            if status == 200:
                try:
                    t = json.loads(rbody)["hits"][0]["t"]
                    c["200" if t == 7.267949192431123 else "200 wrong t %r" % t] += 1
                except Exception:  # noqa: BLE001
                    c["200 unreadable body"] += 1
            elif status is None:
                c["no answer" if timed_out else "closed without an answer"] += 1
                self.alive_or_restart("half_close")
            else:
                c[str(status)] += 1
        self.finish("half_close", "hostile.half_close", c,
                    ok_fn=lambda k: k == "200", note="%d of 20 answered" % c.get("200", 0))

    def form_urlencoded(self):
        c = collections.Counter()
        rng = random.Random(2000)
        objs = ['{"type":"sphere","center":[%.2f,%.2f,%.2f],"radius":%.2f}'
                % (rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(10, 90), rng.uniform(0.1, 1.5))
                for _ in range(2000)]
        body = ('{"name":"two thousand spheres","objects":[' + ",".join(objs) + "]}").encode()
        ids = []
        for _ in range(2):
            self.client.close()  # a fresh connection each: a refused body may be left unread
            r, label = self.send("form_urlencoded_scene", c, "POST", "/v1/scenes", body,
                                 content_type="application/x-www-form-urlencoded")
            if r.status in (200, 201):
                js = r.json()
                ids.append(js.get("id"))
                if js.get("objects") != 2000:
                    c[label] -= 1
                    c["%s with objects=%r" % (label, js.get("objects"))] += 1
        note = "%.0f KB; " % (len(body) / 1024.0) + (
            "same id twice" if len(ids) == 2 and ids[0] == ids[1] else "ids %s" % ids)
        self.finish("form_urlencoded_scene", "hostile.form_urlencoded_scene", c, note=note)


def open_q1():
    with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "clients",
                           "examples", "tutorial-q1.json"), "rb") as f:
        return f.read()


def run(opts, ledger, tmp_root):
    print("\n== hostile inputs", flush=True)
    d = os.path.join(tmp_root, "hostile")
    os.makedirs(d)
    b = Battery(opts, ledger, d)
    t0 = time.monotonic()
    try:
        for step in (b.deep_json, b.numbers, b.binary_nan_inf, b.garbage_model, b.truncated_glb,
                     b.bad_json_misc, b.mutated_docs, b.long_url, b.content_length,
                     b.idle_sockets, b.half_close, b.form_urlencoded):
            try:
                step()
            except harness.ServerStartError:
                raise
            except Exception as e:  # noqa: BLE001 - one class's harness error must not stop the rest
                import traceback
                ledger.check(SUITE, step.__name__ + "_ran", False,
                             "%r %s" % (e, traceback.format_exc(limit=3)))
            b.alive_or_restart(step.__name__)
        alive = b.server.alive()
        h = b.server.client(timeout=5).get("/v1/health") if alive else None
        ledger.check(SUITE, "server_alive_and_healthy_after_battery",
                     alive and h is not None and h.status == 200,
                     "%s, health %s" % (b.server.exit_description(), h.label() if h else "-"))
        ledger.check(SUITE, "no_crashes", not b.crashes,
                     "%d crash(es): %s" % (len(b.crashes), ["%s: %s" % (c_, how) for c_, how, _ in b.crashes])
                     if b.crashes else "")
        total = sum(v.get("sent", 0) for v in b.summary.values())
        print("  %d hostile requests in %.1f s, %d crash(es)" % (total, time.monotonic() - t0,
                                                                 len(b.crashes)), flush=True)
        return {"classes": b.summary, "crashes": [(c_, how) for c_, how, _ in b.crashes],
                "total": total}
    finally:
        b.server.kill()
