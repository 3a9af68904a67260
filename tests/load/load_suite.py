"""The load: N keep-alive clients mixing every kind of request for a fixed time, answers
spot-checked against reference.py, statuses counted by kind."""

import collections
import math
import os
import random
import struct
import threading
import time

import harness
import reference as R

SUITE = "load"

# Relative weights of the request kinds.
WEIGHTS = {
    "intersect_stateless": 3,
    "intersect_all": 1,
    "intersect_id": 3,
    "binary_f32": 2,
    "binary_f64": 2,
    "render": 1,
    "trace": 2,
    "explain": 2,
    "register": 1,
    "delete": 1,
    "points": 1,
}
# Statuses a correct server gives each kind (503 busy is allowed everywhere, and counted).
OK_STATUS = {k: {200} for k in WEIGHTS}
OK_STATUS["register"] = {201, 200}  # 200: the same bytes again (a reconnect's resend)

T_TOL_JSON = 1e-9  # exact path, doubles
T_TOL_F32 = 1e-6  # float32 records: the double answer rounded to float
T_TOL_FAST = 1e-5  # fast path (float traversal and intersection)


class Scene:
    def __init__(self, sid, doc, ref, bounds, kind):
        self.id, self.doc, self.ref, self.bounds, self.kind = sid, doc, ref, bounds, kind


def _bounds_of(resp_json):
    b = resp_json.get("bounds") if resp_json else None
    if not b:
        return (-6.0, -6.0, 4.0), (6.0, 6.0, 16.0)
    lo, hi = b["min"], b["max"]
    pad = [0.2 * (hi[i] - lo[i]) + 0.1 for i in range(3)]
    return (tuple(lo[i] - pad[i] for i in range(3)), tuple(hi[i] + pad[i] for i in range(3)))


def _doc_bounds(doc):
    lo = [math.inf] * 3
    hi = [-math.inf] * 3
    for o in doc["objects"]:
        pts = []
        if o["type"] == "sphere":
            c, r = o["center"], o["radius"]
            pts = [[c[i] - r for i in range(3)], [c[i] + r for i in range(3)]]
        elif o["type"] == "triangle":
            pts = o["vertices"]
        for p in pts:
            for i in range(3):
                lo[i] = min(lo[i], p[i])
                hi[i] = max(hi[i], p[i])
    return _bounds_of({"bounds": {"min": lo, "max": hi}})


class Stats:
    def __init__(self):
        self.lock = threading.Lock()
        self.by_kind = collections.defaultdict(collections.Counter)
        self.latency = collections.defaultdict(list)
        self.wrong = []  # (kind, detail)
        self.compared = collections.Counter()  # rays/answers compared with the reference, by kind
        self.ambiguous = 0
        self.busy_without_retry_after = 0
        self.unexpected = []  # (kind, label, body excerpt, what went before)
        self.errors_5xx = []
        # answers on a connection where the server sent 503 without (necessarily) reading the
        # request body: a server that keeps such a connection alive desynchronises it
        self.desync = []

    def record(self, kind, resp, prev=None):
        label = resp.label()
        tainted = getattr(threading.current_thread(), "tainted", False)
        with self.lock:
            self.by_kind[kind][label] += 1
            if resp.status is not None:
                self.latency[kind].append(resp.elapsed)
            if resp.status == 503 and resp.code() == "busy":
                if "retry-after" not in resp.headers:
                    self.busy_without_retry_after += 1
            elif tainted and (resp.status is None or resp.status not in OK_STATUS[kind]):
                self.desync.append((kind, label, resp.error or resp.body[:120], prev))
            elif resp.status is None or resp.status >= 500:
                self.errors_5xx.append((kind, label, (resp.error or resp.body[:200]), prev))
            elif resp.status not in OK_STATUS[kind]:
                self.unexpected.append((kind, label, resp.body[:200], prev))

    def wrong_answer(self, kind, detail):
        detail = str(detail)[:300]
        me = threading.current_thread()
        with self.lock:
            if getattr(me, "tainted", False):
                self.desync.append((kind, "wrong answer", detail, getattr(me, "prev", "")))
            else:
                self.wrong.append((kind, detail))

    def compared_n(self, kind, n=1):
        with self.lock:
            self.compared[kind] += n


def _compare_hit(stats, kind, ref, got_hit, t, obj, prim, tol, mesh_prims, where):
    """Compares one answer with the reference's; records a wrong answer."""
    if ref is None:
        stats.ambiguous += 1
        return
    stats.compared_n(kind)
    if ref["hit"] != got_hit:
        stats.wrong_answer(kind, "%s: hit=%s, reference hit=%s (t=%s)"
                           % (where, got_hit, ref["hit"], ref.get("t")))
        return
    if not got_hit:
        return
    if obj != ref["object"]:
        stats.wrong_answer(kind, "%s: object %s, reference %s" % (where, obj, ref["object"]))
        return
    if not R.rel_close(t, ref["t"], tol):
        stats.wrong_answer(kind, "%s: t=%r, reference t=%r (rel %.3g > %g)"
                           % (where, t, ref["t"], abs(t - ref["t"]) / abs(ref["t"]), tol))
        return
    if mesh_prims and prim is not None and prim != ref["primitive"]:
        stats.wrong_answer(kind, "%s: primitive %s, reference %s" % (where, prim, ref["primitive"]))


class Worker(threading.Thread):
    def __init__(self, idx, port, seed, deadline, stats, base, docs_pool, kinds, max_requests):
        super().__init__(daemon=True, name="load-%d" % idx)
        self.idx = idx
        self.client = harness.Client(port, timeout=60)
        self.rng = R.rng_for(seed, "worker", idx)
        self.deadline = deadline
        self.stats = stats
        self.base = base  # shared Scenes (registered before the run)
        self.docs_pool = docs_pool  # documents for the stateless calls
        self.mine = []  # Scenes this worker registered (it alone deletes them)
        self.deleted = []  # ids this worker deleted (acknowledged)
        self.kinds = kinds
        self.cum = []
        total = 0
        for k in kinds:
            total += WEIGHTS[k]
            self.cum.append((total, k))
        self.total = total
        self.counter = 0
        self.max_requests = max_requests
        self.sent = 0
        self.crashed = None
        self.prev = "first request of the connection"
        self.tainted = False

    def pick(self):
        x = self.rng.uniform(0, self.total)
        for c, k in self.cum:
            if x <= c:
                return k
        return self.cum[-1][1]

    def run(self):
        try:
            while time.monotonic() < self.deadline and self.sent < self.max_requests:
                kind = self.pick()
                resp = getattr(self, "do_" + kind)()
                self.sent += 1
                if resp is not None and resp.status == 503:
                    ra = resp.headers.get("retry-after", "0.05")
                    try:
                        time.sleep(min(float(ra), 0.2))
                    except ValueError:
                        time.sleep(0.05)
                if resp is not None and resp.status is None:
                    time.sleep(0.05)  # the server is gone or refusing: do not spin
        except Exception as e:  # noqa: BLE001 - a harness bug must show, not hang the run
            self.crashed = repr(e)
            self.stats.wrong_answer("harness", "worker %d: %r" % (self.idx, e))
        finally:
            self.client.close()

    # --- helpers ---
    def send(self, kind, method, path, body=None, content_type=None):
        resp = self.client.request(method, path, body=body, content_type=content_type)
        # what went before on this connection, for the failure message
        self.stats.record(kind, resp, prev=self.prev)
        if resp.status == 503:
            self.tainted = True
        elif self.client.conn is None:
            self.tainted = False  # the next request opens a new connection
        self.prev = "after %s %s %s -> %s on the same connection" % (kind, method, path[:60],
                                                                     resp.label())
        return resp

    def rays(self, scene_bounds, n):
        lo, hi = scene_bounds
        return [R.random_ray(self.rng, lo, hi) for _ in range(n)]

    def small_doc(self):
        if self.rng.random() < 0.7:
            return self.rng.choice(self.docs_pool)
        self.counter += 1
        return R.random_small_scene(self.rng, tag="w%d-s%d" % (self.idx, self.counter))

    def any_scene(self, small_only=False):
        pool = [s for s in self.base if not small_only or s.kind == "small"]
        if self.mine and self.rng.random() < 0.3:
            pool = self.mine
        return self.rng.choice(pool)

    # --- kinds ---
    def do_intersect_stateless(self):
        doc = self.small_doc()
        rays = self.rays(_doc_bounds(doc), self.rng.randint(1, 32))
        body = {"scene": doc, "precision": "exact",
                "rays": [{"origin": o, "direction": d} for o, d in rays]}
        resp = self.send("intersect_stateless", "POST", "/v1/intersect", body)
        if resp.status == 200:
            self.check_json_hits("intersect_stateless", resp, R.reference_objects(doc), rays,
                                 False, len(rays))
        return resp

    def do_intersect_all(self):
        doc = self.small_doc()
        rays = self.rays(_doc_bounds(doc), self.rng.randint(1, 16))
        body = {"scene": doc, "precision": "exact", "mode": "all", "fields": ["t", "object"],
                "rays": [{"origin": o, "direction": d} for o, d in rays]}
        resp = self.send("intersect_all", "POST", "/v1/intersect", body)
        if resp.status != 200:
            return resp
        ref = R.reference_objects(doc)
        try:
            hits = resp.json()["hits"]
        except Exception as e:  # noqa: BLE001
            self.stats.wrong_answer("intersect_all", "unreadable answer: %r" % e)
            return resp
        if len(hits) != len(rays):
            self.stats.wrong_answer("intersect_all", "%d answers for %d rays" % (len(hits), len(rays)))
            return resp
        for i, ((o, d), h) in enumerate(zip(rays, hits)):
            want = R.all_hits(ref, o, d)
            if want is None:
                self.stats.ambiguous += 1
                continue
            self.stats.compared_n("intersect_all")
            got = [x["t"] for x in h.get("hits", [])]
            if h.get("count") != len(want) or len(got) != len(want) or not all(
                    R.rel_close(a, b, T_TOL_JSON) for a, b in zip(got, want)):
                self.stats.wrong_answer("intersect_all", "ray %d %r %r: t %r, reference %r"
                                        % (i, o, d, got, want))
        return resp

    def do_intersect_id(self):
        sc = self.any_scene()
        n = self.rng.randint(1, 32)
        rays = self.rays(sc.bounds, n)
        body = {"precision": "exact", "rays": [{"origin": o, "direction": d} for o, d in rays]}
        resp = self.send("intersect_id", "POST", "/v1/scenes/%s/intersect" % sc.id, body)
        if resp.status == 200:
            k = 4 if sc.kind == "mesh" else 12
            self.check_json_hits("intersect_id", resp, sc.ref, rays, sc.kind == "mesh", k)
        return resp

    def check_json_hits(self, kind, resp, ref, rays, mesh, how_many):
        try:
            js = resp.json()
            hits = js["hits"]
        except Exception as e:  # noqa: BLE001
            self.stats.wrong_answer(kind, "unreadable answer: %r" % e)
            return
        if len(hits) != len(rays):
            self.stats.wrong_answer(kind, "%d answers for %d rays" % (len(hits), len(rays)))
            return
        if js.get("precision") != "exact":
            self.stats.wrong_answer(kind, "asked for exact, answered by %r" % js.get("precision"))
        idx = list(range(len(rays)))
        self.rng.shuffle(idx)
        for i in idx[:how_many]:
            o, d = rays[i]
            h = hits[i]
            _compare_hit(self.stats, kind, R.closest(ref, o, d), bool(h.get("hit")), h.get("t"),
                         h.get("object"), h.get("primitive"), T_TOL_JSON, mesh,
                         "ray %d o=%r d=%r" % (i, o, d))

    def do_binary_f32(self):
        return self.binary("binary_f32", "float32")

    def do_binary_f64(self):
        return self.binary("binary_f64", "float64")

    def binary(self, kind, dtype):
        sc = self.any_scene()
        n = self.rng.randint(64, 512)
        rays = self.rays(sc.bounds, n)
        fmt_in = "<8f" if dtype == "float32" else "<8d"
        fmt_out = "<fIIfffff" if dtype == "float32" else "<dIIddddd"
        if dtype == "float32":
            rays = [([R.f32(x) for x in o], [R.f32(x) for x in d]) for o, d in rays]
        body = b"".join(struct.pack(fmt_in, *o, *d, 0.0, math.inf) for o, d in rays)
        precision = self.rng.choice(["exact", "exact", "refined", "fast"])
        path = "/v1/scenes/%s/intersect?mode=closest&precision=%s&dtype=%s" % (sc.id, precision, dtype)
        resp = self.send(kind, "POST", path, body, content_type="application/octet-stream")
        if resp.status != 200:
            return resp
        size = struct.calcsize(fmt_out)
        if len(resp.body) != size * n:
            self.stats.wrong_answer(kind, "%d bytes for %d records of %d" % (len(resp.body), n, size))
            return resp
        answered = resp.headers.get("x-precision")
        if answered not in ("exact", "refined", "fast"):
            self.stats.wrong_answer(kind, "X-Precision %r" % answered)
            return resp
        if answered == "fast":
            tol = T_TOL_FAST
        else:
            tol = T_TOL_F32 if dtype == "float32" else T_TOL_JSON
        mesh = sc.kind == "mesh"
        for i in self.rng.sample(range(n), 4 if mesh else 12):
            t, obj, prim, u, v, nx, ny, nz = struct.unpack_from(fmt_out, resp.body, i * size)
            o, d = rays[i]
            got_hit = not math.isinf(t)
            if not got_hit and (obj != 0xFFFFFFFF or prim != 0xFFFFFFFF):
                self.stats.wrong_answer(kind, "ray %d: miss with ids %x %x" % (i, obj, prim))
                continue
            ref = R.closest(sc.ref, o, d)
            if answered == "fast" and ref is not None and ref["hit"] != got_hit:
                # fast is not watertight (docs/api.md): near edges it may pass through
                self.stats.ambiguous += 1
                continue
            _compare_hit(self.stats, kind, ref, got_hit, t, obj, prim, tol,
                         mesh and answered != "fast",
                         "ray %d (%s, %s) o=%r d=%r" % (i, dtype, answered, o, d))
        return resp

    def do_render(self):
        sc = self.any_scene()
        w, h = self.rng.randint(8, 64), self.rng.randint(8, 48)
        body = {"width": w, "height": h, "spp": self.rng.choice([1, 1, 2]),
                "shading": self.rng.choice(["phong", "phong", "normal", "depth", "object_id"]),
                "max_depth": 3}
        resp = self.send("render", "POST", "/v1/scenes/%s/render" % sc.id, body)
        if resp.status == 200:
            self.stats.compared_n("render")
            b = resp.body
            if b[:8] != b"\x89PNG\r\n\x1a\n" or b[12:16] != b"IHDR":
                self.stats.wrong_answer("render", "not a PNG: %r" % b[:16])
            else:
                gw, gh = struct.unpack(">II", b[16:24])
                if (gw, gh) != (w, h):
                    self.stats.wrong_answer("render", "PNG %dx%d, asked %dx%d" % (gw, gh, w, h))
            if "x-rays" not in resp.headers:
                self.stats.wrong_answer("render", "no X-Rays header")
        return resp

    def do_trace(self):
        sc = self.any_scene(small_only=True)
        (o, d), = self.rays(sc.bounds, 1)
        body = {"ray": {"origin": o, "direction": d}, "max_depth": 3, "precision": "exact"}
        resp = self.send("trace", "POST", "/v1/scenes/%s/trace" % sc.id, body)
        if resp.status == 200:
            try:
                tree = resp.json()["tree"]
            except Exception as e:  # noqa: BLE001
                self.stats.wrong_answer("trace", "unreadable answer: %r" % e)
                return resp
            _compare_hit(self.stats, "trace", R.closest(sc.ref, o, d), tree is not None,
                         tree and tree.get("t"), tree and tree.get("object"), None, T_TOL_JSON,
                         False, "trace o=%r d=%r" % (o, d))
        return resp

    def do_explain(self):
        doc = self.small_doc()
        (o, d), = self.rays(_doc_bounds(doc), 1)
        resp = self.send("explain", "POST", "/v1/explain",
                         {"scene": doc, "ray": {"origin": o, "direction": d}})
        if resp.status == 200:
            try:
                js = resp.json()
                fh = js["first_hit"]
            except Exception as e:  # noqa: BLE001
                self.stats.wrong_answer("explain", "unreadable answer: %r" % e)
                return resp
            if len(js.get("objects", [])) != len(doc["objects"]):
                self.stats.wrong_answer("explain", "%d objects explained of %d"
                                        % (len(js.get("objects", [])), len(doc["objects"])))
            _compare_hit(self.stats, "explain", R.closest(R.reference_objects(doc), o, d),
                         fh is not None, fh and fh.get("t"), fh and fh.get("object"), None,
                         T_TOL_JSON, False, "explain o=%r d=%r" % (o, d))
        return resp

    def do_register(self):
        self.counter += 1
        doc = R.random_small_scene(self.rng, tag="reg-w%d-%d-%d" % (self.idx, self.counter,
                                                                    self.rng.getrandbits(32)))
        resp = self.send("register", "POST", "/v1/scenes", doc)
        if resp.status in (200, 201):
            try:
                js = resp.json()
                sid = js["id"]
            except Exception as e:  # noqa: BLE001
                self.stats.wrong_answer("register", "unreadable answer: %r" % e)
                return resp
            self.stats.compared_n("register")
            if js.get("objects") != len(doc["objects"]):
                self.stats.wrong_answer("register", "%s: objects %r, sent %d"
                                        % (sid, js.get("objects"), len(doc["objects"])))
            self.mine.append(Scene(sid, doc, R.reference_objects(doc), _bounds_of(js), "small"))
        return resp

    def do_delete(self):
        if not self.mine:
            return self.do_register()
        sc = self.mine.pop(self.rng.randrange(len(self.mine)))
        resp = self.send("delete", "DELETE", "/v1/scenes/%s" % sc.id)
        if resp.status == 200:
            self.stats.compared_n("delete")
            self.deleted.append(sc.id)
            try:
                if resp.json().get("deleted") is not True:
                    self.stats.wrong_answer("delete", "%s: answer %r" % (sc.id, resp.body[:100]))
            except Exception as e:  # noqa: BLE001
                self.stats.wrong_answer("delete", "unreadable answer: %r" % e)
            g = self.client.get("/v1/scenes/%s" % sc.id)
            if g.status != 404 or g.code() != "scene_not_found":
                self.stats.wrong_answer("delete", "%s: GET after DELETE answered %s"
                                        % (sc.id, g.label()))
        elif resp.status is not None and resp.status != 503:
            self.mine.append(sc)
        return resp

    def do_points(self):
        sc = self.any_scene(small_only=True)
        spheres = [o for o in sc.ref if o[0] == "sphere"]
        if len(spheres) != len(sc.ref):
            sc = self.base[0]  # the tutorial: spheres only
            spheres = sc.ref
        lo, hi = sc.bounds
        pts = [[self.rng.uniform(lo[i], hi[i]) for i in range(3)] for _ in range(8)]
        resp = self.send("points", "POST", "/v1/scenes/%s/points" % sc.id,
                         {"points": pts, "query": "distance"})
        if resp.status == 200:
            try:
                res = resp.json()["results"]
            except Exception as e:  # noqa: BLE001
                self.stats.wrong_answer("points", "unreadable answer: %r" % e)
                return resp
            for p, r in zip(pts, res):
                want = min(abs(math.dist(p, c) - rad) for _, c, rad in spheres)
                self.stats.compared_n("points")
                if not R.rel_close(r.get("distance", math.nan), want, 1e-9) and abs(
                        r.get("distance", math.nan) - want) > 1e-12:
                    self.stats.wrong_answer("points", "point %r: distance %r, reference %r"
                                            % (p, r.get("distance"), want))
        return resp


def run(opts, ledger, tmp_root):
    """Returns the summary the report prints."""
    summary = run_load(opts, ledger, tmp_root)
    summary["busy_probe"] = busy_probe(opts, ledger, tmp_root)
    return summary


Q1_T = 7.267949192431123  # the tutorial's question 1: sphere 3 at t = 4 + ... (docs/api.md)


def busy_probe(opts, ledger, tmp_root):
    """A server with --max-concurrent 1, kept busy by two clients sending heavy stateless
    batches, and four keep-alive clients sending small binary and JSON intersects: every 503
    must be `busy` with Retry-After, and the next request on the same connection must get its
    own, right answer (a server that answers 503 before reading the body must drain it or close
    the connection)."""
    print("\n== load: busy probe (--max-concurrent 1)", flush=True)
    d = os.path.join(tmp_root, "busy")
    os.makedirs(d)
    server = harness.ServerProcess(opts.server, args=["--max-concurrent", "1"], log_dir=d, name="busy")
    try:
        c = server.client()
        r = c.post("/v1/scenes", R.tutorial_scene())
        sid = r.json()["id"]
        c.close()
        mdoc, _ = R.mesh_scene()
        heavy = {"scene": mdoc, "precision": "exact",
                 "rays": [{"origin": [0.001 * k, 0, 0], "direction": [0, 0, 1]} for k in range(4000)]}
        stop = time.monotonic() + (3.0 if opts.mode == "quick" else 10.0)
        counts = collections.Counter()
        problems = []
        lock = threading.Lock()
        q1_f32 = R.f32(Q1_T)

        def hog():
            cl = server.client()
            n = 0
            while time.monotonic() < stop and n < 2000:
                cl.post("/v1/intersect", heavy)
                n += 1
            cl.close()

        def prober(k):
            cl = server.client()
            after_busy = False
            busy_kind = None
            n = 0
            body = struct.pack("<8f", 0, 0, 0, 0, 0, 1, 0, math.inf) * 256
            while time.monotonic() < stop and n < 20000:
                n += 1
                kind = "binary" if n % 2 else "JSON"
                if n % 2:
                    r = cl.post("/v1/scenes/%s/intersect?dtype=float32" % sid, body,
                                content_type="application/octet-stream")
                    good = (r.status == 200 and len(r.body) == 32 * 256
                            and struct.unpack_from("<f", r.body, 0)[0] == q1_f32)
                else:
                    r = cl.post("/v1/scenes/%s/intersect" % sid,
                                {"rays": [{"origin": [0, 0, 0], "direction": [0, 0, 1]}]})
                    try:
                        good = r.status == 200 and r.json()["hits"][0]["t"] == Q1_T
                    except Exception:  # noqa: BLE001
                        good = False
                busy = r.status == 503 and r.code() == "busy"
                with lock:
                    counts[r.label()] += 1
                    if busy and "retry-after" not in r.headers:
                        counts["busy without Retry-After"] += 1
                    if not busy and not good and after_busy:
                        problems.append("%s intersect after a 503 to a %s intersect on this "
                                        "connection: %s %r" % (kind, busy_kind, r.label(),
                                                                (r.error or r.body[:80])))
                    elif not busy and not good:
                        problems.append("%s intersect: %s %r" % (kind, r.label(), (r.error or r.body[:80])))
                after_busy = busy or (after_busy and cl.conn is not None)
                if busy:
                    busy_kind = kind
                if busy:
                    time.sleep(0.01)
            cl.close()

        threads = [threading.Thread(target=hog, daemon=True) for _ in range(2)]
        threads += [threading.Thread(target=prober, args=(k,), daemon=True) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=60)
        busy = sum(v for k, v in counts.items() if k == "503 busy")
        no_ra = counts.pop("busy without Retry-After", 0)
        print("  probes: %s" % dict(counts), flush=True)
        ledger.check(SUITE, "busy_probe.server_answers_busy", busy > 0,
                     "%d of %d probe requests answered 503 busy" % (busy, sum(counts.values())))
        ledger.check(SUITE, "busy_probe.busy_carries_retry_after", busy > 0 and no_ra == 0,
                     "%d of %d 503 busy answers had no Retry-After" % (no_ra, busy))
        kinds_seen = collections.Counter(p.split(":")[0] for p in problems)
        ledger.check(SUITE, "busy_probe.next_request_on_connection_answered_right", not problems,
                     "%d wrong answers %s; e.g. %s" % (len(problems), dict(kinds_seen), problems[:2])
                     if problems else "")
        ledger.check(SUITE, "busy_probe.server_alive", server.alive(), server.exit_description())
        return {"statuses": dict(counts), "busy_without_retry_after": no_ra,
                "wrong_after_busy": len(problems)}
    finally:
        server.kill()


def run_load(opts, ledger, tmp_root):
    print("\n== load: %d clients for %.0f s" % (opts.clients, opts.duration), flush=True)
    data_dir = os.path.join(tmp_root, "load-data")
    os.makedirs(data_dir)
    args = []
    if opts.max_concurrent:
        args += ["--max-concurrent", str(opts.max_concurrent)]
    server = harness.ServerProcess(opts.server, args=args, data_dir=data_dir,
                                   log_dir=tmp_root, name="load")
    summary = {"clients": opts.clients, "duration_s": opts.duration,
               "server_args": server.command()[1:]}
    try:
        return _run(opts, ledger, server, summary)
    finally:
        server.kill()


def _run(opts, ledger, server, summary):
    c = server.client()
    rng = R.rng_for(opts.seed, "load-setup")
    base = []
    setup = [("small", R.tutorial_scene(), None)]
    for k in range(6):
        setup.append(("small", R.random_small_scene(rng, tag="base-%d" % k), None))
    mdoc, geo = R.mesh_scene()
    setup.append(("mesh", mdoc, geo))
    for kind, doc, g in setup:
        r = c.post("/v1/scenes", doc)
        if not ledger.check(SUITE, "setup_register_%s_%d" % (kind, len(base)), r.status == 201,
                            "" if r.status == 201 else "answered " + r.label()):
            return summary
        js = r.json()
        base.append(Scene(js["id"], doc, R.reference_objects(doc, g), _bounds_of(js), kind))

    kinds = [k for k in WEIGHTS]
    probe = c.post("/v1/scenes/%s/points" % base[0].id, {"points": [[0, 0, 0]], "query": "distance"})
    if probe.status == 404 and probe.code() == "not_found":
        kinds.remove("points")
        summary["points"] = "skipped: POST /v1/scenes/{id}/points answered 404 not_found"
        print("  points: the server answers 404 not_found; that kind is skipped", flush=True)
    else:
        summary["points"] = "probe answered %s" % probe.label()
    c.close()
    docs_pool = [R.random_small_scene(rng, tag="pool-%d" % k) for k in range(40)]

    stats = Stats()
    summary["rss_before"] = server.memory()
    t0 = time.monotonic()
    deadline = t0 + opts.duration
    workers = [Worker(i, server.port, opts.seed, deadline, stats, base, docs_pool, kinds,
                      opts.max_requests_per_client) for i in range(opts.clients)]
    for w in workers:
        w.start()
    for w in workers:
        w.join(timeout=max(1.0, deadline - time.monotonic()) + 90)
    elapsed = time.monotonic() - t0
    hung = [w.name for w in workers if w.is_alive()]
    summary["rss_after"] = server.memory()
    summary["elapsed_s"] = elapsed
    total = sum(sum(cn.values()) for cn in stats.by_kind.values())
    summary["requests"] = total
    summary["rps"] = total / elapsed if elapsed > 0 else 0.0
    summary["by_kind"] = {k: dict(v) for k, v in sorted(stats.by_kind.items())}
    summary["latency"] = {k: (harness.percentile(v, 50), harness.percentile(v, 99), len(v))
                          for k, v in sorted(stats.latency.items())}
    summary["compared"] = dict(stats.compared)
    summary["ambiguous"] = stats.ambiguous
    summary["wrong"] = len(stats.wrong)
    summary["wrong_examples"] = [("%s: %s" % w) for w in stats.wrong[:5]]
    summary["5xx"] = len(stats.errors_5xx)
    summary["desync_after_busy"] = len(stats.desync)
    busy = sum(v.get("503 busy", 0) for v in stats.by_kind.values())
    summary["busy"] = busy
    summary["kinds"] = kinds

    print("  %d requests in %.1f s (%.0f/s), by kind and status:" % (total, elapsed, summary["rps"]))
    for k, v in summary["by_kind"].items():
        p50, p99, n = summary["latency"].get(k, (math.nan, math.nan, 0))
        print("    %-20s %-40s p50 %7.2f ms  p99 %7.2f ms" % (k, dict(v), p50 * 1e3, p99 * 1e3))
    print("  compared with the reference: %s; ambiguous rays skipped: %d"
          % (dict(stats.compared), stats.ambiguous))
    print("  server memory before %s, after %s" % (_mem(summary["rss_before"]), _mem(summary["rss_after"])),
          flush=True)

    ledger.check(SUITE, "server_alive_after_load", server.alive(), server.exit_description())
    ledger.check(SUITE, "no_hung_clients", not hung, ", ".join(hung))
    ledger.check(SUITE, "no_5xx_but_busy", not stats.errors_5xx,
                 "%d: %s" % (len(stats.errors_5xx), stats.errors_5xx[:3]) if stats.errors_5xx else
                 "0 of %d requests" % total)
    ledger.check(SUITE, "busy_carries_retry_after", stats.busy_without_retry_after == 0,
                 "%d of %d 503 busy answers had no Retry-After" % (stats.busy_without_retry_after, busy)
                 if stats.busy_without_retry_after else "%d busy answers, all with Retry-After" % busy)
    ledger.check(SUITE, "no_unexpected_status", not stats.unexpected,
                 "%d, e.g. %s" % (len(stats.unexpected), stats.unexpected[:3]) if stats.unexpected else "")
    ledger.check(SUITE, "answers_match_reference", not stats.wrong,
                 "%d wrong: %s" % (len(stats.wrong), stats.wrong[:3]) if stats.wrong else
                 "%d answers compared" % sum(stats.compared.values()))
    ledger.check(SUITE, "keepalive_in_sync_after_busy", not stats.desync,
                 "%d answers after a 503 on the same kept-alive connection were wrong, e.g. %s"
                 % (len(stats.desync), stats.desync[:2]) if stats.desync else "")
    missing = [k for k in kinds if not stats.by_kind.get(k)]
    ledger.check(SUITE, "every_kind_sent", not missing, "never sent: %s" % missing if missing else "")
    ray_checks = sum(v for k, v in stats.compared.items()
                     if k not in ("render", "register", "delete"))
    ledger.check(SUITE, "reference_spot_checks_made", ray_checks >= 50,
                 "%d ray answers compared" % ray_checks)

    # After the run: the registry holds the base scenes and every registered, not deleted one.
    if server.alive():
        c = server.client()
        r = c.get("/v1/scenes")
        listed = {s["id"] for s in r.json().get("scenes", [])} if r.status == 200 else set()
        kept = {s.id for w in workers for s in w.mine} | {s.id for s in base}
        gone = {sid for w in workers for sid in w.deleted}
        ledger.check(SUITE, "registry_matches_acknowledged_writes",
                     kept <= listed and not (gone & listed),
                     "missing %s, deleted but listed %s" % (sorted(kept - listed)[:3],
                                                            sorted(gone & listed)[:3]))
        c.close()
    return summary


def _mem(m):
    if not m:
        return "?"
    return "VmRSS %.1f MB (VmHWM %.1f MB)" % (m.get("VmRSS", 0) / 2 ** 20, m.get("VmHWM", 0) / 2 ** 20)
