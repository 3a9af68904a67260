"""The JSON client against a real raycastd: every endpoint, the typed errors, $RAYCASTD_URL."""

from __future__ import annotations

import base64
import http.server
import json
import os
import pathlib
import select
import socket
import struct
import tempfile
import threading
import time
import unittest
from typing import Callable
from unittest import mock

from support import (
    RAY,
    REPO,
    TRIANGLE,
    TUTORIAL,
    ServerTestCase,
    write_gltf_with_files,
    write_obj_with_files,
)

import raycastd
from raycastd import (
    BadRequest,
    Client,
    ClientError,
    ConnectionFailed,
    NotFound,
    RaycastdError,
)
from raycastd.client import embed_gltf_files, mtl_textures, obj_document, obj_files
from raycastd.png import read_png


class EndpointsTest(ServerTestCase):
    def test_health_and_info(self) -> None:
        self.assertEqual(self.client.health(), {"status": "ok"})
        info = self.client.info()
        self.assertEqual(info["name"], "raycastd")
        self.assertIn("max_rays", info["limits"])

    def test_stateless_intersect_question_1(self) -> None:
        ans = self.client.intersect(TUTORIAL, [RAY])
        hit = ans["hits"][0]
        self.assertEqual(hit["name"], "sphere 3")
        self.assertEqual(hit["t"], 7.267949192431123)
        # Rays as tuples and as six numbers are the same rays.
        again = self.client.intersect(TUTORIAL, [((0, 0, 0), (0, 0, 1)), [0, 0, 0, 0, 0, 1]])
        self.assertEqual([h["t"] for h in again["hits"]], [hit["t"]] * 2)

    def test_modes_precision_and_fields(self) -> None:
        rays = [RAY, {"origin": [0, 0, 0], "direction": [0, 0, -1]}]
        every = self.client.intersect(TUTORIAL, rays, mode="all")["hits"]
        self.assertEqual(every[0]["count"], 4)
        self.assertEqual([h["name"] for h in every[0]["hits"]][:2], ["sphere 3", "sphere 1"])
        self.assertEqual(every[1], {"count": 0, "hits": []})
        self.assertEqual(
            [h["count"] for h in self.client.intersect(TUTORIAL, rays, mode="count")["hits"]],
            [4, 0],
        )
        self.assertEqual(
            self.client.intersect(TUTORIAL, rays, mode="any")["hits"],
            [{"hit": True}, {"hit": False}],
        )
        only_t = self.client.intersect(TUTORIAL, [RAY], precision="exact", fields=["t"])
        self.assertEqual(set(only_t["hits"][0]) - {"hit"}, {"t"})
        # tmax = inf is the default (JSON cannot carry it): the client leaves it out.
        self.assertTrue(
            self.client.intersect(TUTORIAL, [((0, 0, 0), (0, 0, 1), 0, float("inf"))])["hits"][0][
                "hit"
            ]
        )

    def test_scene_lifecycle_by_id_and_by_file(self) -> None:
        summary = self.client.add_scene(TRIANGLE)
        sid = summary["id"]
        self.assertEqual(summary["triangles"], 1)
        self.assertEqual(self.client.add_scene(TRIANGLE)["id"], sid)  # content-addressed
        self.assertEqual(self.client.get_scene(sid)["id"], sid)
        self.assertIn(sid, [s["id"] for s in self.client.list_scenes()])
        hit = self.client.intersect(sid, [{"origin": [0.5, 0.5, 0], "direction": [0, 0, 1]}])[
            "hits"
        ][0]
        self.assertEqual((hit["name"], hit["t"], hit["barycentric"]), ("abc", 5, [0.25, 0.25]))
        with tempfile.TemporaryDirectory() as tmp:
            path = pathlib.Path(tmp) / "triangle.json"
            path.write_text(json.dumps(TRIANGLE))
            self.assertEqual(self.client.scene_id(path), sid)
            obj = pathlib.Path(tmp) / "tri.obj"
            obj.write_text("v 0 0 5\nv 2 0 5\nv 0 2 5\nf 1 2 3\n")
            model = self.client.add_scene(obj)
            self.assertEqual(model["triangles"], 1)
        self.assertEqual(self.client.delete_scene(sid), {"id": sid, "deleted": True})
        with self.assertRaises(NotFound) as cm:
            self.client.get_scene(sid)
        self.assertEqual(cm.exception.code, "scene_not_found")
        self.assertEqual(cm.exception.status, 404)

    def test_trace_question_2(self) -> None:
        scene = json.loads(
            (pathlib.Path(__file__).parents[3] / "tests/golden/scenes/tutorial_q2.json").read_text()
        )
        ans = self.client.trace(scene, RAY, max_depth=5)
        self.assertEqual(
            ans["summary"],
            {"points": 5, "full_phong": ["I1", "I2", "I3"], "ambient_only": ["I4", "I5"]},
        )
        self.assertEqual(ans["tree"]["refracted"]["label"], "I4")
        miss = self.client.trace(scene, {"origin": [0, 0, 0], "direction": [1, 0, 0]})
        self.assertIsNone(miss["tree"])

    def test_explain_json_and_markdown(self) -> None:
        ex = self.client.explain(TUTORIAL, RAY)
        self.assertEqual(ex["objects"][0]["roots"], [8, 12])
        self.assertEqual(ex["first_hit"]["name"], "sphere 3")
        md = self.client.explain(TUTORIAL, RAY, markdown=True)
        self.assertIsInstance(md, str)
        self.assertIn("**sphere 3**", md)

    def test_render_sync_and_with_progress(self) -> None:
        png = self.client.render(TUTORIAL, 32, 24, 1, shading="normal")
        self.assertEqual((read_png(png).width, read_png(png).height), (32, 24))
        seen: list[tuple[float, str]] = []
        png2 = self.client.render(
            TUTORIAL,
            32,
            24,
            1,
            shading="normal",
            progress=lambda p, s: seen.append((p, s["state"])),
            poll_s=0.02,
        )
        self.assertEqual(png2, png)  # deterministic renders: the job's image is the same
        self.assertEqual(seen[-1], (1.0, "done"))
        self.assertTrue(all(0.0 <= p <= 1.0 for p, _ in seen))

    def test_jobs(self) -> None:
        sid = self.client.scene_id(TUTORIAL)
        job = self.client._json(
            "POST", f"/v1/scenes/{sid}/render", {"width": 16, "height": 16, "async": True}
        )["job"]
        status = self.client.wait_job(job, poll_s=0.02)
        self.assertEqual(status["state"], "done")
        self.assertEqual(self.client.job(job)["progress"], 1)
        self.assertTrue(self.client.job_image(job).startswith(b"\x89PNG"))
        self.assertTrue(self.client.cancel_job(job)["deleted"])
        with self.assertRaises(NotFound):
            self.client.job(job)

    def test_points_json(self) -> None:
        ans = self.client.points(TUTORIAL, [[0, 0, 0], [0, 0, 10]], query="closest")
        self.assertEqual(ans["query"], "closest")
        self.assertTrue(ans["results"][0]["found"])
        inside = self.client.points(TUTORIAL, [[0, 0, 10], [0, 0, -5]], query="occupancy")[
            "results"
        ]
        self.assertEqual([r["inside"] for r in inside], [True, False])


class ExplainFilesTest(ServerTestCase):
    """explain(doc | Path): a `.json` document or a model file, sent inline (nothing is
    registered); a registered id cannot be explained, and says so."""

    def setUp(self) -> None:
        tmp = tempfile.TemporaryDirectory()
        self.addCleanup(tmp.cleanup)
        self.dir = pathlib.Path(tmp.name)

    def test_a_document_file_and_model_files(self) -> None:
        before = {s["id"] for s in self.client.list_scenes()}
        doc = self.dir / "spheres.json"
        doc.write_text(json.dumps(TUTORIAL))
        self.assertEqual(self.client.explain(doc, RAY)["first_hit"]["name"], "sphere 3")
        ray = ((0.5, 0.5, 0), (0, 0, 1))
        obj = write_obj_with_files(self.dir)  # with its .mtl and texture beside it
        hit = self.client.explain(obj, ray)["first_hit"]
        self.assertEqual((hit["name"], hit["t"]), ("tri", 5))
        (self.dir / "plain.obj").write_text("v 0 0 5\nv 2 0 5\nv 0 2 5\nf 1 2 3\n")
        hit = self.client.explain(self.dir / "plain.obj", ray)["first_hit"]
        self.assertEqual((hit["name"], hit["t"]), ("plain", 5))
        gltf = write_gltf_with_files(self.dir)  # its .bin beside it
        self.assertEqual(self.client.explain(gltf, ray)["first_hit"]["t"], 5)
        self.assertIn("tri", self.client.explain(obj, ray, markdown=True))
        self.assertEqual({s["id"] for s in self.client.list_scenes()}, before)

    def test_a_registered_id_or_an_unknown_file_is_a_clear_error(self) -> None:
        sid = self.client.add_scene(TUTORIAL)["id"]
        with self.assertRaisesRegex(ValueError, "no form for a registered id"):
            self.client.explain(sid, RAY)
        odd = self.dir / "model.xyz"
        odd.write_text("v 0 0 5\n")
        with self.assertRaisesRegex(ValueError, "cannot tell the model format"):
            self.client.explain(odd, RAY)
        bad = self.dir / "bad.json"
        bad.write_text("{nope")
        with self.assertRaisesRegex(ValueError, "not a JSON scene document"):
            self.client.explain(bad, RAY)

    def test_scene_document_of_a_gltf_carries_its_buffers_not_its_images(self) -> None:
        from raycastd.client import scene_document

        gltf = write_gltf_with_files(self.dir)
        mesh = scene_document(gltf)["objects"][0]
        self.assertEqual((mesh["type"], mesh["format"], mesh["name"]), ("mesh", "gltf", "tri"))
        inner = json.loads(base64.b64decode(mesh["data_base64"]))
        self.assertTrue(inner["buffers"][0]["uri"].startswith("data:application/octet-stream"))
        self.assertEqual(inner["images"][0]["uri"], "red.png")
        self.assertIsNone(scene_document(self.dir / "tri data.bin"))


class GltfFilesTest(ServerTestCase):
    """A `.gltf` beside its buffers and images is sent with them inside it (data URIs): the
    server takes only self-contained uploads."""

    def setUp(self) -> None:
        tmp = tempfile.TemporaryDirectory()
        self.addCleanup(tmp.cleanup)
        self.dir = pathlib.Path(tmp.name)

    def test_buffers_and_images_beside_the_file_are_embedded(self) -> None:
        path = write_gltf_with_files(self.dir)
        # As it is, the server refuses it (it reads no file an upload names).
        with self.assertRaises(ClientError) as cm:
            self.client.request("POST", "/v1/scenes", path.read_bytes(), "model/gltf+json")
        self.assertEqual(cm.exception.code, "model_load_failed")
        packed = json.loads(embed_gltf_files(path.read_bytes(), path.parent))
        self.assertTrue(packed["buffers"][0]["uri"].startswith("data:application/octet-stream;"))
        self.assertTrue(packed["images"][0]["uri"].startswith("data:image/png;base64,"))
        summary = self.client.add_scene(path)
        self.assertEqual(summary["triangles"], 1)
        self.assertTrue(summary["features"]["textures"], summary)  # the PNG was decoded
        self.assertEqual(summary["warnings"], [])
        hit = self.client.intersect(summary["id"], [RAY])["hits"][0]
        self.assertEqual(hit["t"], 5)

    def test_a_missing_buffer_is_named_and_a_missing_image_left_to_the_server(self) -> None:
        path = write_gltf_with_files(self.dir)
        (self.dir / "red.png").unlink()
        summary = self.client.add_scene(path)  # the image as the server would: a warning
        self.assertEqual(summary["triangles"], 1)
        self.assertFalse(summary["features"]["textures"])
        self.assertTrue(any("red.png" in w for w in summary["warnings"]), summary["warnings"])
        (self.dir / "tri data.bin").unlink()
        with self.assertRaises(raycastd.ModelLoadFailed) as cm:
            self.client.add_scene(path)
        self.assertEqual(
            (cm.exception.code, cm.exception.path), ("model_load_failed", "buffers[0].uri")
        )
        self.assertIn("tri%20data.bin", str(cm.exception))
        self.assertIsNone(cm.exception.status)

    def test_only_files_beside_it_are_sent(self) -> None:
        # Packing a .gltf from elsewhere must not carry other files of this machine with it.
        inner = self.dir / "model"
        inner.mkdir()
        (self.dir / "secret.png").write_bytes(b"\x89PNG\r\n\x1a\n")
        for uri in ("../secret.png", "/etc/hostname", "file:///etc/hostname", "http://x/y.png"):
            path = write_gltf_with_files(inner, image_uri=uri)
            with self.assertRaises(raycastd.ModelLoadFailed) as cm:
                embed_gltf_files(path.read_bytes(), inner)
            self.assertEqual(cm.exception.path, "images[0].uri", uri)

    def test_an_edited_buffer_is_a_new_scene(self) -> None:
        path = write_gltf_with_files(self.dir)
        first = self.client.scene_id(path)
        self.assertEqual(self.client.scene_id(path), first)  # the same files: asked once
        write_gltf_with_files(self.dir, z=7.0)
        bin_file = self.dir / "tri data.bin"
        os.utime(bin_file, ns=(bin_file.stat().st_atime_ns, bin_file.stat().st_mtime_ns + 10**9))
        second = self.client.scene_id(path)
        self.assertNotEqual(second, first)
        self.assertEqual(self.client.intersect(second, [RAY])["hits"][0]["t"], 7)

    def test_a_self_contained_file_is_sent_as_it_is(self) -> None:
        body = b'{"asset": {"version": "2.0"}, "buffers": [{"uri": "data:,", "byteLength": 0}]}'
        self.assertIs(embed_gltf_files(body, pathlib.Path(".")), body)
        self.assertIs(embed_gltf_files(b"not json", pathlib.Path(".")), b"not json")

    def test_the_fox_with_its_texture(self) -> None:
        fox = REPO.parent / "shared" / "data" / "models" / "Fox" / "glTF" / "Fox.gltf"
        if not fox.exists():
            self.skipTest(f"the shared models are not at {fox.parent}")
        summary = self.client.add_scene(fox)
        self.assertGreater(summary["triangles"], 500)
        self.assertTrue(summary["features"]["textures"], summary)


class ObjFilesTest(ServerTestCase):
    """An OBJ whose material library and textures are files beside it is sent as a scene
    document with them in its mesh object's `files`: the server reads no file an upload names."""

    def setUp(self) -> None:
        tmp = tempfile.TemporaryDirectory()
        self.addCleanup(tmp.cleanup)
        self.dir = pathlib.Path(tmp.name)

    def carried(self, path: pathlib.Path) -> list[str]:
        return sorted(obj_files(path.read_bytes(), path.parent)[0])

    def test_its_mtl_and_textures_are_carried(self) -> None:
        path = write_obj_with_files(self.dir)
        self.assertEqual(self.carried(path), ["sub/tex/red.png", "sub/tri.mtl"])
        # As it is, it registers with no material and the server says why.
        raw = self.client.add_scene(path.read_bytes(), "model/obj")
        self.assertFalse(raw["features"]["textures"])
        self.assertTrue(any("sub/tri.mtl" in w for w in raw["warnings"]), raw["warnings"])
        summary = self.client.add_scene(path)
        self.assertEqual((summary["objects"], summary["triangles"]), (1, 1))
        self.assertTrue(summary["features"]["textures"], summary)  # the PNG was decoded
        self.assertEqual(summary["warnings"], [])
        self.assertEqual(summary["default_view"], "+z")
        hit = self.client.intersect(summary["id"], [RAY], fields=["t", "name"])["hits"][0]
        self.assertEqual((hit["t"], hit["name"]), (5, "tri"))

    def test_an_edited_or_new_mtl_is_a_new_scene(self) -> None:
        path = write_obj_with_files(self.dir)
        mtl = self.dir / "sub" / "tri.mtl"
        text = mtl.read_text()
        mtl.unlink()  # absent at first: the OBJ goes as it is
        first = self.client.scene_id(path)
        self.assertEqual(self.client.scene_id(path), first)  # nothing changed: asked once
        mtl.write_text(text)  # it appears, the .obj untouched
        second = self.client.scene_id(path)
        self.assertNotEqual(second, first)
        self.assertTrue(self.client.get_scene(second)["features"]["textures"])
        mtl.write_text(text.replace("Kd 1 1 1", "Kd 0.5 0.5 0.5"))  # edited
        os.utime(mtl, ns=(mtl.stat().st_atime_ns, mtl.stat().st_mtime_ns + 10**9))
        self.assertNotEqual(self.client.scene_id(path), second)

    def test_names_are_read_as_the_server_reads_them(self) -> None:
        path = write_obj_with_files(self.dir)
        lines = path.read_text().splitlines()
        # A comment after the name, and the statement continued on the next line.
        lines[0] = "mtllib \\\n   sub/tri.mtl # the materials"
        path.write_text("\n".join(lines) + "\n")
        self.assertEqual(self.carried(path), ["sub/tex/red.png", "sub/tri.mtl"])
        # map_Kd with options (an infinite number is not one: the file name starts there), a
        # '#' in the name (no comment in map_Kd) and a no-break space, which is not a blank.
        mtl = self.dir / "sub" / "tri.mtl"
        (self.dir / "sub" / "inf a#\u00a0b.png").write_bytes(
            (self.dir / "sub" / "tex" / "red.png").read_bytes()
        )
        mtl.write_text("newmtl red\nmap_Kd -s 1 1 inf a#\u00a0b.png\n")
        self.assertEqual(self.carried(path), ["sub/inf a#\u00a0b.png", "sub/tri.mtl"])
        summary = self.client.add_scene(path)
        self.assertEqual(summary["warnings"], [])
        self.assertTrue(summary["features"]["textures"])

    def test_map_kd_names_as_the_server_reads_them(self) -> None:
        # The cases of ObjReader.DiffuseMapNamesAreReadWordByWord: an infinite or out-of-range
        # number ends -s's numbers, "+-1" is one, '#' is part of a name (also its first letter),
        # an unknown option starts the name, a no-break space is not a blank.
        mtl = (
            "map_Kd -s 1 1 inf a.png\nmap_Kd -s 1e-400 b.png\nmap_Kd -s +-1 1 1 c.png\n"
            "map_Kd tex#1.png\nmap_Kd #x.png\nmap_Kd -zz d.png\nmap_Kd a\u00a0b.png\n"
        )
        self.assertEqual(
            mtl_textures(mtl),
            [
                "inf a.png",
                "1e-400 b.png",
                "c.png",
                "tex#1.png",
                "#x.png",
                "-zz d.png",
                "a\u00a0b.png",
            ],
        )

    def test_one_texture_of_two_libraries_goes_once(self) -> None:
        # Two libraries in sibling folders naming ../tex/red.png: one file, sent under one
        # name (two spellings of it had been refused as naming the same file twice).
        path = write_obj_with_files(self.dir)
        for d in ("m1", "m2"):
            (self.dir / d).mkdir()
            (self.dir / d / "lib.mtl").write_text("newmtl red\nmap_Kd ../sub/tex/red.png\n")
        path.write_text(
            path.read_text().replace("mtllib sub/tri.mtl", "mtllib m1/lib.mtl\nmtllib m2/lib.mtl")
        )
        self.assertEqual(self.carried(path), ["m1/lib.mtl", "m2/lib.mtl", "sub/tex/red.png"])
        summary = self.client.add_scene(path)
        self.assertTrue(summary["features"]["textures"], summary)

    def test_what_the_server_cannot_use_is_left_to_it(self) -> None:
        # An image of another kind (the server decodes PNG and JPEG) and an .mtl that cannot be
        # read are not sent; the server warns about them, as for an absent file.
        path = write_obj_with_files(self.dir)
        mtl = self.dir / "sub" / "tri.mtl"
        (self.dir / "sub" / "tex" / "red.tga").write_bytes(b"\x00\x00\x02" + bytes(15))
        mtl.write_text("newmtl red\nmap_Kd tex/red.tga\n")
        self.assertEqual(self.carried(path), ["sub/tri.mtl"])
        # Unreadable (as root every file reads: the read is made to fail instead of chmod).
        real = pathlib.Path.read_text

        def refuse(self: pathlib.Path, *args, **kwargs):
            if self.name == "tri.mtl":
                raise PermissionError(13, "Permission denied")
            return real(self, *args, **kwargs)

        with mock.patch.object(pathlib.Path, "read_text", refuse):
            self.assertEqual(self.carried(path), [])
            self.assertIsNone(obj_document(path.read_bytes(), self.dir, "tri"))

    def test_names_out_of_its_folder_are_left_to_the_server(self) -> None:
        # Only files inside the OBJ's folder travel: a library named by an absolute path, a
        # Windows drive or a climb out is not read, and the server warns it cannot read it.
        inner = self.dir / "model"
        inner.mkdir()
        (self.dir / "secret.mtl").write_text("newmtl red\nKd 1 0 0\n")
        for name in ("../secret.mtl", str(self.dir / "secret.mtl"), "C:\\x\\secret.mtl"):
            path = write_obj_with_files(inner, mtllib=name)
            self.assertEqual(self.carried(path), [], name)
            self.assertIsNone(obj_document(path.read_bytes(), inner, "tri"))
            summary = self.client.add_scene(path)
            self.assertTrue(any("secret.mtl" in w for w in summary["warnings"]), name)
        # Nor a texture the library names out of the folder, or through a symlink out of it.
        path = write_obj_with_files(inner)
        (inner / "sub" / "tri.mtl").write_text("newmtl red\nmap_Kd ../../secret.mtl\n")
        self.assertEqual(self.carried(path), ["sub/tri.mtl"])
        (self.dir / "secret.png").write_bytes((inner / "sub" / "tex" / "red.png").read_bytes())
        (inner / "sub" / "out.png").symlink_to(self.dir / "secret.png")
        (inner / "sub" / "tri.mtl").write_text("newmtl red\nmap_Kd out.png\n")
        self.assertEqual(self.carried(path), ["sub/tri.mtl"])

    def test_the_spider_with_its_textures(self) -> None:
        spider = REPO.parent / "shared" / "data" / "models" / "spider" / "spider.obj"
        if not spider.exists():
            self.skipTest(f"the shared models are not at {spider.parent}")
        summary = self.client.add_scene(spider)
        self.assertEqual(summary["triangles"], 1368)
        self.assertTrue(summary["features"]["textures"], summary)
        self.assertEqual(summary["warnings"], [])


class ErrorsTest(ServerTestCase):
    def test_error_carries_code_message_path_status_request_id(self) -> None:
        bad = {"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": -1}]}
        with self.assertRaises(BadRequest) as cm:
            self.client.intersect(bad, [RAY])
        err = cm.exception
        self.assertIsInstance(err, ClientError)
        self.assertIsInstance(err, RaycastdError)
        self.assertEqual(
            (err.status, err.code, err.path), (400, "invalid_scene", "/scene/objects/0/radius")
        )
        self.assertTrue(err.request_id and err.request_id.startswith("rq_"))
        self.assertIn("radius", err.message)
        self.assertIn("invalid_scene", str(err))

    def test_invalid_ray_and_unknown_route(self) -> None:
        with self.assertRaises(BadRequest) as cm:
            self.client.intersect(TUTORIAL, [{"origin": [0, 0, 0], "direction": [0, 0, 0]}])
        self.assertEqual(cm.exception.code, "invalid_ray")
        with self.assertRaises(NotFound) as cm:
            self.client.request("GET", "/v1/nothing-here")
        self.assertEqual(cm.exception.code, "not_found")
        with self.assertRaises(NotFound) as cm:
            self.client.trace("sc_00000000000000000000000000000000", RAY)
        self.assertEqual(cm.exception.code, "scene_not_found")

    def test_connection_failure_names_the_url(self) -> None:
        with socket.socket() as s:  # a port nothing listens on
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        url = f"http://127.0.0.1:{port}"
        with Client(url, timeout=2) as c:
            with self.assertRaises(ConnectionFailed) as cm:
                c.health()
        self.assertIn(url, str(cm.exception))
        self.assertEqual(cm.exception.url, url + "/v1/health")
        self.assertIsNone(cm.exception.status)

    def test_keep_alive_survives_a_closed_connection(self) -> None:
        with Client(self.server.url) as c:
            c.health()
            assert c._conn is not None and c._conn.sock is not None
            c._conn.sock.shutdown(socket.SHUT_RDWR)  # as if the server had timed it out
            self.assertEqual(c.health(), {"status": "ok"})


class UrlAndTokenTest(unittest.TestCase):
    def test_url_defaults(self) -> None:
        with mock.patch.dict(os.environ, {"RAYCASTD_URL": "http://example.invalid:9"}):
            self.assertEqual(Client().url, "http://example.invalid:9")
            self.assertEqual(Client("http://127.0.0.1:1/").url, "http://127.0.0.1:1")
        with mock.patch.dict(os.environ, {}, clear=True):
            self.assertEqual(Client().url, raycastd.DEFAULT_URL)
        with self.assertRaises(ValueError):
            Client("ftp://x")

    def test_token_is_sent_as_bearer(self) -> None:
        seen: list[str | None] = []

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_POST(self) -> None:  # noqa: N802 (http.server's name)
                seen.append(self.headers.get("Authorization"))
                self.rfile.read(int(self.headers.get("Content-Length", 0)))
                body = b'{"error":{"code":"unauthorized","message":"bearer token required"}}'
                self.send_response(401)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.send_header("X-Request-Id", "rq_7")
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args: object) -> None:
                pass

        httpd = http.server.HTTPServer(("127.0.0.1", 0), Handler)
        thread = threading.Thread(target=httpd.serve_forever, daemon=True)
        thread.start()
        try:
            with Client(f"http://127.0.0.1:{httpd.server_address[1]}", token="s3cret") as c:
                with self.assertRaises(raycastd.Unauthorized) as cm:
                    c.add_scene(TUTORIAL)
        finally:
            httpd.shutdown()
            httpd.server_close()
        self.assertEqual(seen, ["Bearer s3cret"])
        self.assertEqual((cm.exception.code, cm.exception.request_id), ("unauthorized", "rq_7"))


# What the fake servers below answer to a query: no hit.
ANSWER = b'{"precision":"refined","mode":"closest","hits":[null]}'


def serve_posts(
    test: unittest.TestCase, respond: Callable[[http.server.BaseHTTPRequestHandler, int], None]
) -> tuple[str, list[str]]:
    """A threaded HTTP/1.1 server on a free port for the test's duration: it reads each POST's
    body, notes its path, then calls `respond(handler, n)` for the n-th POST (from 1). Returns
    its URL and the paths seen."""
    seen: list[str] = []

    class Handler(http.server.BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.1"

        def do_POST(self) -> None:  # noqa: N802 (http.server's name)
            self.rfile.read(int(self.headers.get("Content-Length", 0)))
            seen.append(self.path)
            respond(self, len(seen))

        def log_message(self, *args: object) -> None:
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    test.addCleanup(httpd.server_close)
    test.addCleanup(httpd.shutdown)
    return f"http://127.0.0.1:{httpd.server_address[1]}", seen


def answer_head(handler: http.server.BaseHTTPRequestHandler) -> None:
    """The status line and headers of a 200 carrying ANSWER."""
    handler.send_response(200)
    handler.send_header("Content-Type", "application/json")
    handler.send_header("Content-Length", str(len(ANSWER)))
    handler.end_headers()


class CutAnswerTest(unittest.TestCase):
    """An answer cut short (behind nginx: the replica died while writing it) is asked once more
    when the request is pure, and is an error for a render, which may have started a job."""

    def serve_cutting(self, cut: int = 1, reset: bool = False) -> tuple:
        """A server that cuts its answer to the `cut`-th request short (closing the connection,
        or with `reset` resetting it), and answers the rest."""

        def respond(h: http.server.BaseHTTPRequestHandler, n: int) -> None:
            answer_head(h)
            if n != cut:
                h.wfile.write(ANSWER)
                return
            h.wfile.write(ANSWER[:5])  # the header and a few bytes, then the connection closes
            h.close_connection = True
            if reset:  # SO_LINGER 0: the close sends RST, read as ConnectionResetError
                time.sleep(0.1)  # the bytes above reach the client first
                h.connection.setsockopt(
                    socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0)
                )
                h.connection.close()

        return serve_posts(self, respond)

    def test_a_query_is_asked_again(self) -> None:
        url, seen = self.serve_cutting()
        with Client(url, timeout=5) as c:
            got = c.intersect("sc_0", [RAY])
        self.assertEqual(got["hits"], [None])
        self.assertEqual(seen, ["/v1/scenes/sc_0/intersect"] * 2)

    def test_a_render_is_not(self) -> None:
        url, seen = self.serve_cutting()
        with Client(url, timeout=5) as c:
            with self.assertRaises(ConnectionFailed):
                c.render("sc_0", width=8, height=8)
        self.assertEqual(seen, ["/v1/scenes/sc_0/render"])
        # Nor on a kept-alive connection, where a failure before the answer is taken for the
        # server's idle close and the request sent again.
        url, seen = self.serve_cutting(cut=2, reset=True)
        with Client(url, timeout=5) as c:
            c.intersect("sc_0", [RAY])
            with self.assertRaises(ConnectionFailed):
                c.render("sc_0", width=8, height=8)
        self.assertEqual(seen, ["/v1/scenes/sc_0/intersect", "/v1/scenes/sc_0/render"])


class KeptAliveTest(unittest.TestCase):
    """A kept-alive connection the server closed while it sat idle is replaced before the next
    request is sent; one the server closes after taking a request unanswered (it died) sends
    only a pure request again, never a render."""

    def serve(self, silent: int = 0, idle_close: bool = False) -> tuple:
        """A server answering every POST on one kept-alive connection, which it closes without
        a byte of answer upon the `silent`-th request, or, with `idle_close`, right after its
        first answer (as its keep-alive timeout would, the client not told)."""

        def respond(h: http.server.BaseHTTPRequestHandler, n: int) -> None:
            if n == silent:
                h.close_connection = True
                return
            answer_head(h)
            h.wfile.write(ANSWER)
            h.wfile.flush()
            h.close_connection = idle_close and n == 1

        return serve_posts(self, respond)

    def test_an_idle_close_is_seen_before_a_render_is_sent(self) -> None:
        url, seen = self.serve(idle_close=True)
        with Client(url, timeout=5) as c:
            c.intersect("sc_0", [RAY])
            assert c._conn is not None and c._conn.sock is not None
            select.select([c._conn.sock], [], [], 10)  # the server's close reaches the client
            first = c._conn
            c.request("POST", "/v1/scenes/sc_0/render", b"{}", "application/json")
            self.assertIsNot(c._conn, first)  # a fresh connection
        self.assertEqual(seen, ["/v1/scenes/sc_0/intersect", "/v1/scenes/sc_0/render"])

    def test_a_render_the_server_took_unanswered_is_not_sent_again(self) -> None:
        url, seen = self.serve(silent=2)
        with Client(url, timeout=5) as c:
            c.intersect("sc_0", [RAY])
            with self.assertRaises(ConnectionFailed):
                c.request("POST", "/v1/scenes/sc_0/render", b"{}", "application/json")
        self.assertEqual(seen, ["/v1/scenes/sc_0/intersect", "/v1/scenes/sc_0/render"])

    def test_a_query_the_server_took_unanswered_is_sent_again(self) -> None:
        url, seen = self.serve(silent=2)
        with Client(url, timeout=5) as c:
            c.intersect("sc_0", [RAY])
            self.assertEqual(c.intersect("sc_0", [RAY])["hits"], [None])
        self.assertEqual(seen, ["/v1/scenes/sc_0/intersect"] * 3)


if __name__ == "__main__":
    unittest.main()
