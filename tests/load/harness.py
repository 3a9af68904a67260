"""Server processes, HTTP helpers and the named-check ledger shared by the load suites.

Everything here talks to 127.0.0.1 only. Servers are started from the main thread with
PR_SET_PDEATHSIG, so a runner that is killed (a ctest timeout) takes its servers with it.
"""

import ctypes
import http.client
import json
import os
import resource
import select
import shutil
import signal
import socket
import subprocess
import tempfile
import threading
import time

HOST = "127.0.0.1"

_LIVE_SERVERS = []  # every ServerProcess not yet stopped, for the exit handler
_MOUNTS = []  # mount points to unmount at exit
NO_MOUNT = False  # run.py --no-mount: take the paths a non-root run takes


def _libc():
    try:
        return ctypes.CDLL("libc.so.6", use_errno=True)
    except OSError:
        return None


_LIBC = _libc()


def _preexec(fsize_limit=None):
    """Runs in the child between fork and exec."""

    def fn():
        if _LIBC is not None:
            _LIBC.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG: die with the runner
        if fsize_limit is not None:
            # The server would get SIGXFSZ on the first write past the limit; ignored, the
            # write fails with EFBIG instead (SIG_IGN is inherited across exec).
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize_limit, fsize_limit))

    return fn


class ServerStartError(RuntimeError):
    pass


class ServerProcess:
    """One raycastd on a free loopback port (--port 0), its stderr in a log file."""

    def __init__(self, binary, args=(), data_dir=None, scene_root=None, fsize_limit=None,
                 log_dir=None, name="server"):
        self.binary = binary
        self.args = list(args)
        self.data_dir = data_dir
        self.scene_root = scene_root
        self.fsize_limit = fsize_limit
        self.name = name
        self.log_dir = log_dir or tempfile.mkdtemp(prefix="raycastd-load-log-")
        self.proc = None
        self.port = None
        self.starts = 0
        self.start()

    def command(self):
        cmd = [self.binary, "--port", "0"]
        if self.data_dir:
            cmd += ["--data-dir", self.data_dir]
        if self.scene_root:
            cmd += ["--scene-root", self.scene_root]
        return cmd + self.args

    def start(self, timeout=20.0):
        if threading.current_thread() is not threading.main_thread():
            raise RuntimeError("servers are started from the main thread (PR_SET_PDEATHSIG)")
        self.starts += 1
        self.log_path = os.path.join(self.log_dir, "%s.%d.stderr" % (self.name, self.starts))
        log = open(self.log_path, "wb")
        self.proc = subprocess.Popen(self.command(), stdout=subprocess.PIPE, stderr=log,
                                     stdin=subprocess.DEVNULL,
                                     preexec_fn=_preexec(self.fsize_limit))
        log.close()
        _LIVE_SERVERS.append(self)
        deadline = time.monotonic() + timeout
        line = b""
        fd = self.proc.stdout.fileno()
        while not line.endswith(b"\n"):
            left = deadline - time.monotonic()
            if left <= 0 or self.proc.poll() is not None:
                break
            r, _, _ = select.select([fd], [], [], min(left, 0.5))
            if r:
                ch = os.read(fd, 1)
                if not ch:
                    break
                line += ch
        text = line.decode(errors="replace").strip()
        if "listening on http://" not in text:
            self.kill()
            raise ServerStartError("%s did not start (printed %r); stderr: %s"
                                   % (self.binary, text, self.stderr_tail()))
        self.port = int(text.rsplit(":", 1)[1])
        # Drain stdout so the server never blocks on a full pipe.
        threading.Thread(target=self._drain, args=(self.proc,), daemon=True).start()
        return self

    @staticmethod
    def _drain(proc):
        try:
            while proc.stdout.read(65536):
                pass
        except (OSError, ValueError):
            pass

    @property
    def pid(self):
        return self.proc.pid if self.proc else None

    def alive(self):
        return self.proc is not None and self.proc.poll() is None

    def exit_description(self):
        """'running', 'exit 3' or 'killed by SIGSEGV'."""
        if self.proc is None:
            return "not started"
        rc = self.proc.poll()
        if rc is None:
            return "running"
        if rc < 0:
            try:
                return "killed by " + signal.Signals(-rc).name
            except ValueError:
                return "killed by signal %d" % -rc
        return "exit %d" % rc

    def kill(self, sig=signal.SIGKILL):
        """Sends `sig` and waits; true if the process was still running."""
        if self.proc is None:
            return False
        was = self.proc.poll() is None
        if was:
            try:
                self.proc.send_signal(sig)
            except ProcessLookupError:
                pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self in _LIVE_SERVERS:
            _LIVE_SERVERS.remove(self)
        return was

    def stop(self):
        self.kill(signal.SIGTERM)

    def restart(self):
        self.kill()
        return self.start()

    def memory(self):
        """{'VmRSS': bytes, 'VmHWM': bytes} from /proc/PID/status."""
        out = {}
        try:
            with open("/proc/%d/status" % self.pid) as f:
                for line in f:
                    key, _, rest = line.partition(":")
                    if key in ("VmRSS", "VmHWM"):
                        out[key] = int(rest.split()[0]) * 1024
        except (OSError, TypeError):
            pass
        return out

    def stderr_tail(self, n=1500):
        try:
            with open(self.log_path, "rb") as f:
                data = f.read()
            return data[-n:].decode(errors="replace")
        except OSError:
            return ""

    def client(self, timeout=60.0):
        return Client(self.port, timeout=timeout)


def stop_all():
    for s in list(_LIVE_SERVERS):
        try:
            s.kill()
        except Exception:  # noqa: BLE001 - best effort at exit
            pass
    for m in reversed(list(_MOUNTS)):
        umount(m)


class Response:
    __slots__ = ("status", "headers", "body", "elapsed", "error")

    def __init__(self, status, headers, body, elapsed, error=None):
        self.status = status  # int, or None when the connection failed
        self.headers = headers  # dict with lower-case keys
        self.body = body
        self.elapsed = elapsed
        self.error = error  # the exception text when status is None

    def json(self):
        return json.loads(self.body)

    def code(self):
        """The error code of a JSON error body, or None."""
        try:
            return self.json()["error"]["code"]
        except Exception:  # noqa: BLE001 - any body that is not an error document
            return None

    def label(self):
        """'200', '503 busy', 'conn_error' — how the ledgers count responses."""
        if self.status is None:
            return "conn_error"
        if self.status >= 400:
            c = self.code()
            return "%d %s" % (self.status, c) if c else "%d (no JSON error)" % self.status
        return str(self.status)


class Client:
    """A keep-alive HTTP/1.1 connection (http.client), reconnecting once when the server has
    closed an idle connection."""

    def __init__(self, port, timeout=60.0):
        self.port = port
        self.timeout = timeout
        self.conn = None

    def _connect(self):
        self.conn = http.client.HTTPConnection(HOST, self.port, timeout=self.timeout)

    def close(self):
        if self.conn is not None:
            self.conn.close()
            self.conn = None

    def request(self, method, path, body=None, headers=None, content_type=None):
        hdrs = dict(headers or {})
        if isinstance(body, (dict, list)):
            body = json.dumps(body).encode()
            hdrs.setdefault("Content-Type", "application/json")
        elif isinstance(body, str):
            body = body.encode()
        if content_type:
            hdrs["Content-Type"] = content_type
        if body is not None and "Content-Type" not in hdrs:
            hdrs["Content-Type"] = "application/json"
        t0 = time.perf_counter()
        for attempt in (0, 1):
            if self.conn is None:
                self._connect()
            fresh = attempt == 1
            try:
                self.conn.request(method, path, body=body, headers=hdrs)
                r = self.conn.getresponse()
                data = r.read()
                h = {k.lower(): v for k, v in r.getheaders()}
                if h.get("connection", "").lower() == "close":
                    self.close()
                return Response(r.status, h, data, time.perf_counter() - t0)
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError) as e:
                # A kept-alive connection the server closed while idle: reconnect once.
                self.close()
                if fresh:
                    return Response(None, {}, b"", time.perf_counter() - t0, repr(e))
                t0 = time.perf_counter()
            except (OSError, http.client.HTTPException) as e:
                self.close()
                return Response(None, {}, b"", time.perf_counter() - t0, repr(e))
        return Response(None, {}, b"", time.perf_counter() - t0, "unreachable")

    def get(self, path, **kw):
        return self.request("GET", path, **kw)

    def post(self, path, body=None, **kw):
        return self.request("POST", path, body=body, **kw)

    def delete(self, path, **kw):
        return self.request("DELETE", path, **kw)


def raw_exchange(port, data, timeout=2.0, half_close=False, read_all=False):
    """Sends raw bytes on a fresh socket; returns (bytes received, seconds until the first byte
    or the timeout, timed_out). With read_all, reads until EOF or a whole response."""
    s = socket.create_connection((HOST, port), timeout=timeout)
    try:
        t0 = time.monotonic()
        s.sendall(data)
        if half_close:
            s.shutdown(socket.SHUT_WR)
        got = b""
        first = None
        deadline = t0 + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return got, (first if first is not None else timeout), True
            s.settimeout(left)
            try:
                chunk = s.recv(65536)
            except socket.timeout:
                return got, (first if first is not None else timeout), True
            except OSError:
                return got, time.monotonic() - t0, False
            if first is None:
                first = time.monotonic() - t0
            if not chunk:
                return got, first, False
            got += chunk
            if not read_all and complete_response(got):
                return got, first, False
            if read_all and complete_response(got):
                return got, first, False
    finally:
        s.close()


def complete_response(data):
    """True when `data` holds a whole HTTP response with a Content-Length body."""
    head, sep, body = data.partition(b"\r\n\r\n")
    if not sep:
        return False
    for line in head.split(b"\r\n")[1:]:
        k, _, v = line.partition(b":")
        if k.strip().lower() == b"content-length":
            try:
                return len(body) >= int(v.strip())
            except ValueError:
                return True
    return True


def parse_raw_response(data):
    """(status or None, headers dict, body bytes) of raw response bytes."""
    head, sep, body = data.partition(b"\r\n\r\n")
    lines = head.split(b"\r\n")
    try:
        status = int(lines[0].split()[1])
    except (IndexError, ValueError):
        return None, {}, data
    headers = {}
    for line in lines[1:]:
        k, _, v = line.partition(b":")
        headers[k.strip().lower().decode(errors="replace")] = v.strip().decode(errors="replace")
    return status, headers, body


# --- mounts ---------------------------------------------------------------------------------

def is_root():
    return os.geteuid() == 0


def _run(cmd):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=20)
    return p.returncode, p.stdout.decode(errors="replace").strip()


def mount_tmpfs(path, size, read_only=False):
    """Mounts a tmpfs of `size` at path; returns (ok, message)."""
    if NO_MOUNT:
        return False, "--no-mount"
    if not is_root():
        return False, "not running as root"
    if shutil.which("mount") is None:
        return False, "no mount(8)"
    opts = "size=%s" % size + (",ro" if read_only else "")
    rc, out = _run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", path])
    if rc != 0:
        return False, "mount -t tmpfs failed: " + out
    _MOUNTS.append(path)
    return True, "tmpfs size=%s" % size


def bind_mount(path):
    if NO_MOUNT:
        return False, "--no-mount"
    if not is_root():
        return False, "not running as root"
    rc, out = _run(["mount", "--bind", path, path])
    if rc != 0:
        return False, "mount --bind failed: " + out
    _MOUNTS.append(path)
    return True, "bind mount at " + path


def remount(path, read_only):
    flag = "ro" if read_only else "rw"
    rc, out = _run(["mount", "-o", "remount,%s,bind" % flag, path])
    return rc == 0, out


def umount(path):
    if path not in _MOUNTS:
        return True
    for _ in range(5):
        rc, out = _run(["umount", path])
        if rc == 0:
            break
        time.sleep(0.3)
    else:
        _run(["umount", "-l", path])
    _MOUNTS.remove(path)
    return True


def list_tree(root):
    """Every file and directory under root, relative, sorted ('d ' / 'f ' prefixed)."""
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        rel = os.path.relpath(dirpath, root)
        for d in sorted(dirnames):
            out.append("d " + os.path.normpath(os.path.join(rel, d)))
        for f in sorted(filenames):
            out.append("f " + os.path.normpath(os.path.join(rel, f)))
    return sorted(out)


def check_data_dir(root, listed_ids):
    """Problems with a data dir's layout (server/scene_registry.cpp): DIR/scenes/<id>/ holds
    body, meta.json and file0..N (copies of files the scene read); DIR/tmp/ holds writes in
    progress (<id>.<token>.<n>/) and deletions in progress (<id>.deleted.<token>.<n>/), and a
    server opening the dir empties it of the entries of writers that have ended; DIR/locks/
    holds one <token>.lock per server using the dir (flocked while it runs). Returns a list of
    strings; empty when the layout is clean."""
    problems = []
    tmp = os.path.join(root, "tmp")
    scenes = os.path.join(root, "scenes")
    if os.path.isdir(tmp):
        left = sorted(os.listdir(tmp))
        if left:
            problems.append("tmp/ not empty: %s" % left[:5])
    for entry in sorted(os.listdir(root)) if os.path.isdir(root) else []:
        if entry not in ("scenes", "tmp", "locks"):
            problems.append("unexpected entry in data dir: %s" % entry)
    locks = os.path.join(root, "locks")
    for name in sorted(os.listdir(locks)) if os.path.isdir(locks) else []:
        if not name.endswith(".lock") or os.path.isdir(os.path.join(locks, name)):
            problems.append("locks/%s: unexpected entry" % name)
    on_disk = set()
    if os.path.isdir(scenes):
        for sid in sorted(os.listdir(scenes)):
            d = os.path.join(scenes, sid)
            on_disk.add(sid)
            if not os.path.isdir(d):
                problems.append("scenes/%s is not a directory" % sid)
                continue
            names = set(os.listdir(d))
            if "meta.json" not in names or "body" not in names:
                problems.append("scenes/%s incomplete: %s" % (sid, sorted(names)))
            for n in names:
                if n not in ("meta.json", "body") and not n.startswith("file"):
                    problems.append("scenes/%s/%s: unexpected file" % (sid, n))
    if listed_ids is not None:
        listed = set(listed_ids)
        if on_disk - listed:
            problems.append("on disk but not listed: %s" % sorted(on_disk - listed)[:5])
        if listed - on_disk:
            problems.append("listed but not on disk: %s" % sorted(listed - on_disk)[:5])
    return problems


# --- the ledger of named checks -------------------------------------------------------------

class Ledger:
    """Named assertions. Every check prints one line; the run ends with
    'load: N passed, M failed'."""

    def __init__(self, verbose=True):
        self.results = []  # (suite, name, status 'pass'|'fail'|'skip', detail)
        self.verbose = verbose
        self.lock = threading.Lock()

    def check(self, suite, name, ok, detail=""):
        status = "pass" if ok else "fail"
        detail = str(detail)
        if len(detail) > 600:
            detail = detail[:600] + "… (%d chars)" % len(detail)
        with self.lock:
            self.results.append((suite, name, status, detail))
        if self.verbose:
            tag = "PASS" if ok else "FAIL"
            print("  %s %s.%s%s" % (tag, suite, name, (": " + detail) if detail else ""),
                  flush=True)
        return ok

    def skip(self, suite, name, why):
        with self.lock:
            self.results.append((suite, name, "skip", why))
        print("  SKIP %s.%s: %s" % (suite, name, why), flush=True)

    def counts(self):
        p = sum(1 for r in self.results if r[2] == "pass")
        f = sum(1 for r in self.results if r[2] == "fail")
        s = sum(1 for r in self.results if r[2] == "skip")
        return p, f, s

    def failures(self):
        return [r for r in self.results if r[2] == "fail"]


def percentile(values, q):
    if not values:
        return float("nan")
    v = sorted(values)
    k = min(len(v) - 1, max(0, int(round(q / 100.0 * (len(v) - 1)))))
    return v[k]
