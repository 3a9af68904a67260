"""deploy/nginx.conf made runnable by anyone on loopback: the same http block (map, hashing,
retries, headers), with the listen port and the replicas' ports of a test, and the pid file,
logs and temp paths in a directory of its own (nginx's defaults are root's: /run, /var/log,
/var/lib/nginx). Used by tests/scale/run.py and tests/deploy/test_manifests.py."""

import os
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CONF = ROOT / "deploy" / "nginx.conf"


def local_conf(workdir: Path, listen_port: int, upstream_ports: list) -> str:
    """deploy/nginx.conf with its site-specific lines replaced for a loopback test."""
    text = CONF.read_text()
    work = Path(workdir)
    (work / "logs").mkdir(parents=True, exist_ok=True)
    # As root the workers would drop to www-data, which cannot enter a private temp dir.
    user = "user root;" if os.geteuid() == 0 else ""
    text, n_user = re.subn(r"^user [^;]+;", user, text, flags=re.M)
    text, n_pid = re.subn(r"^pid [^;]+;", f"pid {work}/nginx.pid;", text, flags=re.M)
    text, n_err = re.subn(
        r"^error_log [^;]+;", f"error_log {work}/logs/error.log warn;", text, flags=re.M
    )
    text, n_acc = re.subn(
        r"access_log /var/log/nginx/[^ ;]+", f"access_log {work}/logs/access.log", text
    )
    servers = "\n".join(
        f"        server 127.0.0.1:{p} max_fails=1 fail_timeout=5s;" for p in upstream_ports
    )
    text, n_srv = re.subn(
        r"(upstream raycastd \{\n(?:.*\n)*?)((?:\s*server 127\.0\.0\.1:\d+[^\n]*\n)+)",
        lambda m: m.group(1) + servers + "\n",
        text,
    )
    text, n_listen = re.subn(r"listen 8080;", f"listen 127.0.0.1:{listen_port};", text)
    temps = "".join(
        f"    {d}_temp_path {work}/{d};\n"
        for d in ("client_body", "proxy", "fastcgi", "uwsgi", "scgi")
    )
    text, n_http = re.subn(r"^http \{\n", "http {\n" + temps, text, flags=re.M)
    counts = dict(
        user=n_user,
        pid=n_pid,
        error_log=n_err,
        access_log=n_acc,
        servers=n_srv,
        listen=n_listen,
        http=n_http,
    )
    missing = [k for k, n in counts.items() if n != 1]
    if missing:
        raise ValueError(f"deploy/nginx.conf no longer has the lines to adapt: {missing}")
    return text
