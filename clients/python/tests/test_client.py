"""The Python client against a real raycastd binary (RAYCASTD_BINARY), on a free loopback port."""

import os
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from raycastd import Client, RaycastdError  # noqa: E402

TUTORIAL = {
    "objects": [
        {"type": "sphere", "center": [0, 0, 10], "radius": 2},
        {"type": "sphere", "center": [0, 3, 8], "radius": 2},
        {"type": "sphere", "center": [0, 1, 9], "radius": 2},
    ]
}
RAY = {"origin": [0, 0, 0], "direction": [0, 0, 1]}


class ClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls) -> None:
        binary = os.environ.get("RAYCASTD_BINARY", "build/release/server/raycastd")
        cls.proc = subprocess.Popen([binary, "--port", "0"], stdout=subprocess.PIPE, text=True)
        port = int(cls.proc.stdout.readline().rsplit(":", 1)[1])
        cls.client = Client(f"http://127.0.0.1:{port}")

    @classmethod
    def tearDownClass(cls) -> None:
        cls.client.close()
        cls.proc.kill()
        cls.proc.wait()

    def test_tutorial_question_1(self) -> None:
        hit = self.client.intersect(TUTORIAL, [RAY])["hits"][0]
        self.assertEqual(hit["name"], "sphere 3")
        self.assertEqual(hit["t"], 7.267949192431123)

    def test_explain(self) -> None:
        ex = self.client.explain(TUTORIAL, RAY)
        self.assertEqual(ex["objects"][0]["roots"], [8, 12])
        md = self.client.explain(TUTORIAL, RAY, markdown=True)
        self.assertIn("**sphere 3**", md)

    def test_register_query_binary_delete(self) -> None:
        info = self.client.register(TUTORIAL)
        self.assertEqual(info["spheres"], 3)
        self.assertEqual(self.client.register(TUTORIAL)["id"], info["id"])
        hit = self.client.query(info["id"], [RAY])["hits"][0]
        self.assertEqual(hit["object"], 2)
        binary = self.client.query_binary(info["id"], [((0, 0, 0), (0, 0, 1), 0.0, 1e30),
                                                       ((0, 0, 0), (0, 0, -1), 0.0, 1e30)])
        self.assertTrue(binary[0].hit)
        self.assertEqual(binary[0].t, hit["t"])
        self.assertEqual(binary[0].object, 2)
        self.assertFalse(binary[1].hit)
        self.assertIn(info["id"], [s["id"] for s in self.client.scenes()])
        self.client.delete(info["id"])
        with self.assertRaises(RaycastdError) as cm:
            self.client.scene(info["id"])
        self.assertEqual(cm.exception.code, "scene_not_found")

    def test_errors_carry_code_and_path(self) -> None:
        bad = {"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": -1}]}
        with self.assertRaises(RaycastdError) as cm:
            self.client.intersect(bad, [RAY])
        self.assertEqual(cm.exception.status, 400)
        self.assertEqual(cm.exception.code, "invalid_scene")
        self.assertEqual(cm.exception.path, "/scene/objects/0/radius")


if __name__ == "__main__":
    unittest.main()
