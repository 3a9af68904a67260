"""Shared by the client tests: the package on sys.path, a real raycastd per test class, scenes.

The server binary is `$RAYCASTD_BINARY` (ctest passes `$<TARGET_FILE:raycastd>`), else what
`raycastd.server.find_server` finds. Each test class starts its own server on a free loopback
port (`--port 0`) and stops it afterwards.
"""

from __future__ import annotations

import os
import pathlib
import sys
import unittest

HERE = pathlib.Path(__file__).resolve().parent
PACKAGE_ROOT = HERE.parent
REPO = PACKAGE_ROOT.parents[1]
sys.path.insert(0, str(PACKAGE_ROOT))

from raycastd import Client  # noqa: E402
from raycastd.server import LocalServer  # noqa: E402

EXAMPLES = REPO / "clients" / "examples"
GRADING = REPO / "clients" / "grading"
TUTORIAL7 = GRADING / "tutorial7"

TUTORIAL = {
    "objects": [
        {"type": "sphere", "center": [0, 0, 10], "radius": 2},
        {"type": "sphere", "center": [0, 3, 8], "radius": 2},
        {"type": "sphere", "center": [0, 1, 9], "radius": 2},
    ]
}
RAY = {"origin": [0, 0, 0], "direction": [0, 0, 1]}
TRIANGLE = {
    "objects": [{"type": "triangle", "name": "abc", "vertices": [[0, 0, 5], [2, 0, 5], [0, 2, 5]]}]
}

try:
    import numpy
except ImportError:  # the list paths are tested without it; NumPy tests skip
    numpy = None


class ServerTestCase(unittest.TestCase):
    """Starts one raycastd for the class: `cls.server.url`, `cls.client`."""

    server: LocalServer
    client: Client

    @classmethod
    def setUpClass(cls) -> None:
        cls.server = LocalServer(os.environ.get("RAYCASTD_BINARY") or None, ["--threads", "8"])
        cls.client = Client(cls.server.url)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.client.close()
        cls.server.close()
