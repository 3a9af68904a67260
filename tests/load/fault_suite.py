"""Faults: kill -9 during registration, deletion and a render, a full disk and a read-only data
dir. Each scenario starts its own server with its own temporary --data-dir.

The data dir's layout (server/scene_registry.cpp): DIR/scenes/<id>/ holds `body` (the request
bytes), `file0..N` (copies of files the scene read) and `meta.json`; a registration writes them
under DIR/tmp/<id>.<pid>.<n>/, fsyncs each file and the directory, renames it to scenes/<id>/ and
fsyncs scenes/; a deletion renames scenes/<id>/ to tmp/<id>.deleted/, fsyncs scenes/ and removes
it. A server opening DIR empties tmp/ (writes that never reached their rename were never
acknowledged). So after a crash and restart tmp/ must be empty and every scenes/<id>/ whole.
"""

import os
import threading
import time
import traceback

import expected as X
import harness
import reference as R

SUITE = "faults"


def fixed_rays():
    rng = R.rng_for("fixed-rays")
    rays = [([0.0, 0.0, 0.0], [0.0, 0.0, 1.0])]
    rays += [R.random_ray(rng, (-5, -5, 5), (5, 5, 15)) for _ in range(15)]
    return [{"origin": o, "direction": d} for o, d in rays]


RAYS = fixed_rays()


def answer(client, sid):
    """The JSON answer of scene `sid` to the fixed rays at precision exact, or a label."""
    r = client.post("/v1/scenes/%s/intersect" % sid, {"rays": RAYS, "precision": "exact"})
    if r.status != 200:
        return "status " + r.label()
    return r.json()


def stateless_answer(client, doc):
    r = client.post("/v1/intersect", {"scene": doc, "rays": RAYS, "precision": "exact"})
    if r.status != 200:
        return "status " + r.label()
    return r.json()


def listed_ids(client):
    r = client.get("/v1/scenes")
    if r.status != 200:
        return None
    return [s["id"] for s in r.json().get("scenes", [])]


def check_status(ledger, scenario, key, resp):
    """A check against expected.EXPECTED[key]; the message names what came and what was due."""
    ok = X.matches(key, resp.status, resp.code())
    name = key.split(".", 2)[-1] if key.count(".") >= 2 else key
    return ledger.check(SUITE, "%s.%s" % (scenario, name), ok,
                        "answered %s; expected %s" % (resp.label(), X.describe(key)))


def run(opts, ledger, tmp_root):
    summary = {}
    for name, fn in (("kill_during_registration", kill_during_registration),
                     ("kill_during_deletion", kill_during_deletion),
                     ("kill_during_render", kill_during_render),
                     ("full_disk", full_disk),
                     ("read_only", read_only)):
        print("\n== faults: %s" % name, flush=True)
        d = os.path.join(tmp_root, "fault-" + name)
        os.makedirs(d)
        t0 = time.monotonic()
        try:
            summary[name] = fn(opts, ledger, d) or {}
        except harness.ServerStartError as e:
            ledger.check(SUITE, name + ".server_starts", False, str(e))
            summary[name] = {"error": str(e)}
        except Exception as e:  # noqa: BLE001 - one scenario's harness error must not stop the rest
            ledger.check(SUITE, name + ".scenario_ran", False,
                         "%r\n%s" % (e, traceback.format_exc(limit=4)))
            summary[name] = {"error": repr(e)}
        finally:
            harness.stop_all()
        summary[name]["seconds"] = time.monotonic() - t0
    return summary


def _after_restart(ledger, scenario, server, data_dir, acked, gone=(), must_keep=None):
    """The checks every kill -9 scenario makes after the restart. `acked`: {id: (doc, answer or
    None)} of acknowledged registrations; `gone`: ids whose deletion was acknowledged."""
    c = server.client()
    listed = listed_ids(c)
    ledger.check(SUITE, scenario + ".restarted_server_lists_scenes", listed is not None)
    listed = set(listed or [])
    keep = set(acked) - set(gone) if must_keep is None else set(must_keep)
    missing = sorted(keep - listed)
    ledger.check(SUITE, scenario + ".acknowledged_scenes_survive", not missing,
                 "%d of %d acknowledged scenes listed; missing %s"
                 % (len(keep) - len(missing), len(keep), missing[:3]))
    differ = []
    compared = 0
    for sid in sorted(keep):
        doc, before = acked[sid]
        if before is None:
            before = stateless_answer(c, doc)
        now = answer(c, sid)
        compared += 1
        if now != before:
            differ.append("%s: before %s, after %s" % (sid, str(before)[:120], str(now)[:120]))
    ledger.check(SUITE, scenario + ".answers_identical_after_restart", not differ,
                 "%d of %d differ: %s" % (len(differ), compared, differ[:2]) if differ else
                 "%d scenes x %d rays at precision exact" % (compared, len(RAYS)))
    if gone:
        still = []
        for sid in sorted(gone):
            r = c.get("/v1/scenes/%s" % sid)
            if r.status != 404 or sid in listed:
                still.append("%s (%s)" % (sid, r.label()))
        ledger.check(SUITE, scenario + ".acknowledged_deletions_stay_deleted", not still,
                     "%d of %d deleted scenes came back: %s" % (len(still), len(gone), still[:3])
                     if still else "%d deleted scenes all 404" % len(gone))
    others = sorted(listed - set(acked))
    bad = []
    for sid in others:
        r = c.post("/v1/scenes/%s/intersect" % sid, {"rays": RAYS[:2], "precision": "exact"})
        if r.status != 200:
            bad.append("%s: %s" % (sid, r.label()))
    ledger.check(SUITE, scenario + ".unacknowledged_but_listed_scenes_work", not bad,
                 "%d scenes written but not acknowledged, all answer" % len(others) if not bad
                 else "%s" % bad[:3])
    problems = harness.check_data_dir(data_dir, listed)
    ledger.check(SUITE, scenario + ".data_dir_clean_after_restart", not problems, "; ".join(problems[:4]))
    c.close()
    return {"listed_after_restart": len(listed), "unacknowledged_listed": len(others)}


def _tmp_leftovers(data_dir):
    t = os.path.join(data_dir, "tmp")
    return sorted(os.listdir(t)) if os.path.isdir(t) else []


def kill_during_registration(opts, ledger, d):
    data = os.path.join(d, "data")
    server = harness.ServerProcess(opts.server, data_dir=data, log_dir=d, name="reg")
    acked = {}
    lock = threading.Lock()
    stop = threading.Event()
    in_flight = [0]

    def writer(k):
        c = server.client(timeout=10)
        rng = R.rng_for(opts.seed, "kill-reg", k)
        for n in range(400):
            if stop.is_set():
                break
            doc = R.random_small_scene(rng, tag="kill-reg-%d-%d" % (k, n), spheres=(4, 12))
            with lock:
                in_flight[0] += 1
            r = c.post("/v1/scenes", doc)
            with lock:
                in_flight[0] -= 1
            if r.status in (200, 201):
                sid = r.json()["id"]
                a = answer(c, sid)
                with lock:
                    acked[sid] = (doc, a if isinstance(a, dict) else None)
            elif r.status is None:
                break
        c.close()

    threads = [threading.Thread(target=writer, args=(k,), daemon=True) for k in range(8)]
    for t in threads:
        t.start()
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        with lock:
            if len(acked) >= 40:
                break
        time.sleep(0.01)
    # then the first moment at least 4 registrations are in flight (for at most 1 s)
    deadline = time.monotonic() + 1
    while time.monotonic() < deadline:
        with lock:
            if in_flight[0] >= 4:
                break
        time.sleep(0.0005)
    with lock:
        flying = in_flight[0]
    server.kill()  # kill -9 while registrations are in flight
    stop.set()
    for t in threads:
        t.join(timeout=15)
    left = _tmp_leftovers(data)
    print("  killed with %d registrations in flight, %d acknowledged; tmp/ after the kill: %d entries"
          % (flying, len(acked), len(left)), flush=True)
    ledger.check(SUITE, "kill_during_registration.killed_mid_write", flying > 0 and acked,
                 "%d in flight, %d acknowledged at the kill" % (flying, len(acked)))
    server.start()
    s = _after_restart(ledger, "kill_during_registration", server, data, acked)
    server.kill()
    s.update({"acknowledged": len(acked), "in_flight_at_kill": flying, "tmp_after_kill": len(left)})
    return s


def kill_during_deletion(opts, ledger, d):
    data = os.path.join(d, "data")
    server = harness.ServerProcess(opts.server, data_dir=data, log_dir=d, name="del")
    c = server.client()
    rng = R.rng_for(opts.seed, "kill-del")
    acked = {}
    for n in range(80):
        doc = R.random_small_scene(rng, tag="kill-del-%d" % n, spheres=(4, 12))
        r = c.post("/v1/scenes", doc)
        if r.status == 201:
            sid = r.json()["id"]
            acked[sid] = (doc, answer(c, sid))
    c.close()
    ledger.check(SUITE, "kill_during_deletion.setup_registered", len(acked) == 80,
                 "%d of 80 registered" % len(acked))
    ids = sorted(acked)
    to_delete = ids[:60]  # the last 20 are never sent a DELETE
    queue = list(to_delete)
    lock = threading.Lock()
    deleted = set()
    sent = set()
    in_flight = [0]

    def deleter():
        cl = server.client(timeout=10)
        while True:
            with lock:
                if not queue:
                    break
                sid = queue.pop()
                sent.add(sid)
                in_flight[0] += 1
            r = cl.delete("/v1/scenes/%s" % sid)
            with lock:
                in_flight[0] -= 1
                if r.status == 200:
                    deleted.add(sid)
            if r.status is None:
                break
        cl.close()

    threads = [threading.Thread(target=deleter, daemon=True) for _ in range(6)]
    for t in threads:
        t.start()
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline:
        with lock:
            if len(deleted) >= 25:
                break
        time.sleep(0.002)
    with lock:
        flying = in_flight[0]
    server.kill()
    for t in threads:
        t.join(timeout=15)
    left = _tmp_leftovers(data)
    print("  killed with %d deletions in flight, %d acknowledged, %d never sent; tmp/ after the kill: %s"
          % (flying, len(deleted), len(ids) - len(sent), left[:3]), flush=True)
    ledger.check(SUITE, "kill_during_deletion.killed_mid_deletions", 0 < len(deleted) < len(to_delete),
                 "%d of %d deletions acknowledged at the kill, %d in flight"
                 % (len(deleted), len(to_delete), flying))
    server.start()
    untouched = set(ids) - sent
    s = _after_restart(ledger, "kill_during_deletion", server, data, acked, gone=deleted,
                       must_keep=untouched)
    server.kill()
    s.update({"registered": len(acked), "deleted_acknowledged": len(deleted), "in_flight_at_kill": flying})
    return s


def heavy_render_scene():
    """The mesh scene with a mirror icosphere, glass spheres and a point light: shadows,
    reflection and refraction, so a render is long."""
    doc, _ = R.mesh_scene()
    doc = dict(doc)
    doc["objects"] = [dict(o) for o in doc["objects"]]
    doc["objects"][0]["material"] = "mirror"
    doc["objects"][1]["material"] = "glass"
    doc["objects"][2]["material"] = "glass"
    doc["materials"] = {"mirror": {"reflectivity": 0.9},
                        "glass": {"transparency": 0.9, "ior": 1.5, "reflectivity": 0.1}}
    doc["lights"] = [{"type": "ambient", "intensity": [0.2, 0.2, 0.2]},
                     {"type": "point", "position": [5, 5, 0], "intensity": [1, 1, 1]}]
    return doc


def kill_during_render(opts, ledger, d):
    data = os.path.join(d, "data")
    server = harness.ServerProcess(opts.server, data_dir=data, log_dir=d, name="render")
    c = server.client()
    acked = {}
    heavy = heavy_render_scene()
    for doc in (R.tutorial_scene(), heavy):
        r = c.post("/v1/scenes", doc)
        if r.status == 201:
            sid = r.json()["id"]
            acked[sid] = (doc, answer(c, sid))
    c.close()
    ledger.check(SUITE, "kill_during_render.setup_registered", len(acked) == 2, "%d of 2" % len(acked))
    heavy_id = [k for k, v in acked.items() if v[0] is heavy][0]
    # The first render still running 0.8 s after it was sent is killed; a faster machine
    # finishing one moves on to the next, larger one (all within the default --max-pixels).
    attempts = [(1000, 1000, 16, 5), (2000, 2000, 4, 16), (4000, 4000, 1, 32)]
    running = False
    r = None
    for w, h, spp, depth in attempts:
        result = {}

        def render():
            cl = server.client(timeout=120)
            result["resp"] = cl.post("/v1/scenes/%s/render" % heavy_id,
                                     {"width": w, "height": h, "spp": spp, "max_depth": depth,
                                      "shading": "phong"})
            cl.close()

        t = threading.Thread(target=render, daemon=True)
        t.start()
        time.sleep(0.8)
        running = "resp" not in result
        if running:
            rss = server.memory()
            server.kill()
            t.join(timeout=15)
            r = result.get("resp")
            print("  killed during a %dx%d spp %d render (server %s)" % (w, h, spp, rss), flush=True)
            break
        t.join(timeout=120)
        r = result.get("resp")
        print("  a %dx%d spp %d render answered %s within 0.8 s; a larger one"
              % (w, h, spp, r.label() if r else "?"), flush=True)
    ledger.check(SUITE, "kill_during_render.killed_mid_render", running,
                 "" if running else "every render answered within 0.8 s (last: %s)"
                 % (r.label() if r else "?"))
    ledger.check(SUITE, "kill_during_render.no_partial_image", r is None or r.status is None,
                 "the client got %s" % (r.label() if r else "nothing") if running else "not killed")
    if server.alive():
        server.kill()
    server.start()
    s = _after_restart(ledger, "kill_during_render", server, data, acked)
    server.kill()
    return s


# --- storage faults --------------------------------------------------------------------------

def _big_doc(rng, tag, n):
    """A scene of n spheres (about 100 bytes each)."""
    return R.random_small_scene(rng, tag=tag, spheres=(n, n), triangles=(0, 0))


def full_disk(opts, ledger, d):
    mnt = os.path.join(d, "mnt")
    os.makedirs(mnt)
    ok, how = harness.mount_tmpfs(mnt, "256k")
    fsize = None
    if not ok:
        # Not root, or no tmpfs: a per-file size limit in the server's preexec instead. Only a
        # file larger than the limit fails, so the filling document below is made larger.
        fsize = 48 * 1024
        how = "RLIMIT_FSIZE=%d (tmpfs: %s)" % (fsize, how)
    print("  data dir: %s" % how, flush=True)
    try:
        return _full_disk(opts, ledger, d, mnt, fsize, how)
    finally:
        harness.stop_all()
        harness.umount(mnt)


def _full_disk(opts, ledger, d, data, fsize, how):
    server = harness.ServerProcess(opts.server, data_dir=data, log_dir=d, name="full",
                                   fsize_limit=fsize)
    c = server.client()
    rng = R.rng_for(opts.seed, "full-disk")
    acked = {}
    full = None
    for n in range(400):
        size = 40 if (fsize is None or n < 5) else 800  # 800 spheres ~ 80 KB > the limit
        doc = _big_doc(rng, "full-%d" % n, size)
        r = c.post("/v1/scenes", doc)
        if r.status in (200, 201):
            sid = r.json()["id"]
            acked[sid] = (doc, answer(c, sid))
            continue
        full = (doc, r)
        break
    print("  %d scenes registered before the first refusal: %s"
          % (len(acked), full[1].label() if full else "none"), flush=True)
    if not ledger.check(SUITE, "full_disk.fills_up", full is not None,
                        "" if full else "400 registrations fitted"):
        return {"data_dir": how}
    check_status(ledger, "full_disk", "faults.full_disk.register_when_full", full[1])
    again = [c.post("/v1/scenes", _big_doc(rng, "full-again-%d" % k, 40 if fsize is None else 800))
             for k in range(3)]
    labels = [r.label() for r in again]
    ledger.check(SUITE, "full_disk.stays_refused_the_same_way", all(
        X.matches("faults.full_disk.register_when_full", r.status, r.code()) for r in again),
        "three more registrations: %s" % labels)
    ledger.check(SUITE, "full_disk.server_alive", server.alive(), server.exit_description())
    listed = listed_ids(c)
    ledger.check(SUITE, "full_disk.nothing_half_registered",
                 listed is not None and set(listed) == set(acked),
                 "listed %d, acknowledged %d" % (len(listed or []), len(acked)))
    problems = harness.check_data_dir(data, listed)
    ledger.check(SUITE, "full_disk.data_dir_clean", not problems, "; ".join(problems[:4]))
    differ = [sid for sid, (doc, a) in acked.items() if answer(c, sid) != a]
    ledger.check(SUITE, "full_disk.queries_still_answer", not differ,
                 "%d of %d scenes answer differently: %s" % (len(differ), len(acked), differ[:2]))
    gone = set()
    if acked:
        victim = sorted(acked)[0]
        r = c.delete("/v1/scenes/%s" % victim)
        check_status(ledger, "full_disk", "faults.full_disk.delete_when_full", r)
        if r.status == 200:
            gone.add(victim)
            r2 = c.post("/v1/scenes", _big_doc(rng, "full-after-delete", 20 if fsize is None else 10))
            check_status(ledger, "full_disk", "faults.full_disk.register_after_delete", r2)
            if r2.status in (200, 201):
                sid = r2.json()["id"]
                acked[sid] = (None, answer(c, sid))
    c.close()
    server.kill()
    server.start()
    c = server.client()
    keep = set(acked) - gone
    listed = set(listed_ids(c) or [])
    missing = keep - listed
    ledger.check(SUITE, "full_disk.restart_keeps_acknowledged", not missing and not (gone & listed),
                 "missing %s, deleted but back %s" % (sorted(missing)[:3], sorted(gone & listed)))
    differ = [sid for sid in keep if answer(c, sid) != acked[sid][1]]
    ledger.check(SUITE, "full_disk.answers_identical_after_restart", not differ,
                 "%d differ: %s" % (len(differ), differ[:2]))
    c.close()
    server.kill()
    return {"data_dir": how, "registered_before_full": len(acked) - (1 if gone else 0),
            "refused_with": full[1].label(), "again": labels}


def read_only(opts, ledger, d):
    data = os.path.join(d, "data")
    os.makedirs(data)
    ok, how = harness.bind_mount(data)
    if not ok:
        for name in ("register", "delete", "scene_stays_after_refused_delete"):
            ledger.skip(SUITE, "read_only." + name,
                        "needs root for a read-only bind mount (chmod does not stop root): " + how)
        return {"skipped": how}
    try:
        return _read_only(opts, ledger, d, data)
    finally:
        harness.stop_all()
        harness.remount(data, read_only=False)
        harness.umount(data)


def _read_only(opts, ledger, d, data):
    server = harness.ServerProcess(opts.server, data_dir=data, log_dir=d, name="ro")
    c = server.client()
    rng = R.rng_for(opts.seed, "read-only")
    acked = {}
    for n in range(3):
        doc = R.random_small_scene(rng, tag="ro-%d" % n)
        r = c.post("/v1/scenes", doc)
        if r.status == 201:
            sid = r.json()["id"]
            acked[sid] = (doc, answer(c, sid))
    ledger.check(SUITE, "read_only.setup_registered", len(acked) == 3, "%d of 3" % len(acked))
    ok, out = harness.remount(data, read_only=True)
    if not ledger.check(SUITE, "read_only.remounted_read_only", ok, out):
        return {}
    before = harness.list_tree(data)
    r = c.post("/v1/scenes", R.random_small_scene(rng, tag="ro-new"))
    check_status(ledger, "read_only", "faults.read_only.register", r)
    reg_label = r.label()
    victim = sorted(acked)[0]
    r = c.delete("/v1/scenes/%s" % victim)
    check_status(ledger, "read_only", "faults.read_only.delete", r)
    del_label = r.label()
    g = c.get("/v1/scenes/%s" % victim)
    a = answer(c, victim)
    ledger.check(SUITE, "read_only.scene_stays_after_refused_delete",
                 g.status == 200 and a == acked[victim][1],
                 "GET after the DELETE: %s; intersect: %s" % (g.label(), "identical" if a == acked[victim][1]
                                                              else str(a)[:100]))
    differ = [sid for sid in acked if sid != victim and answer(c, sid) != acked[sid][1]]
    ledger.check(SUITE, "read_only.other_scenes_answer", not differ, "%s" % differ)
    after = harness.list_tree(data)
    ledger.check(SUITE, "read_only.disk_unchanged", before == after,
                 "before %d entries, after %d" % (len(before), len(after)))
    ledger.check(SUITE, "read_only.server_alive", server.alive(), server.exit_description())
    c.close()
    server.kill()
    # A server started on a read-only data dir serves what is there.
    try:
        server.start()
        c = server.client()
        listed = set(listed_ids(c) or [])
        same = all(answer(c, sid) == acked[sid][1] for sid in acked if sid in listed)
        ledger.check(SUITE, "read_only.restart_on_read_only_dir_serves_scenes",
                     set(acked) <= listed and same,
                     "listed %d of %d, answers %s" % (len(set(acked) & listed), len(acked),
                                                     "identical" if same else "differ"))
        c.close()
    except harness.ServerStartError as e:
        ledger.check(SUITE, "read_only.restart_on_read_only_dir_serves_scenes", False, str(e)[:300])
    return {"register": reg_label, "delete": del_label}
