"""The command line against a real raycastd: every command, --json, exit codes 0/1/2."""

from __future__ import annotations

import io
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import unittest
from unittest import mock

from support import (
    EXAMPLES,
    PACKAGE_ROOT,
    REPO,
    TRIANGLE,
    TUTORIAL,
    ServerTestCase,
    numpy,
    write_gltf_with_files,
    write_obj_with_files,
)

from raycastd.cli import main
from raycastd.png import read_png
from raycastd.server import LocalServer
from raycastd.tables import npy_bytes, read_table


class CliTest(ServerTestCase):
    def setUp(self) -> None:
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = pathlib.Path(self.tmp.name)
        self.scene_file = self.dir / "spheres.json"
        self.scene_file.write_text(json.dumps(TUTORIAL))

    def tearDown(self) -> None:
        self.tmp.cleanup()

    def run_cli(self, *args: str, server: bool = True) -> tuple[int, str, str]:
        out, err = io.StringIO(), io.StringIO()
        argv = list(args) + (["--server", self.server.url] if server else [])
        code = main(argv, out, err)
        return code, out.getvalue(), err.getvalue()

    def ok(self, *args: str) -> str:
        code, out, err = self.run_cli(*args)
        self.assertEqual(code, 0, f"{args}: {err}")
        return out

    def test_health_info(self) -> None:
        self.assertIn(": ok", self.ok("health"))
        self.assertEqual(json.loads(self.ok("info", "--json"))["name"], "raycastd")

    def test_scene_add_list_show_rm(self) -> None:
        out = json.loads(self.ok("scene", "add", str(self.scene_file), "--json"))
        sid = out["id"]
        self.assertEqual(out["file"], str(self.scene_file))
        text = self.ok(
            "scene", "add", str(self.scene_file), str(EXAMPLES / "tutorial-spheres.json")
        )
        self.assertEqual(len(text.strip().splitlines()), 2)
        self.assertIn(sid, self.ok("scene", "list"))
        self.assertIn(sid, [s["id"] for s in json.loads(self.ok("scene", "list", "--json"))])
        self.assertEqual(json.loads(self.ok("scene", "show", sid, "--json"))["spheres"], 3)
        self.assertIn(f"deleted {sid}", self.ok("scene", "rm", sid))
        code, out, err = self.run_cli("scene", "show", sid)
        self.assertEqual((code, out), (1, ""))
        self.assertIn("scene_not_found", err)

    def test_intersect_rays_on_the_command_line(self) -> None:
        out = self.ok(
            "intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--ray", "0,0,0:0,0,-1"
        )
        lines = out.splitlines()
        self.assertIn("sphere 3 (object 2, primitive 0)", lines[0])
        self.assertIn("t = 7.267949192431123", lines[0])
        self.assertEqual(lines[1], "ray 1: miss")
        data = json.loads(
            self.ok("intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--json")
        )
        self.assertEqual(data["hits"][0]["name"], "sphere 3")
        self.assertIn(
            "4 hits",
            self.ok("intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--mode", "all"),
        )
        self.assertIn(
            "4 crossings",
            self.ok("intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--mode", "count"),
        )
        self.assertIn(
            "ray 0: hit",
            self.ok("intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--mode", "any"),
        )
        # tmin past the first sphere's entry: the next hit.
        self.assertIn(
            "t = 8",
            self.ok(
                "intersect",
                str(self.scene_file),
                "--ray",
                "0,0,0:0,0,1:7.5",
                "--precision",
                "exact",
            ),
        )
        only = json.loads(
            self.ok(
                "intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--fields", "t", "--json"
            )
        )
        self.assertEqual(set(only["hits"][0]), {"hit", "t"})

    def test_intersect_rays_from_csv_and_npy(self) -> None:
        csv = self.dir / "rays.csv"
        csv.write_text("ox,oy,oz,dx,dy,dz\n0,0,0,0,0,1\n0,0,0,0,0,-1\n")
        out = self.ok(
            "intersect", str(self.scene_file), "--rays", str(csv), "-o", str(self.dir / "out.csv")
        )
        self.assertIn("miss", out)
        rows = read_table(self.dir / "out.csv")
        self.assertEqual(rows[0], [7.267949192431123, 2.0, 0.0])
        self.assertEqual(rows[1][1:], [-1.0, -1.0])
        npy = self.dir / "rays.npy"
        npy.write_bytes(npy_bytes([[0, 0, 0, 0, 0, 1, 0, 7.0]]))  # tmax 7: before every sphere
        data = json.loads(
            self.ok(
                "intersect",
                str(self.scene_file),
                "--rays",
                str(npy),
                "--ray",
                "0,0,0:0,0,1",
                "--json",
            )
        )
        self.assertEqual(data["t"], [7.267949192431123, None])  # --ray first, then the file
        every = json.loads(
            self.ok(
                "intersect", str(self.scene_file), "--rays", str(csv), "--mode", "all", "--json"
            )
        )
        self.assertEqual(every["count"], [4, 0])
        self.assertEqual(len(every["t"][0]), 4)
        counts = json.loads(
            self.ok(
                "intersect", str(self.scene_file), "--rays", str(csv), "--mode", "count", "--json"
            )
        )
        self.assertEqual(counts["count"], [4, 0])
        self.assertEqual(
            json.loads(
                self.ok(
                    "intersect", str(self.scene_file), "--rays", str(csv), "--mode", "any", "--json"
                )
            )["hit"],
            [1, 0],
        )
        self.ok(
            "intersect", str(self.scene_file), "--rays", str(csv), "-o", str(self.dir / "out.npy")
        )
        if numpy is not None:
            self.assertEqual(numpy.load(self.dir / "out.npy").shape, (2, 3))

    def test_render_writes_a_png(self) -> None:
        out_png = self.dir / "out.png"
        code, out, err = self.run_cli(
            "render",
            str(self.scene_file),
            "-o",
            str(out_png),
            "--size",
            "40x30",
            "--spp",
            "2",
            "--sampling",
            "adaptive",
            "--lighting",
            "headlight",
        )
        self.assertEqual(code, 0, err)
        self.assertEqual(out, "")  # messages go to stderr
        self.assertIn("wrote", err)
        img = read_png(out_png.read_bytes())
        self.assertEqual((img.width, img.height), (40, 30))
        # --progress always draws the bar (a job) even when stderr is not a terminal.
        code, _, err = self.run_cli(
            "render",
            str(self.scene_file),
            "-o",
            str(out_png),
            "--size",
            "20x10",
            "--progress",
            "always",
            "--shading",
            "normal",
        )
        self.assertEqual(code, 0, err)
        self.assertIn("100%", err)
        self.assertNotIn(
            "[",
            self.run_cli("render", str(self.scene_file), "-o", str(out_png), "--size", "8x8")[2],
        )

    def test_trace_and_explain(self) -> None:
        q2 = REPO / "tests" / "golden" / "scenes" / "tutorial_q2.json"
        out = self.ok("trace", str(q2), "--ray", "0,0,0:0,0,1")
        self.assertIn("I1: glass at t = 8", out)
        self.assertIn("5 points; full Phong: I1 I2 I3; ambient only: I4 I5", out)
        self.assertEqual(
            json.loads(self.ok("trace", str(q2), "--ray", "0,0,0:0,0,1", "--json"))["summary"][
                "points"
            ],
            5,
        )
        text = self.ok("explain", str(self.scene_file), "--ray", "0,0,0:0,0,1")
        self.assertIn("first hit: sphere 3 at t = 7.267949192431123", text)
        md = self.ok("explain", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--markdown")
        self.assertTrue(md.startswith("# "))
        self.assertEqual(
            json.loads(self.ok("explain", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--json"))[
                "objects"
            ][0]["roots"],
            [8, 12],
        )

    def test_points(self) -> None:
        out = self.ok("points", str(self.scene_file), "--point", "0,0,0", "--query", "closest")
        self.assertIn("closest", out)
        data = json.loads(
            self.ok(
                "points",
                str(self.scene_file),
                "--point",
                "0,0,10",
                "--query",
                "occupancy",
                "--json",
            )
        )
        self.assertTrue(data["results"][0]["inside"])

    def test_points_with_no_surface_in_reach(self) -> None:
        # The server answers {"distance": null}: nothing within --max-distance, or (signed
        # distance, which searches the whole scene) an empty scene. No traceback.
        code, out, err = self.run_cli(
            "points",
            str(self.scene_file),
            "--point",
            "0,0,0",
            "--query",
            "distance",
            "--max-distance",
            "1",
        )
        self.assertEqual((code, err), (0, ""))
        self.assertEqual(out, "(0, 0, 0): no surface within max_distance\n")
        empty = self.dir / "empty.json"
        empty.write_text('{"objects": []}')
        code, out, err = self.run_cli(
            "points", str(empty), "--point", "0,0,0", "--query", "signed_distance"
        )
        self.assertEqual((code, err), (0, ""))
        self.assertEqual(out, "(0, 0, 0): no surface in the scene\n")
        data = json.loads(
            self.ok("points", str(empty), "--point", "0,0,0", "--query", "distance", "--json")
        )
        self.assertEqual(data["results"], [{"distance": None}])

    def test_queries_send_a_file_inline_and_register_nothing(self) -> None:
        # intersect --ray, points and explain send a .json document to the stateless
        # endpoints: an edited scene is not stored on the server. explain sends a model file
        # as an inline mesh (the API explains only a scene sent with the question); intersect
        # and points register it, so that its parts keep the server's names and numbers.
        before = {s["id"] for s in self.client.list_scenes()}
        out = self.ok("intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1")
        self.assertIn("sphere 3 (object 2, primitive 0)", out)
        self.assertIn("closest", self.ok("points", str(self.scene_file), "--point", "0,0,0"))
        self.assertIn(
            "first hit: sphere 3", self.ok("explain", str(self.scene_file), "--ray", "0,0,0:0,0,1")
        )
        obj = write_obj_with_files(self.dir)
        self.assertIn(
            "first hit: tri at t = 5", self.ok("explain", str(obj), "--ray", "0.5,0.5,0:0,0,1")
        )
        self.assertEqual({s["id"] for s in self.client.list_scenes()}, before)
        self.assertIn("t = 5", self.ok("intersect", str(obj), "--ray", "0.5,0.5,0:0,0,1"))
        self.assertIn(
            "distance 5", self.ok("points", str(obj), "--point", "0.5,0.5,0", "--query", "distance")
        )
        gltf = write_gltf_with_files(self.dir)
        self.assertIn("t = 5", self.ok("intersect", str(gltf), "--ray", "0.5,0.5,0:0,0,1"))
        # (that they are registered is TokenCliTest's: there it needs the token)

    def test_explain_a_model_file_but_not_an_id(self) -> None:
        obj = write_obj_with_files(self.dir)
        out = self.ok("explain", str(obj), "--ray", "0.5,0.5,0:0,0,1")
        self.assertIn("first hit: tri at t = 5", out)
        sid = self.client.add_scene(TUTORIAL)["id"]
        code, out, err = self.run_cli("explain", sid, "--ray", "0,0,0:0,0,1")
        self.assertEqual((code, out), (2, ""))
        self.assertIn("explain needs the scene itself", err)
        self.assertNotIn("Traceback", err)
        odd = self.dir / "tri.xyz"
        odd.write_bytes(obj.read_bytes())
        code, _, err = self.run_cli("explain", str(odd), "--ray", "0,0,0:0,0,1")
        self.assertEqual(code, 2)
        self.assertIn("model file named .glb .gltf .obj .stl .ply .off", err)

    def test_output_files_are_checked_before_the_request(self) -> None:
        missing = self.dir / "missing" / "x.png"
        code, out, err = self.run_cli("render", str(self.scene_file), "-o", str(missing))
        self.assertEqual((code, out), (2, ""))
        self.assertEqual(err, f"raycastd: usage: -o {missing}: no such folder {missing.parent}\n")
        csv = self.dir / "rays.csv"
        csv.write_text("0,0,0,0,0,1\n")
        code, _, err = self.run_cli(
            "intersect",
            str(self.scene_file),
            "--rays",
            str(csv),
            "-o",
            str(self.dir / "no" / "x.csv"),
        )
        self.assertEqual(code, 2)
        self.assertIn("no such folder", err)
        self.assertNotIn("Traceback", err)
        code, _, err = self.run_cli(
            "render", str(self.scene_file), "-o", str(self.dir / "x.png"), "--camera", "nofile.json"
        )
        self.assertEqual(code, 2)
        self.assertIn("--camera: no such file: nofile.json", err)
        code, _, err = self.run_cli(
            "render", str(self.scene_file), "-o", str(self.dir / "x.png"), "--camera", "{nope"
        )
        self.assertEqual(code, 2)
        self.assertIn("--camera: not JSON", err)

    def test_text_output_shows_what_was_asked_in_good_english(self) -> None:
        out = self.ok(
            "intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--fields", "t,name"
        )
        self.assertEqual(out.splitlines()[0], "ray 0: hit sphere 3, t = 7.267949192431123")
        out = self.ok(
            "intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1", "--fields", "object"
        )
        self.assertEqual(out.splitlines()[0], "ray 0: hit (object 2)")
        out = self.ok(
            "intersect",
            str(self.scene_file),
            "--ray",
            "0,0,0:0,0,1",
            "--fields",
            "t",
            "--mode",
            "all",
        )
        self.assertEqual(out.splitlines()[0], "ray 0: 4 hits: 7.26794919, 8, 10.7320508, 12")
        tri = self.dir / "tri.json"
        tri.write_text(json.dumps(TRIANGLE))
        out = self.ok("intersect", str(tri), "--ray", "0.5,0.5,0:0,0,1", "--mode", "all")
        self.assertEqual(out.splitlines()[0], "ray 0: 1 hit: 5 (abc)")
        out = self.ok("intersect", str(tri), "--ray", "0.5,0.5,0:0,0,1", "--mode", "count")
        self.assertEqual(out.splitlines()[0], "ray 0: 1 crossing")
        self.assertIn("1 object, 1 triangle, 0 spheres", self.ok("scene", "add", str(tri)))
        self.assertIn("1 point;", self.ok("trace", str(tri), "--ray", "0.5,0.5,0:0,0,1"))
        # -o CSV: ids and counts as integers.
        csv = self.dir / "rays.csv"
        csv.write_text("0,0,0,0,0,1\n0,0,0,0,0,-1\n")
        code, _, err = self.run_cli(
            "intersect", str(self.scene_file), "--rays", str(csv), "-o", str(self.dir / "h.csv")
        )
        self.assertEqual(code, 0, err)
        self.assertIn("wrote 2 rows (t, object, primitive)", err)
        self.assertEqual(
            (self.dir / "h.csv").read_text(),
            "t,object,primitive\n7.267949192431123,2,0\ninf,-1,-1\n",
        )
        one = self.dir / "one.csv"
        one.write_text("0,0,0,0,0,1\n")
        code, _, err = self.run_cli(
            "intersect",
            str(self.scene_file),
            "--rays",
            str(one),
            "--mode",
            "count",
            "-o",
            str(self.dir / "c.csv"),
        )
        self.assertIn("wrote 1 row (count)", err)
        self.assertEqual((self.dir / "c.csv").read_text(), "count\n4\n")
        # --mode all: one row per hit (it crashed on the lists of t).
        code, _, err = self.run_cli(
            "intersect",
            str(self.scene_file),
            "--rays",
            str(csv),
            "--mode",
            "all",
            "-o",
            str(self.dir / "a.csv"),
        )
        self.assertEqual(code, 0, err)
        self.assertEqual(
            read_table(self.dir / "a.csv"),
            [[0, 7.267949192431123], [0, 8], [0, 10.732050807568877], [0, 12]],
        )

    def test_scene_show_is_a_summary_and_json_with_json(self) -> None:
        sid = json.loads(self.ok("scene", "add", str(self.scene_file), "--json"))["id"]
        text = self.ok("scene", "show", sid)
        self.assertTrue(text.startswith(f"{sid}: 3 objects, 0 triangles, 3 spheres, bounds "), text)
        self.assertIn("camera: none (renders look from -z)", text)
        self.assertNotIn("{", text)
        self.assertEqual(json.loads(self.ok("scene", "show", sid, "--json"))["id"], sid)
        gltf = write_gltf_with_files(self.dir)
        gid = json.loads(self.ok("scene", "add", str(gltf), "--json"))["id"]
        self.assertRegex(
            self.ok("scene", "show", gid), r"mesh 0 '.*': 3 vertices, 1 triangle, open"
        )

    def test_usage_errors_exit_2(self) -> None:
        for args in (
            ["intersect", str(self.scene_file)],  # no rays
            ["intersect", str(self.scene_file), "--ray", "0,0:0,0,1"],
            ["intersect", "no-such-file.json", "--ray", "0,0,0:0,0,1"],
            ["render", str(self.scene_file), "-o", "x.png", "--size", "big"],
            ["explain", str(self.dir / "missing.json"), "--ray", "0,0,0:0,0,1"],
            ["frobnicate"],
            [],
        ):
            code, _, err = self.run_cli(*args)
            self.assertEqual(code, 2, f"{args}: {err}")
            self.assertTrue(err)

    def test_api_error_exit_1_prints_the_code(self) -> None:
        bad = self.dir / "bad.json"
        bad.write_text('{"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": -1}]}')
        code, out, err = self.run_cli("intersect", str(bad), "--ray", "0,0,0:0,0,1")
        self.assertEqual((code, out), (1, ""))
        self.assertIn("400 invalid_scene", err)
        self.assertIn("/objects/0/radius", err)
        code, _, err = self.run_cli("intersect", str(self.scene_file), "--ray", "0,0,0:0,0,0")
        self.assertEqual(code, 1)
        self.assertIn("invalid_ray", err)

    def test_a_gltf_beside_its_files(self) -> None:
        # The .gltf goes with its .bin and image inside it; without the .bin, exit 1 names it.
        gltf = write_gltf_with_files(self.dir)
        out = json.loads(self.ok("scene", "add", str(gltf), "--json"))
        self.assertEqual(out["triangles"], 1)
        (self.dir / "tri data.bin").unlink()
        code, out, err = self.run_cli("render", str(gltf), "-o", str(self.dir / "x.png"))
        self.assertEqual((code, out), (1, ""))
        self.assertIn("model_load_failed", err)
        self.assertIn("tri%20data.bin", err)
        self.assertNotIn("Traceback", err)

    def test_an_obj_with_its_mtl_and_the_servers_warnings(self) -> None:
        # The OBJ goes with its .mtl and texture; a render of a file prints the warnings the
        # server has about it, as `scene add` does (here: the library it could not read).
        obj = write_obj_with_files(self.dir)
        code, _, err = self.run_cli("render", str(obj), "-o", str(self.dir / "x.png"))
        self.assertEqual(code, 0, err)
        self.assertNotIn("warning", err)
        (self.dir / "sub" / "tri.mtl").unlink()
        code, _, err = self.run_cli("render", str(obj), "-o", str(self.dir / "x.png"))
        self.assertEqual(code, 0, err)
        self.assertIn(f"{obj}: warning: material library 'sub/tri.mtl' could not be read", err)

    def test_raycastd_url_and_connection_failure(self) -> None:
        with mock.patch.dict(os.environ, {"RAYCASTD_URL": self.server.url}):
            code, out, _ = self.run_cli("health", server=False)
        self.assertEqual(code, 0)
        self.assertIn(self.server.url, out)
        with mock.patch.dict(os.environ, {"RAYCASTD_URL": "http://127.0.0.1:9"}):
            code, _, err = self.run_cli("health", server=False)
        self.assertEqual(code, 1)
        self.assertIn("http://127.0.0.1:9", err)
        self.assertIn("connection_failed", err)

    def test_python_dash_m_entry_point(self) -> None:
        env = {**os.environ, "PYTHONPATH": str(PACKAGE_ROOT), "RAYCASTD_URL": self.server.url}
        run = subprocess.run(
            [
                sys.executable,
                "-m",
                "raycastd",
                "intersect",
                str(self.scene_file),
                "--ray",
                "0,0,0:0,0,1",
                "--json",
            ],
            capture_output=True,
            text=True,
            env=env,
            timeout=60,
        )
        self.assertEqual(run.returncode, 0, run.stderr)
        self.assertEqual(json.loads(run.stdout)["hits"][0]["object"], 2)
        usage = subprocess.run(
            [sys.executable, "-m", "raycastd", "--nope"],
            capture_output=True,
            text=True,
            env=env,
            timeout=60,
        )
        self.assertEqual(usage.returncode, 2)


class TokenCliTest(unittest.TestCase):
    """A server started with --token: queries stay open, so the query commands work without
    the token; a command that has to register a file says why and how to pass the token."""

    @classmethod
    def setUpClass(cls) -> None:
        cls.server = LocalServer(
            os.environ.get("RAYCASTD_BINARY") or None, ["--threads", "2", "--token", "s3cret"]
        )

    @classmethod
    def tearDownClass(cls) -> None:
        cls.server.close()

    def setUp(self) -> None:
        tmp = tempfile.TemporaryDirectory()
        self.addCleanup(tmp.cleanup)
        self.dir = pathlib.Path(tmp.name)
        self.scene_file = self.dir / "spheres.json"
        self.scene_file.write_text(json.dumps(TUTORIAL))

    def run_cli(self, *args: str) -> tuple[int, str, str]:
        out, err = io.StringIO(), io.StringIO()
        with mock.patch.dict(os.environ, {"RAYCASTD_TOKEN": ""}):
            code = main(list(args) + ["--server", self.server.url], out, err)
        return code, out.getvalue(), err.getvalue()

    def test_queries_need_no_token(self) -> None:
        obj = write_obj_with_files(self.dir)
        for args in (
            ["intersect", str(self.scene_file), "--ray", "0,0,0:0,0,1"],
            ["points", str(self.scene_file), "--point", "0,0,0"],
            ["explain", str(self.scene_file), "--ray", "0,0,0:0,0,1"],
            ["explain", str(obj), "--ray", "0.5,0.5,0:0,0,1"],
        ):
            code, out, err = self.run_cli(*args)
            self.assertEqual((code, err), (0, ""), args)
            self.assertTrue(out, args)
        # A model file is registered for intersect and points (its parts' names and numbers).
        code, _, err = self.run_cli("intersect", str(obj), "--ray", "0.5,0.5,0:0,0,1")
        self.assertEqual(code, 1)
        self.assertIn("intersect registers a model file", err)
        self.assertIn("pass --token T (or set RAYCASTD_TOKEN=T)", err)

    def test_a_needed_write_says_why_and_how_to_pass_the_token(self) -> None:
        csv = self.dir / "rays.csv"
        csv.write_text("0,0,0,0,0,1\n")
        png = self.dir / "x.png"
        for args, why in (
            (["render", str(self.scene_file), "-o", str(png)], "render needs a registered scene"),
            (["trace", str(self.scene_file), "--ray", "0,0,0:0,0,1"], "trace needs a registered"),
            (["intersect", str(self.scene_file), "--rays", str(csv)], "binary form"),
            (["scene", "add", str(self.scene_file)], "scene add registers scenes"),
        ):
            code, out, err = self.run_cli(*args)
            self.assertEqual((code, out), (1, ""), args)
            self.assertIn("401 unauthorized", err)
            self.assertIn(why, err)
            self.assertIn("pass --token T (or set RAYCASTD_TOKEN=T)", err)
            self.assertNotIn("Traceback", err)
        code, _, err = self.run_cli("render", str(self.scene_file), "-o", str(png), "--token", "no")
        self.assertEqual(code, 1)
        self.assertIn("refused the token given", err)
        code, _, err = self.run_cli(
            "render", str(self.scene_file), "-o", str(png), "--size", "8x8", "--token", "s3cret"
        )
        self.assertEqual(code, 0, err)
        self.assertTrue(png.read_bytes().startswith(b"\x89PNG"))


if __name__ == "__main__":
    unittest.main()
