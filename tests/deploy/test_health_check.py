"""raycastd --health-check, the Dockerfile's HEALTHCHECK: exit 0 when the server at
--host/--port (or RAYCASTD_HOST/RAYCASTD_PORT) answers GET /v1/health, 1 when none does.

Run by CTest as deploy_health_check, with RAYCASTD_BINARY naming the server binary."""

import os
import socket
import subprocess
import unittest

BINARY = os.environ.get("RAYCASTD_BINARY", "")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class HealthCheck(unittest.TestCase):
    def test_a_running_server_is_healthy(self) -> None:
        server = subprocess.Popen(
            [BINARY, "--port", "0", "--log-level", "error"], stdout=subprocess.PIPE, text=True
        )
        try:
            port = server.stdout.readline().strip().rsplit(":", 1)[1]
            by_flag = subprocess.run(
                [BINARY, "--health-check", "--port", port], capture_output=True, timeout=10
            )
            self.assertEqual(by_flag.returncode, 0, by_flag.stderr)
            # As the container runs it: the address from the environment, 0.0.0.0 = loopback.
            env = dict(os.environ, RAYCASTD_HOST="0.0.0.0", RAYCASTD_PORT=port)
            by_env = subprocess.run(
                [BINARY, "--health-check"], env=env, capture_output=True, timeout=10
            )
            self.assertEqual(by_env.returncode, 0, by_env.stderr)
        finally:
            server.kill()
            server.wait()
            server.stdout.close()

    def test_no_server_is_unhealthy(self) -> None:
        r = subprocess.run(
            [BINARY, "--health-check", "--port", str(free_port())],
            capture_output=True,
            text=True,
            timeout=10,
        )
        self.assertEqual(r.returncode, 1)
        self.assertIn("health check of 127.0.0.1", r.stderr)


if __name__ == "__main__":
    unittest.main()
