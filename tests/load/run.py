#!/usr/bin/env python3
"""raycastd load, fault and hostile-input tests (issue #13), loopback only, bounded in time.

    tests/load/run.py --quick --server build/release/server/raycastd --shared ../shared
    tests/load/run.py --long  --server ... --report docs/reliability.md [--fuzz-summary DIR]

--quick (CI, about 90 s): 16 clients for 20 s, every fault scenario, a few hundred hostile
requests. --long (the default): 64 clients for 300 s and a larger battery. Each part starts its
own servers on 127.0.0.1 (--port 0) with their own temporary --data-dir. The run ends with
'load: N passed, M failed' and exits 1 when a check failed.
"""

import argparse
import datetime
import json
import os
import shlex
import shutil
import signal
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import harness  # noqa: E402


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="the CI run: about 90 s in all")
    mode.add_argument("--long", action="store_true", help="the long run (the default): 64 clients, 5 min")
    p.add_argument("--server", default=os.environ.get("RAYCASTD_BINARY"),
                   help="the raycastd binary (default: $RAYCASTD_BINARY)")
    p.add_argument("--shared", default=None,
                   help="the shared folder holding data/models (Duck.glb for truncations); "
                        "absent: those inputs are skipped with a message")
    p.add_argument("--only", default="load,faults,hostile",
                   help="comma-separated parts to run: load, faults, hostile (default all)")
    p.add_argument("--clients", type=int, help="load clients (quick 16, long 64)")
    p.add_argument("--duration", type=float, help="load seconds (quick 20, long 300)")
    p.add_argument("--max-concurrent", type=int,
                   help="--max-concurrent for the load server (default: the server's own; 503 "
                        "busy is exercised separately by the busy probe)")
    p.add_argument("--max-requests-per-client", type=int, default=10 ** 7,
                   help="a bound on each client's loop besides the duration")
    p.add_argument("--seed", default="13", help="seed of every random choice (default 13)")
    p.add_argument("--report", metavar="FILE", help="write the Markdown report to FILE")
    p.add_argument("--fuzz-summary", metavar="DIR",
                   help="a folder of fuzzing JSON summaries for the report's Fuzzing section")
    p.add_argument("--json", metavar="FILE", help="also write every summary and check as JSON")
    p.add_argument("--max-seconds", type=float,
                   help="watchdog: stop everything after this long (quick 200, long 1200)")
    p.add_argument("--no-mount", action="store_true",
                   help="mount nothing, even as root: the full disk is RLIMIT_FSIZE and the "
                        "read-only checks are skipped (what a run without root does)")
    p.add_argument("--keep-tmp", action="store_true", help="keep the temporary data dirs and logs")
    a = p.parse_args(argv)
    quick = a.quick
    a.mode = "quick" if quick else "long"
    a.clients = a.clients or (16 if quick else 64)
    a.duration = a.duration if a.duration is not None else (20.0 if quick else 300.0)
    a.max_seconds = a.max_seconds or (200.0 if quick else 1200.0)
    a.parts = [x.strip() for x in a.only.split(",") if x.strip()]
    a.models = None
    if a.shared:
        m = os.path.join(a.shared, "data", "models")
        a.models = m if os.path.isdir(m) else None
    return a


def watchdog(seconds):
    def fire():
        print("\nload: watchdog: the run took over %.0f s; stopping every server" % seconds,
              flush=True)
        harness.stop_all()
        print("load: 0 passed, 1 failed", flush=True)
        os._exit(2)

    t = threading.Timer(seconds, fire)
    t.daemon = True
    t.start()
    return t


def main(argv):
    opts = parse_args(argv)
    if not opts.server or not os.access(opts.server, os.X_OK):
        print("load: no raycastd binary (--server or RAYCASTD_BINARY): %r" % opts.server)
        print("load: 0 passed, 1 failed")
        return 2
    opts.server = os.path.abspath(opts.server)
    harness.NO_MOUNT = opts.no_mount
    command = " ".join([sys.executable, "tests/load/run.py"] + [shlex.quote(x) for x in argv])
    started = datetime.datetime.now(datetime.timezone.utc)
    print("load: %s run of %s, seed %s, models: %s" % (opts.mode, opts.server, opts.seed,
                                                     opts.models or "absent"), flush=True)
    dog = watchdog(opts.max_seconds)
    signal.signal(signal.SIGTERM, lambda *_: (harness.stop_all(), os._exit(3)))
    ledger = harness.Ledger()
    tmp_root = tempfile.mkdtemp(prefix="raycastd-load-")
    summaries = {}
    t0 = time.monotonic()
    try:
        for part in opts.parts:
            pt = time.monotonic()
            try:
                if part == "load":
                    import load_suite
                    summaries["load"] = load_suite.run(opts, ledger, tmp_root)
                elif part == "faults":
                    import fault_suite
                    summaries["faults"] = fault_suite.run(opts, ledger, tmp_root)
                elif part == "hostile":
                    import hostile_suite
                    summaries["hostile"] = hostile_suite.run(opts, ledger, tmp_root)
                else:
                    ledger.check("run", "known_part_" + part, False, "no such part: " + part)
                    continue
            except harness.ServerStartError as e:
                ledger.check(part, "server_starts", False, str(e))
            except Exception as e:  # noqa: BLE001 - a harness bug fails the run, with the closing line
                import traceback
                ledger.check(part, "part_ran", False, "%r\n%s" % (e, traceback.format_exc(limit=5)))
            summaries.setdefault(part, {})["seconds"] = time.monotonic() - pt
    finally:
        harness.stop_all()  # servers first, then mounts
        dog.cancel()
        if not opts.keep_tmp:
            shutil.rmtree(tmp_root, ignore_errors=True)
    seconds = time.monotonic() - t0
    passed, failed, skipped = ledger.counts()

    print("\n== summary (%.1f s)" % seconds)
    for suite, name, status, detail in ledger.failures():
        print("  FAILED %s.%s: %s" % (suite, name, detail))
    if skipped:
        print("  %d skipped: %s" % (skipped, ", ".join("%s.%s" % (r[0], r[1])
                                                        for r in ledger.results if r[2] == "skip")))
    meta = {"command": command, "date": started.strftime("%Y-%m-%d %H:%M UTC"),
            "seconds": seconds, "server": opts.server, "mode": opts.mode, "seed": opts.seed,
            "passed": passed, "failed": failed, "skipped": skipped}
    if opts.report:
        import report
        report.write(opts.report, meta, summaries, ledger, opts.fuzz_summary)
        print("  report written to %s" % opts.report)
    if opts.json:
        with open(opts.json, "w") as f:
            json.dump({"meta": meta, "summaries": summaries,
                       "checks": [list(r) for r in ledger.results]}, f, indent=1, default=str)
    if opts.keep_tmp:
        print("  temporary files kept in %s" % tmp_root)
    print("load: %d passed, %d failed" % (passed, failed), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
