"""Slow readers against --answer-budget-mb: the figure in docs/api.md ("Memory budgets").

N clients each ask for a 19.2 MB binary answer (600,000 closest hits in float32) with a 4 KB
receive window and read none of it for 3 s; then the server's resident memory (VmRSS, VmHWM)
and the status each got. Loopback only, one server of its own, bounded by N and 3 s.

    python3 tests/load/answer_budget_probe.py build/release/server/raycastd --budget-mb 40
"""

from __future__ import annotations

import argparse
import http.client
import json
import socket
import struct
import subprocess
import time


def status_of(sock: socket.socket) -> str:
    """The status code of the answer waiting on `sock`, or what became of it."""
    sock.settimeout(5)
    try:
        head = sock.recv(64)
    except OSError:
        return "reset"
    return head.split(b" ")[1].decode() if head else "closed"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("server", help="the raycastd binary")
    parser.add_argument("--budget-mb", default="2048", help="--answer-budget-mb (default 2048)")
    parser.add_argument("--clients", type=int, default=12)
    args = parser.parse_args()
    server = subprocess.Popen(
        [args.server, "--port", "0", "--log-level", "error", "--answer-budget-mb", args.budget_mb],
        stdout=subprocess.PIPE,
    )
    try:
        port = int(server.stdout.readline().decode().rsplit(":", 1)[1])
        c = http.client.HTTPConnection("127.0.0.1", port)
        scene = '{"objects":[{"type":"sphere","center":[0,0,0],"radius":1}]}'
        c.request("POST", "/v1/scenes", scene, {"Content-Type": "application/json"})
        sid = json.loads(c.getresponse().read())["id"]
        records = struct.pack("<8f", 0, 0, -5, 0, 0, 1, 0, float("inf")) * 600_000
        request = (
            f"POST /v1/scenes/{sid}/intersect?mode=closest&dtype=float32 HTTP/1.1\r\n"
            f"Host: x\r\nContent-Type: application/octet-stream\r\n"
            f"Content-Length: {len(records)}\r\n\r\n"
        ).encode() + records
        sockets = []
        for _ in range(args.clients):
            s = socket.socket()
            s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            s.connect(("127.0.0.1", port))
            sockets.append(s)
            try:
                s.sendall(request)
            except OSError:
                pass  # refused before its body was read: the answer is waiting
        time.sleep(3)
        statuses = [status_of(s) for s in sockets]
        memory = {}
        with open(f"/proc/{server.pid}/status") as f:
            for line in f:
                if line.startswith(("VmRSS", "VmHWM")):
                    memory[line.split(":")[0]] = int(line.split()[1]) >> 10
        counts = {k: statuses.count(k) for k in sorted(set(statuses))}
        print(
            f"--answer-budget-mb {args.budget_mb}, {args.clients} slow readers of 19.2 MB: "
            f"statuses {counts}, VmRSS {memory['VmRSS']} MB, VmHWM {memory['VmHWM']} MB"
        )
        for s in sockets:
            s.close()
    finally:
        server.kill()
        server.wait()


if __name__ == "__main__":
    main()
