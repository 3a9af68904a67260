"""The grading kit, after a new-user review: blank rows in a program's output, question fields
that name objects (`object`, first_hit's `expected`) following index_base, a question that
cannot be graded making `grade` exit 1, the camera an image question's program is given when
neither the question nor its scene has one, the tutorial 7 sample graded as the platforms run it,
and a server binary named explicitly that does not exist.

Run as the other client tests are:
    cd clients/python/tests && RAYCASTD_BINARY=build/release/server/raycastd \\
        python3 -m unittest test_grading_review
"""

from __future__ import annotations

import io
import json
import math
import os
import pathlib
import shutil
import subprocess
import tempfile
import unittest
from unittest import mock

from support import GRADING, TUTORIAL, TUTORIAL7, ServerTestCase

from raycastd.cli import main
from raycastd.grading import compare as cmp
from raycastd.grading import load_questions
from raycastd.grading import cli as grading_cli
from raycastd.grading.grader import Answers, Grader, _read_output, default_camera, grade_files
from raycastd.grading.questions import QuestionFileError, parse_questions
from raycastd.png import read_png

QUESTIONS = TUTORIAL7 / "questions.toml"
CORRECT = TUTORIAL7 / "submissions" / "correct"
WRONG = TUTORIAL7 / "submissions" / "wrong"
RAY = {"origin": [0, 0, 0], "direction": [0, 0, 1]}
THREE_RAYS = [[0, 0, 0, 0, 0, 1], [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 1]]  # hit, miss, hit
BALL = {"objects": [{"type": "sphere", "center": [0, 0, 10], "radius": 2}]}
TWO_TRIANGLES = {
    "objects": [
        {"type": "triangle", "name": "abc", "vertices": [[0, 0, 5], [2, 0, 5], [0, 2, 5]]},
        {"type": "triangle", "name": "def", "vertices": [[10, 0, 5], [12, 0, 5], [10, 2, 5]]},
    ]
}


def one(question: dict, grading: dict | None = None):
    """The single Question of a question file holding `question`."""
    data = {"question": [question]}
    if grading:
        data["grading"] = grading
    return parse_questions(data, pathlib.Path(".")).questions[0]


def write_program(folder: pathlib.Path, outputs: dict[str, str]) -> list[str]:
    """A student program that writes `outputs[question id]` to its output file."""
    (folder / "prog.py").write_text(
        "import json, sys\n"
        f"OUT = {json.dumps(outputs)}\n"
        "open(sys.argv[2], 'w', newline='').write(OUT[sys.argv[1]])\n"
    )
    return ["{python}", "{submission}/prog.py", "{question}", "{output}"]


class BlankRowTest(unittest.TestCase):
    """Item 1: a blank line in a program's output is a row holding a miss (t, hits,
    triangle_hit), and a trailing newline is not an extra row."""

    def read(self, ask: str, text: str, rays=THREE_RAYS):
        q = one({"id": "q", "scene": BALL, "ask": ask, "rays": rays, "answer_file": "out.csv"})
        with tempfile.TemporaryDirectory() as tmp:
            path = pathlib.Path(tmp) / "out.csv"
            path.write_bytes(text.encode())
            return _read_output(q, path)

    def test_a_blank_line_is_a_miss_for_t(self) -> None:
        inf = float("inf")
        self.assertEqual(self.read("t", "8\n\n8\n"), [8.0, inf, 8.0])
        self.assertEqual(self.read("t", "8\r\n\r\n8\r\n"), [8.0, inf, 8.0])
        self.assertEqual(self.read("t", "8\n\n8"), [8.0, inf, 8.0])  # no final newline
        self.assertEqual(self.read("t", "\n8\n8\n"), [inf, 8.0, 8.0])  # the first ray misses
        self.assertEqual(self.read("t", "8\n8\n\n"), [8.0, 8.0, inf])  # the last ray misses
        self.assertEqual(self.read("t", "8\n\n8\n\n\n"), [8.0, inf, 8.0])  # trailing blank lines
        self.assertEqual(self.read("t", "t\n8\n\n8\n"), [8.0, inf, 8.0])  # a header row
        self.assertEqual(self.read("t", "# t\n8\n\n8\n"), [8.0, inf, 8.0])  # a comment
        # Blank lines above the answers, past the number of rays, are not rows either.
        self.assertEqual(self.read("t", "\n7.25\n", rays=[THREE_RAYS[0]]), [7.25])
        self.assertEqual(self.read("t", "\n\n8\n8\n8\n"), [8.0, 8.0, 8.0])

    def test_a_blank_line_is_a_ray_with_no_hits_or_a_miss(self) -> None:
        self.assertEqual(self.read("hits", "8,12\n\n8,12\n"), [[8.0, 12.0], [], [8.0, 12.0]])
        self.assertEqual(self.read("triangle_hit", "1\n\n1\n"), [True, False, True])

    def test_inside_has_no_miss_and_keeps_skipping_blank_lines(self) -> None:
        q = one(
            {
                "id": "q",
                "scene": BALL,
                "ask": "inside",
                "points_at": [[0, 0, 10], [5, 0, 0]],
                "answer_file": "out.csv",
            }
        )
        with tempfile.TemporaryDirectory() as tmp:
            path = pathlib.Path(tmp) / "out.csv"
            path.write_text("1\n\n0\n")
            self.assertEqual(_read_output(q, path), [True, False])


class DefaultCameraTest(unittest.TestCase):
    """grader.default_camera mirrors engine/scene/scene.cpp default_camera (render_test.cpp
    Camera.AFlatSceneIsSeenFromAboveNotEdgeOn): a flat scene from 45° above or beside."""

    def test_a_flat_scene_is_seen_from_above(self) -> None:
        dist = math.sqrt(2) / math.sin(math.radians(22.5))
        ground = default_camera({"min": [-1, 0, -1], "max": [1, 0, 1]}, 1.0, "+z")
        self.assertEqual(ground["look_at"], [0, 0, 0])
        for got, want in zip(ground["position"], [0, dist / math.sqrt(2), dist / math.sqrt(2)]):
            self.assertAlmostEqual(got, want, places=12)
        wall = default_camera({"min": [0, -1, -1], "max": [0, 1, 1]}, 1.0, "-z")
        for got, want in zip(wall["position"], [dist / math.sqrt(2), 0, -dist / math.sqrt(2)]):
            self.assertAlmostEqual(got, want, places=12)
        box = default_camera({"min": [-1, -1, -1], "max": [1, 1, 1]}, 1.0, "+z")
        self.assertEqual(box["position"][:2], [0.0, 0.0])

    def test_a_tiny_scene_is_framed_at_its_own_size(self) -> None:
        # as Camera.TinyScenesAreFramedAtTheirOwnSize: a floor of 1e-9 had framed it from afar
        for s in (1e-300, 1e-20, 1.0, 1e20, 1e300):
            cam = default_camera({"min": [-s, -s, -s], "max": [s, s, s]}, 1.0, "-z")
            want = math.sqrt(3) / math.sin(math.radians(22.5))
            self.assertAlmostEqual(-cam["position"][2] / s, want, places=12)


class ObjectFieldTest(unittest.TestCase):
    """Items 2 and 3, at load time: `object` and first_hit's `expected` follow index_base and
    must name an object of the scene."""

    def test_object_index_follows_index_base(self) -> None:
        base = {"id": "q", "scene": TWO_TRIANGLES, "ray": RAY, "ask": "triangle_hit"}
        self.assertEqual(one({**base, "object": 1}, {"index_base": 1}).object, 0)
        self.assertEqual(one({**base, "object": 1}).object, 1)
        self.assertEqual(one({**base, "object": "ABC"}).object, "ABC")
        for obj, base_index, message in (
            (
                3,
                1,
                "object = 3 is not an object of the scene (index_base = 1: its objects are "
                "1 = abc, 2 = def)",
            ),
            (0, 1, "object = 0 is not an object"),
            ("xyz", 0, "object = 'xyz' names no object of the scene"),
            (True, 0, "object must be an object's name or index"),
        ):
            with self.assertRaises(QuestionFileError) as cm:
                parse_questions(
                    {"grading": {"index_base": base_index}, "question": [{**base, "object": obj}]},
                    pathlib.Path("."),
                )
            self.assertIn("question 1 (q): " + message, str(cm.exception))
        with self.assertRaises(QuestionFileError) as cm:
            parse_questions(
                {"question": [{**base, "ask": "first_hit", "object": 1}]}, pathlib.Path(".")
            )
        self.assertIn("object is read by triangle_hit questions only", str(cm.exception))

    def test_a_mesh_scene_names_its_objects(self) -> None:
        # A mesh object becomes as many objects as its file has parts, numbered by the server:
        # a name is taken as written, an index is refused with the reason.
        scene = {"objects": [{"type": "mesh", "uri": "duck.glb"}, TWO_TRIANGLES["objects"][0]]}
        q = one({"id": "q", "scene": scene, "ray": RAY, "ask": "first_hit", "expected": "abc"})
        self.assertEqual(q.expected, (-1, "abc"))
        q = one({"id": "q", "scene": scene, "ray": RAY, "ask": "triangle_hit", "object": "abc"})
        self.assertEqual(q.object, "abc")
        for extra in ({"ask": "first_hit", "expected": 2}, {"ask": "triangle_hit", "object": 2}):
            with self.assertRaises(QuestionFileError) as cm:
                parse_questions(
                    {"question": [{"id": "q", "scene": scene, "ray": RAY, **extra}]},
                    pathlib.Path("."),
                )
            self.assertIn("numbered by the server; name the object instead", str(cm.exception))

    def test_a_name_in_a_mesh_scene_is_matched_by_name_only(self) -> None:
        # (-1, name): an index answer cannot be matched; 0 with index_base 1 had equalled -1.
        q = one({"id": "q", "scene": BALL, "ray": RAY, "ask": "first_hit"}, {"index_base": 1})
        self.assertEqual(cmp.check_first_hit((-1, "Cylinder"), 0, q).credit, 0.0)
        self.assertEqual(cmp.check_first_hit((-1, "Cylinder"), " cylinder", q).credit, 1.0)
        self.assertEqual(cmp.check_first_hit((-1, "Cylinder"), "none", q).credit, 0.0)

    def test_first_hit_expected_is_resolved_against_the_scene(self) -> None:
        base = {"id": "q", "scene": TUTORIAL, "ray": RAY, "ask": "first_hit"}
        for expected in ("sphere 3", " Sphere3 ", 3, "3"):
            q = one({**base, "expected": expected}, {"index_base": 1})
            self.assertEqual(q.expected, (2, "sphere 3"), expected)
        self.assertEqual(one({**base, "expected": 2}).expected, (2, "sphere 3"))
        self.assertIsNone(one({**base, "expected": "none"}).expected)
        self.assertIsNone(one({**base, "expected": -1}).expected)
        many = {**base, "rays": [RAY, RAY]}
        del many["ray"]
        self.assertEqual(
            one({**many, "expected": [3, "none"]}, {"index_base": 1}).expected,
            [(2, "sphere 3"), None],
        )

    def test_a_wrong_expected_stops_the_run_naming_question_and_key(self) -> None:
        ray = {"id": "q", "scene": TUTORIAL, "ray": RAY}
        rays = {"id": "q", "scene": TUTORIAL, "rays": [RAY, RAY]}
        cases = [
            ({**ray, "ask": "first_hit", "expected": 4}, "expected = 4 is not an object"),
            ({**ray, "ask": "first_hit", "expected": "sphere 9"}, "names no object"),
            ({**ray, "ask": "first_hit", "expected": 2.5}, "expected must be an object's name"),
            ({**rays, "ask": "first_hit", "expected": [3]}, "expected must be a list of 2"),
            ({**ray, "ask": "t", "expected": "seven"}, "expected must be a number"),
            ({**ray, "ask": "hit_point", "expected": [0, 0]}, "expected must be 3 numbers"),
            ({**ray, "ask": "hits", "expected": 8}, "expected must be a list of numbers"),
            ({**ray, "ask": "triangle_hit", "expected": 1}, "expected must be true or false"),
            ({**ray, "ask": "full_phong", "expected": ["I1"]}, "expected cannot be given"),
        ]
        for question, message in cases:
            with self.assertRaises(QuestionFileError, msg=message) as cm:
                parse_questions(
                    {"grading": {"index_base": 1}, "question": [question]}, pathlib.Path(".")
                )
            self.assertIn("question 1 (q): ", str(cm.exception))
            self.assertIn(message, str(cm.exception))
        self.assertEqual(one({**ray, "ask": "t", "expected": "none"}).expected, float("inf"))
        self.assertEqual(one({**ray, "ask": "t", "expected": 7}).expected, 7.0)


class NamedServerBinaryTest(unittest.TestCase):
    """Item 6: a server binary named explicitly that does not exist (or cannot run) is an error
    naming it; the Gradescope zip is not built without a binary unless asked to be."""

    def test_a_named_binary_must_exist(self) -> None:
        env = {k: v for k, v in os.environ.items() if not k.startswith("RAYCASTD_")}
        with mock.patch.dict(os.environ, env, clear=True):
            self.assertIsNone(grading_cli.named_server_binary(None))
            with self.assertRaises(ValueError) as cm:
                grading_cli.named_server_binary("/nonexistent/raycastd")
            self.assertIn(
                "/nonexistent/raycastd (--server-binary) does not exist", str(cm.exception)
            )
            with tempfile.TemporaryDirectory() as tmp:
                script = pathlib.Path(tmp) / "raycastd"
                script.write_text("#!/bin/sh\n")
                script.chmod(0o755)
                with self.assertRaises(ValueError) as cm:
                    grading_cli.named_server_binary(str(script))
                self.assertIn("is a script", str(cm.exception))
        with mock.patch.dict(
            os.environ, {**env, "RAYCASTD_SERVER": "/nonexistent/rcd"}, clear=True
        ):
            with self.assertRaises(ValueError) as cm:
                grading_cli.named_server_binary(None)
            self.assertIn("/nonexistent/rcd ($RAYCASTD_SERVER) does not exist", str(cm.exception))

    def test_grade_exits_1_naming_a_missing_binary(self) -> None:
        env = {k: v for k, v in os.environ.items() if k != "RAYCASTD_URL"}
        for args, extra, named in (
            (["--server-binary", "/nonexistent/raycastd"], {}, "/nonexistent/raycastd"),
            ([], {"RAYCASTD_SERVER": "/nonexistent/rcd"}, "/nonexistent/rcd"),
        ):
            err = io.StringIO()
            with mock.patch.dict(os.environ, {**env, **extra}, clear=True):
                code = main(
                    ["grade", str(QUESTIONS), "--submission", str(CORRECT), *args],
                    io.StringIO(),
                    err,
                )
            self.assertEqual(code, 1, err.getvalue())
            self.assertIn(f"the server binary {named}", err.getvalue())
            self.assertIn("does not exist", err.getvalue())

    def test_make_autograder_needs_a_binary(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            # A checkout with no build tree: the script, the package, the question folder.
            repo = pathlib.Path(tmp) / "repo"
            shutil.copytree(GRADING / "gradescope", repo / "clients" / "grading" / "gradescope")
            (repo / "clients" / "python" / "raycastd").mkdir(parents=True)
            (repo / "clients" / "python" / "raycastd" / "__init__.py").write_text("")
            (repo / "q").mkdir()
            (repo / "q" / "questions.toml").write_text("")
            script = repo / "clients" / "grading" / "gradescope" / "make_autograder.sh"
            env = {k: v for k, v in os.environ.items() if k != "RAYCASTD_SERVER"}

            def make(*args: str, **extra: str) -> subprocess.CompletedProcess:
                return subprocess.run(
                    [str(script), *args, str(repo / "q"), str(repo / "ag.zip")],
                    env={**env, **extra},
                    capture_output=True,
                    text=True,
                    timeout=60,
                )

            typo = make(RAYCASTD_SERVER="/nonexistent/raycastd")
            self.assertEqual(typo.returncode, 1, typo.stderr)
            self.assertIn(
                "$RAYCASTD_SERVER=/nonexistent/raycastd is not an executable file", typo.stderr
            )
            none = make()
            self.assertEqual(none.returncode, 1, none.stderr)
            self.assertIn("no raycastd server binary", none.stderr)
            self.assertIn("--without-binary", none.stderr)
            self.assertFalse((repo / "ag.zip").exists())
            without = make("--without-binary")
            self.assertEqual(without.returncode, 0, without.stderr)
            import zipfile

            with zipfile.ZipFile(repo / "ag.zip") as z:
                names = set(z.namelist())
            self.assertIn("run_autograder", names)
            self.assertNotIn("bin/raycastd", names)


class GradingReviewServerTest(ServerTestCase):
    """The fixes end to end, with a real raycastd."""

    def grade(self, questions: dict, answers: dict, submission: pathlib.Path | None = None):
        qset = parse_questions(questions, submission or pathlib.Path("."))
        report = Grader(qset, self.server.url).grade(Answers(answers), submission)
        return {r.question.id: r for r in report.results}

    def test_blank_rows_of_a_program_are_misses(self) -> None:  # item 1
        with tempfile.TemporaryDirectory() as tmp:
            sub = pathlib.Path(tmp)
            program = write_program(
                sub, {"t": "8\n\n8\n", "hits": "8,12\n\n8,12\n", "tail": "8\n\n8\n\n"}
            )
            qs = [
                {"id": i, "scene": BALL, "rays": THREE_RAYS, "ask": a, "program": program}
                for i, a in (("t", "t"), ("hits", "hits"), ("tail", "t"))
            ]
            res = self.grade({"question": qs}, {}, sub)
        for qid in ("t", "hits", "tail"):
            self.assertTrue(res[qid].passed, f"{qid}: {res[qid].message}")

    def test_object_index_follows_index_base(self) -> None:  # item 2
        q = {
            "id": "first_triangle",
            "scene": TWO_TRIANGLES,
            "ray": {"origin": [0.5, 0.5, 0], "direction": [0, 0, 1]},
            "ask": "triangle_hit",
            "object": 1,  # index_base = 1: the first object, abc, which the ray hits
        }
        res = self.grade({"grading": {"index_base": 1}, "question": [q]}, {"first_triangle": True})
        self.assertTrue(res["first_triangle"].passed, res["first_triangle"].message)
        res = self.grade({"question": [q]}, {"first_triangle": False})  # index_base 0: def
        self.assertTrue(res["first_triangle"].passed, res["first_triangle"].message)

    def test_first_hit_expected_by_name_or_index(self) -> None:  # item 3
        base = {"scene": TUTORIAL, "ray": RAY, "ask": "first_hit"}
        qs = {
            "grading": {"index_base": 1},
            "question": [
                {**base, "id": "by_name", "expected": "sphere 3"},
                {**base, "id": "by_index", "expected": 3},
            ],
        }
        for answer in (3, "sphere 3", "Sphere3", "3"):
            res = self.grade(qs, {"by_name": answer, "by_index": answer})
            for qid in ("by_name", "by_index"):
                self.assertEqual(res[qid].message, "correct: sphere 3", f"{qid} {answer!r}")
                self.assertIsNone(res[qid].instructor_error)
        res = self.grade(qs, {"by_name": 1, "by_index": "sphere 1"})
        self.assertEqual(res["by_name"].message, "incorrect: expected sphere 3, got object 1")
        self.assertEqual(res["by_index"].message, "incorrect: expected sphere 3, got sphere 1")

    def test_a_question_that_cannot_be_graded_exits_1(self) -> None:  # item 3
        with tempfile.TemporaryDirectory() as tmp:
            root = pathlib.Path(tmp)
            (root / "q.toml").write_text(
                "[[question]]\nid = 'odd'\nask = 't'\nray = [0, 0, 0, 0, 0, 1]\n"
                "scene = { objects = [{ type = 'sphere', center = [0, 0, 5], radius = 1 }] }\n"
                "[[question]]\nid = 'fine'\nask = 't'\nray = [0, 0, 0, 0, 0, 1]\n"
                "scene = { objects = [{ type = 'sphere', center = [0, 0, 5], radius = 1 }] }\n"
            )
            (root / "answers.toml").write_text("odd = 4.0\nfine = 4.0\n")
            original = Grader._check

            def check(self, q, ref, val, scale):
                if q.id == "odd":
                    raise TypeError("'int' object is not subscriptable")
                return original(self, q, ref, val, scale)

            err = io.StringIO()
            gs = root / "results.json"
            with mock.patch.object(Grader, "_check", check):
                code = main(
                    ["grade", str(root / "q.toml"), "--answers", str(root / "answers.toml")]
                    + ["--gradescope", str(gs), "--server", self.server.url],
                    io.StringIO(),
                    err,
                )
            self.assertEqual(code, 1, err.getvalue())
            self.assertIn("question odd could not be graded: TypeError:", err.getvalue())
            self.assertNotIn("question fine", err.getvalue())
            scores = {t["number"]: t["score"] for t in json.loads(gs.read_text())["tests"]}
            self.assertEqual(scores, {"odd": 0, "fine": 1})

    def test_an_image_question_without_a_camera_gets_the_reference_camera(self) -> None:  # 4
        with tempfile.TemporaryDirectory() as tmp:
            sub = pathlib.Path(tmp)
            shutil.copy(CORRECT / "tracer.py", sub / "tracer.py")
            (sub / "keep.py").write_text(
                "import shutil, subprocess, sys\n"
                "shutil.copy(sys.argv[1], sys.argv[2])\n"
                "sys.exit(subprocess.call([sys.executable, *sys.argv[3:]]))\n"
            )
            tracer = ["{scene}", "{camera}", "{width}", "{height}", "{output}"]
            question = {
                "id": "img",
                "scene": BALL,  # no camera, in the scene or the question
                "ask": "image",
                "shading": "normal",
                "width": 64,
                "height": 48,
                "max_bad_fraction": 0.02,
                "program": ["{python}", "{submission}/keep.py", "{camera}", "{submission}/cam.json"]
                + ["{submission}/tracer.py", "image"]
                + tracer,
            }
            res = self.grade({"question": [question]}, {}, sub)
            camera = json.loads((sub / "cam.json").read_text())
        self.assertTrue(res["img"].passed, res["img"].message)
        self.assertEqual(set(camera), {"position", "look_at", "up", "fov_y_deg"})
        self.assertEqual(camera["look_at"], [0.0, 0.0, 10.0])
        self.assertLess(camera["position"][2], 10.0)  # seen from −z, the scene's default_view
        # The camera written is the one the server frames the scene with by default.
        sid = self.client.scene_id(BALL)
        default = self.client.render(sid, 64, 48, 1, shading="normal")
        given = self.client.render(sid, 64, 48, 1, shading="normal", camera=camera)
        self.assertEqual(read_png(default).pixels, read_png(given).pixels)

    def test_tutorial7_samples_graded_as_the_platforms_run_them(self) -> None:  # item 5
        qset = load_questions(QUESTIONS)
        wrong = grade_files(qset, self.server.url, None, WRONG)  # no --answers
        self.assertEqual(wrong.notes, [])
        self.assertAlmostEqual(wrong.score, 9.43, places=2)  # the README's figure
        correct = grade_files(qset, self.server.url, None, CORRECT)
        self.assertEqual(correct.score, 22.0)


if __name__ == "__main__":
    unittest.main()
