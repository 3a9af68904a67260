"""Writes docs/reliability.md from one run's summaries and checks (run.py --report FILE)."""

import glob
import json
import math
import os

import expected as X

METHOD = """\
## How the run checks

- **Servers.** Every part starts its own `raycastd --port 0` on 127.0.0.1 with its own temporary
  `--data-dir` (a fault scenario restarts the same binary on the same dir). Nothing leaves the
  loopback interface; every loop is bounded by a count and a deadline, and a watchdog stops the
  whole run (quick: 200 s).
- **Load.** Each client is a thread with one keep-alive `http.client` connection, choosing a kind
  of request at random by weight: stateless JSON intersect (`closest` and `all`), JSON intersect
  by id, binary intersect (float32 and float64 records), render (PNG, 8–64 px), trace, explain,
  registration of fresh scene documents and deletion of ones the same client registered (then
  `GET` must be 404), and `POST /v1/scenes/{id}/points` when a probe shows the server has it.
  Statuses are counted by kind. Any 5xx other than `503 busy` fails the run, a `503 busy`
  without `Retry-After` fails it, and so does any other status a valid request should not get.
  Clients that get `503` wait `min(Retry-After, 0.2 s)`. A separate **busy probe** runs a
  server with `--max-concurrent 1`, two clients sending heavy batches and four keep-alive clients
  sending small binary and JSON intersects of the tutorial's ray: every `503` must be `busy` with
  `Retry-After`, and the next request on the same connection must get its own, right answer.
- **Answers.** Spot checks compare answers with an exact reference computed in the test
  (`tests/load/reference.py`): the ray/sphere quadratic and Möller–Trumbore's ray/triangle test
  evaluated in rationals (`fractions.Fraction`) from the same doubles the server parsed, so
  hit/miss, the object (and a mesh's triangle) must agree and `t` must match to 1e-9 relative
  (JSON and float64 records at `precision: "exact"`; float32 records 1e-6, the double answer
  rounded to float; the `fast` path 1e-5 and hit/miss not compared, since it is not watertight).
  Rays the reference cannot call are skipped and counted as ambiguous: within 1e-6 of a sphere's
  tangency, within 1e-6 (barycentric) of a triangle's edge, nearly parallel to its plane, a root
  within 1e-9 of `tmin`/`tmax`, or two objects hit within 1e-9 of each other. The scenes are
  tutorial-like documents of ≤ 16 spheres and triangles (answered on the exact path) and an
  icosphere OBJ of 320 triangles sent inline as `data_base64` (coordinates rounded to float32 so
  a float or double loader reads the same numbers), which gets a BVH.
- **Memory.** `VmRSS` and `VmHWM` of the server from `/proc/PID/status` before the load starts
  (after the base scenes are registered) and when it ends.
- **Faults.** `kill -9` while 8 clients register scenes, while 6 clients delete them and while a
  1000×1000×16 render runs; then a restart on the same data dir, where every acknowledged
  (201/200) scene must be listed and answer 16 fixed rays at `precision: "exact"` with the same
  JSON as before the kill, every acknowledged deletion must stay deleted (404), every scene that
  was written but not acknowledged must work, and the data dir must be clean (below). A full disk
  is a 256 KiB tmpfs as the data dir (as root; otherwise `RLIMIT_FSIZE` in the server's
  `preexec_fn`, with `SIGXFSZ` ignored); a read-only data dir is a read-only bind mount. The
  statuses the contract asks for are written in ONE place, `tests/load/expected.py`.
- **Hostile inputs.** A battery by class; each class prints how many it sent, the statuses it got
  and what was expected. A request after which the server is gone is counted as a crash of its
  class (with the signal), and the server is restarted for the remaining classes.

### The data dir's layout (from `server/scene_registry.cpp`)

```
DIR/scenes/<id>/body        the request body as received (scene document or model file)
DIR/scenes/<id>/file0..N    copies of every file the scene read under --scene-root
DIR/scenes/<id>/meta.json   format, content type, request key, SHA-256 of each file, the summary
DIR/tmp/<id>.<pid>.<n>/     a registration being written: each file fsynced, the directory
                            fsynced, then renamed to scenes/<id>/ and scenes/ fsynced; only then 201
DIR/tmp/<id>.deleted/       a deletion: scenes/<id>/ renamed here, scenes/ fsynced, then removed
```

A server opening `DIR` empties `tmp/` (those writes were never acknowledged) and lists every
`scenes/<id>/meta.json`. "Clean" therefore means, after a restart: `tmp/` empty, nothing in
`DIR` but `scenes/` and `tmp/`, every `scenes/<id>/` holding `body` and `meta.json` (and only
`fileN` besides), and the set of directories equal to what `GET /v1/scenes` lists.
"""


# What the failing checks came from when they were first seen (main at e96c58e, 2026-12-01),
# read from server/ and observed on the wire. Printed under a check only while it fails.
DIAGNOSES = {
    "load.busy_probe.busy_carries_retry_after":
        "`WorkSlot` (server/app.cpp) throws `busy` without a `Retry-After` header; only the job "
        "image route sets one.",
    "load.busy_probe.next_request_on_connection_answered_right":
        "A 503 to a binary intersect is sent before its body is read and the connection is kept "
        "alive, so the unread ray records are parsed as the next request (`400 malformed HTTP "
        "request`, even `414`); the client's real next request then gets someone else's answer. "
        "Reproduced with a raw socket. The server must drain the body or answer `Connection: close`.",
    "load.keepalive_in_sync_after_busy": "As the busy probe's check above.",
    "faults.full_disk.register_when_full":
        "`SceneRegistry::add` turns any `persist` failure into `api_error(\"internal\")` "
        "(server/scene_registry.cpp); ENOSPC/EDQUOT/EFBIG/EROFS should be `507 insufficient_storage`.",
    "faults.full_disk.stays_refused_the_same_way": "As `register_when_full`.",
    "faults.read_only.register": "As `full_disk.register_when_full` (EROFS).",
    "faults.read_only.delete":
        "`SceneRegistry::remove` erases the in-memory entry first and ignores the rename's error, "
        "so the DELETE answers 200 while the saved copy stays: the scene is gone until a restart "
        "brings it back.",
    "faults.read_only.scene_stays_after_refused_delete": "As `read_only.delete`.",
    "hostile.deep_json":
        "100,000 levels of nesting overflow a worker thread's 8 MB stack somewhere in the "
        "recursive handling of the document: the server dies with SIGSEGV and logs nothing. Run "
        "under `ulimit -s 1000000` the same body registers (201), so it is stack depth; a nesting "
        "limit checked before any recursive walk is needed.",
    "hostile.no_crashes": "The deep-JSON crashes.",
    "hostile.long_url":
        "cpp-httplib answers 414 itself and the error handler (server/app.cpp) maps only "
        "404/413/400 to codes, so the body says `internal`.",
    "hostile.content_length_negative":
        "The connection is held with no answer (cpp-httplib waits; the server's read timeout is 60 s).",
    "hostile.content_length_23_digits": "As `content_length_negative`.",
    "hostile.idle_sockets":
        "Each socket holding a partial head occupies one of the 64 worker threads until the 60 s "
        "read timeout; a 65th client waits for a free thread.",
    "hostile.half_close":
        "When the client's FIN is already there as the server goes to read the request, the "
        "connection is closed without an answer (a 50 ms pause before `shutdown` makes 20 of 20 "
        "succeed).",
    "hostile.form_urlencoded_scene":
        "cpp-httplib 0.11 caps `application/x-www-form-urlencoded` bodies at "
        "`CPPHTTPLIB_FORM_URL_ENCODED_PAYLOAD_MAX_LENGTH` (8,192 bytes) and answers 413 before the "
        "route runs; 100 spheres (6 KB) register, 500 (31 KB) do not.",
}


def _ms(x):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else "%.1f" % (x * 1e3)


def _args(args):
    out = []
    for a in args:
        out.append("$TMP/" + os.path.basename(a) if a.startswith(("/tmp/", "/var/tmp/")) else a)
    return " ".join(out)


def _mb(m, key):
    v = (m or {}).get(key)
    return "?" if v is None else "%.1f MB" % (v / 2 ** 20)


def _esc(s):
    return str(s).replace("|", "\\|").replace("\n", " ")


def _checks_table(lines, results):
    lines.append("| check | result | detail |")
    lines.append("|---|---|---|")
    for suite, name, status, detail in results:
        lines.append("| `%s.%s` | %s | %s |" % (suite, name, {"pass": "pass", "fail": "**FAIL**",
                                                             "skip": "skipped"}[status],
                                             _esc(detail)[:300]))
    lines.append("")


def fuzz_section(folder):
    lines = ["## Fuzzing", ""]
    if not folder:
        lines += ["Fuzzing: not run in this report (pass `--fuzz-summary DIR`, a folder of JSON "
                  "summaries, to include one).", ""]
        return lines
    files = sorted(glob.glob(os.path.join(folder, "*.json")))
    if not files:
        lines += ["Fuzzing: not run in this report (no `*.json` summaries in `%s`)." % folder, ""]
        return lines
    lines.append("From the JSON summaries in `%s`:" % folder)
    lines.append("")
    lines.append("| summary | fields |")
    lines.append("|---|---|")
    for f in files:
        try:
            with open(f) as fh:
                data = json.load(fh)
        except (OSError, ValueError) as e:
            lines.append("| `%s` | unreadable: %s |" % (os.path.basename(f), _esc(e)))
            continue
        if isinstance(data, dict):
            fields = ", ".join("%s: %s" % (k, _esc(v)) for k, v in data.items()
                               if isinstance(v, (str, int, float, bool)) or v is None)
            nested = [k for k, v in data.items() if isinstance(v, (dict, list))]
            if nested:
                fields += (", " if fields else "") + "(also: %s)" % ", ".join(nested)
        else:
            fields = "%s of %d entries" % (type(data).__name__, len(data)) if hasattr(data, "__len__") else _esc(data)
        lines.append("| `%s` | %s |" % (os.path.basename(f), fields[:600]))
    lines.append("")
    return lines


def write(path, meta, summaries, ledger, fuzz_dir):
    L = ["# Reliability: load, faults and hostile inputs", ""]
    L.append("Generated by `%s` on %s against `%s` (%s run, seed %s, %.0f s). Issue #13."
             % (meta["command"], meta["date"], meta["server"], meta["mode"], meta["seed"], meta["seconds"]))
    L.append("")
    L.append("**Result: %d passed, %d failed, %d skipped.**" % (meta["passed"], meta["failed"], meta["skipped"]))
    L.append("")
    fails = ledger.failures()
    if fails:
        L.append("Failed checks (each names what the server answered and what the contract asks for):")
        L.append("")
        for suite, name, _, detail in fails:
            L.append("- `%s.%s`: %s" % (suite, name, _esc(detail)[:400]))
            why = DIAGNOSES.get("%s.%s" % (suite, name))
            if why:
                L.append("  - *Cause, as diagnosed when first seen:* %s" % why)
        L.append("")

    s = summaries.get("load")
    L += ["## Load", ""]
    if s and "by_kind" in s:
        busy = s.get("busy", 0)
        L.append("%d clients for %.0f s (`%s`): **%d requests, %.0f/s; 5xx other than busy: %d; "
                 "503 busy: %d; wrong answers: %d** of %d answers compared with the reference "
                 "(%d ambiguous rays skipped)."
                 % (s["clients"], s["elapsed_s"], _args(s.get("server_args", [])), s["requests"],
                    s["rps"], s["5xx"], busy, s["wrong"], sum(s["compared"].values()), s["ambiguous"]))
        L.append("")
        L.append("Server memory: before %s (VmHWM %s), after %s (VmHWM %s)."
                 % (_mb(s["rss_before"], "VmRSS"), _mb(s["rss_before"], "VmHWM"),
                    _mb(s["rss_after"], "VmRSS"), _mb(s["rss_after"], "VmHWM")))
        L.append("")
        L.append("| kind | requests | statuses | compared | p50 ms | p99 ms |")
        L.append("|---|---:|---|---:|---:|---:|")
        for k, st in s["by_kind"].items():
            p50, p99, _ = s["latency"].get(k, (None, None, 0))
            L.append("| %s | %d | %s | %d | %s | %s |" % (k, sum(st.values()), _esc(st),
                                                        s["compared"].get(k, 0), _ms(p50), _ms(p99)))
        L.append("")
        L.append("Points: %s." % s.get("points", "?"))
        if s.get("wrong_examples"):
            L.append("")
            L.append("Wrong answers, first few:")
            L += ["- %s" % _esc(w) for w in s["wrong_examples"]]
        L.append("")
    else:
        L += ["Not run in this report.", ""]
    _checks_table(L, [r for r in ledger.results if r[0] == "load"])

    f = summaries.get("faults")
    L += ["## Faults", ""]
    if f:
        for name, v in f.items():
            if name == "seconds" or not isinstance(v, dict):
                continue
            facts = ", ".join("%s: %s" % (k, _esc(x)) for k, x in v.items() if k != "seconds")
            L.append("- **%s** (%.1f s): %s" % (name, v.get("seconds", 0), facts or "–"))
        L.append("")
        L.append("Expected statuses (`tests/load/expected.py`):")
        L.append("")
        for k in sorted(X.EXPECTED):
            if k.startswith("faults."):
                L.append("- `%s`: %s" % (k, X.describe(k)))
        L.append("")
        _checks_table(L, [r for r in ledger.results if r[0] == "faults"])
    else:
        L += ["Not run in this report.", ""]

    h = summaries.get("hostile")
    L += ["## Hostile inputs", ""]
    if h and "classes" in h:
        L.append("%d requests in %d classes; %d crash(es)%s."
                 % (h["total"], len(h["classes"]), len(h["crashes"]),
                    (": " + ", ".join("%s (%s)" % c for c in h["crashes"])) if h["crashes"] else ""))
        L.append("")
        L.append("| class | sent | statuses | expected | result |")
        L.append("|---|---:|---|---|---|")
        for cls, v in h["classes"].items():
            if "skipped" in v:
                L.append("| %s | 0 | – | – | skipped: %s |" % (cls, _esc(v["skipped"])))
                continue
            L.append("| %s | %d | %s | %s | %s |" % (cls, v["sent"], _esc(v["statuses"]), _esc(v["expected"]),
                                                     ("ok" if v["ok"] else "**FAIL**")
                                                     + ((" — " + _esc(v["note"])) if v.get("note") else "")))
        L.append("")
        _checks_table(L, [r for r in ledger.results if r[0] == "hostile"])
    else:
        L += ["Not run in this report.", ""]

    L += fuzz_section(fuzz_dir)
    L.append(METHOD)
    L += ["## Running it", "",
          "```sh",
          "/usr/bin/python3 tests/load/run.py --quick --server build/release/server/raycastd --shared ../shared",
          "/usr/bin/python3 tests/load/run.py --long --server build/release/server/raycastd --shared ../shared \\",
          "    --report docs/reliability.md [--fuzz-summary DIR]",
          "ctest --preset release -L load   # load_quick",
          "```", "",
          "`--quick` (CI, under a minute on 2 cores): 16 clients for 20 s at the server's default "
          "limits, the busy probe (`--max-concurrent 1`, 3 s), every fault scenario and ~460 hostile "
          "requests. `--long` (the default): 64 clients for 300 s, a 10 s busy probe and a battery "
          "of ~2,700. `--only load,faults,hostile`, `--clients`, `--duration`, `--seed` adjust a "
          "run; `--json FILE` keeps every number. The last line is `load: N passed, M failed`.",
          ""]
    with open(path, "w") as fh:
        fh.write("\n".join(L))
