"""The grading kit: the tutorial 7 example end to end, both results formats, the failure paths,
tolerances, question-file checks, and the Gradescope / PrairieLearn entry scripts."""

from __future__ import annotations

import io
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import unittest
import zipfile
from unittest import mock

from support import GRADING, PACKAGE_ROOT, TUTORIAL, TUTORIAL7, ServerTestCase

from raycastd.cli import main
from raycastd.grading import Tolerance, load_questions
from raycastd.grading.grader import Answers, Grader, load_answers
from raycastd.grading.questions import QuestionFileError, parse_questions
from raycastd.grading.results import gradescope, prairielearn, text_report

QUESTIONS = TUTORIAL7 / "questions.toml"
CORRECT = TUTORIAL7 / "submissions" / "correct"
WRONG = TUTORIAL7 / "submissions" / "wrong"
MAX_POINTS = 22.0


# -- the documented shapes of both results files --------------------------------------------


def check_gradescope(test: unittest.TestCase, doc: dict) -> None:
    """Gradescope's autograder results: score, tests with score/max_score/status/name/output."""
    test.assertIsInstance(doc["score"], (int, float))
    test.assertIn(
        doc.get("visibility", "visible"), ("hidden", "after_due_date", "after_published", "visible")
    )
    test.assertIsInstance(doc["tests"], list)
    total = 0.0
    for t in doc["tests"]:
        test.assertLessEqual(
            {"score", "max_score", "status", "name", "output", "visibility"}, set(t)
        )
        test.assertIn(t["status"], ("passed", "failed"))
        test.assertIn(t["visibility"], ("hidden", "after_due_date", "after_published", "visible"))
        test.assertIsInstance(t["name"], str)
        test.assertIsInstance(t["output"], str)
        test.assertTrue(0 <= t["score"] <= t["max_score"])
        total += t["score"]
    test.assertAlmostEqual(total, doc["score"], places=6)
    json.dumps(doc)  # plain JSON


def check_prairielearn(test: unittest.TestCase, doc: dict) -> None:
    """PrairieLearn's external-grader results: score in [0, 1], tests with points/max_points."""
    test.assertIs(doc["gradable"], True)
    test.assertTrue(0.0 <= doc["score"] <= 1.0)
    test.assertIsInstance(doc["message"], str)
    test.assertIsInstance(doc["output"], str)
    for img in doc.get("images", []):
        test.assertTrue(img["url"].startswith("data:image/png;base64,"))
    points = max_points = 0.0
    for t in doc["tests"]:
        test.assertLessEqual({"name", "points", "max_points", "message"}, set(t))
        test.assertTrue(0 <= t["points"] <= t["max_points"])
        for img in t.get("images", []):
            test.assertIsInstance(img["label"], str)
            test.assertTrue(img["url"].startswith("data:image/png;base64,"))
        points += t["points"]
        max_points += t["max_points"]
    test.assertAlmostEqual(doc["score"], points / max_points, places=5)
    test.assertLess(len(json.dumps(doc)), 1 << 20)  # PrairieLearn's 1 MB limit


class TutorialExampleTest(ServerTestCase):
    @classmethod
    def setUpClass(cls) -> None:
        super().setUpClass()
        cls.qset = load_questions(QUESTIONS)
        cls.grader = Grader(cls.qset, cls.server.url)

    def grade(self, answers: pathlib.Path | None, submission: pathlib.Path | None):
        return self.grader.grade(load_answers(answers), submission)

    def test_correct_answers_score_full(self) -> None:
        report = self.grade(CORRECT / "answers.toml", CORRECT)
        bad = [(r.question.id, r.message) for r in report.results if not r.passed]
        self.assertEqual(bad, [])
        self.assertEqual((report.score, report.max_score), (MAX_POINTS, MAX_POINTS))
        by_id = {r.question.id: r for r in report.results}
        self.assertEqual(by_id["q1_first_hit"].message, "correct: sphere 3")
        self.assertEqual(by_id["q1_normal"].message, "correct")  # hidden: no expected value
        check_gradescope(self, gradescope(report))
        check_prairielearn(self, prairielearn(report))

    def test_wrong_answers_score_partially_with_the_right_messages(self) -> None:
        report = self.grade(WRONG / "answers.json", WRONG)
        by_id = {r.question.id: r for r in report.results}
        expect = {  # id: (points, start of the message)
            "q1_first_hit": (0, "incorrect: expected sphere 3, got sphere 1"),
            "q1_t": (0, "incorrect: expected 7.26795 (to 3 significant figures), got 8"),
            "q1_point": (1, "correct: (0, 0, 7.26795)"),
            "q1_hits": (
                1,
                "incorrect: expected (7.26795, 8, 10.7321, 12), got (8, 12) (2 matched)",
            ),
            "q1_normal": (0, "incorrect"),
            "q2_points": (1, "correct: 5"),
            "q2_full_phong": (
                1.2,
                "incorrect: full phong: expected I1, I2, I3, got I1, I2, I4 (3 of 5 points right)",
            ),
            "q2_ambient_only": (
                1.6,
                "incorrect: ambient only: expected I4, I5, got I5 (4 of 5 points right)",
            ),
            "q3_hit": (2, "2 of 3 rays correct. ray 2: expected miss, got hit"),
            "q3_t": (1, "correct"),
            "tracer_t": (
                0.375,
                "1 of 8 rays correct. ray 1: expected 7.26795 (± 0.0728), got 10.7321",
            ),
            "tracer_image": (None, "incorrect: "),
        }
        for qid, (points, message) in expect.items():
            r = by_id[qid]
            if points is not None:
                self.assertAlmostEqual(r.score, points, msg=qid)
            self.assertTrue(r.message.startswith(message), f"{qid}: {r.message!r}")
        hidden = by_id["q1_normal"].message
        self.assertNotIn("0.866", hidden)
        image = by_id["tracer_image"]
        self.assertTrue(0 <= image.score < 3)
        self.assertEqual(
            [label.split()[0] for label, _ in image.images], ["reference", "yours", "difference"]
        )
        self.assertTrue(all(png.startswith(b"\x89PNG") for _, png in image.images))
        self.assertTrue(0 < report.score < MAX_POINTS)
        pl = prairielearn(report)
        check_prairielearn(self, pl)
        self.assertEqual(
            len(next(t for t in pl["tests"] if t["name"] == "tracer_image")["images"]), 3
        )
        with tempfile.TemporaryDirectory() as tmp:
            gs = gradescope(report, pathlib.Path(tmp))
            check_gradescope(self, gs)
            out = next(t["output"] for t in gs["tests"] if t["number"] == "tracer_image")
            self.assertIn("tracer_image-difference.png", out)
            self.assertTrue((pathlib.Path(tmp) / "tracer_image-difference.png").is_file())
        text = text_report(report)
        self.assertIn("[FAIL] q1_first_hit (0/2)", text)
        self.assertIn("[PART] q1_hits (1/2)", text)
        self.assertIn(f"/ {MAX_POINTS:g}", text)

    def test_missing_answers_file_scores_0_and_results_are_written(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            sub = pathlib.Path(tmp) / "submission"
            sub.mkdir()  # no answers.toml, no tracer.py
            gs, pl = (
                pathlib.Path(tmp) / "gs" / "results.json",
                pathlib.Path(tmp) / "pl" / "results.json",
            )
            out, err = io.StringIO(), io.StringIO()
            code = main(
                [
                    "grade",
                    str(QUESTIONS),
                    "--submission",
                    str(sub),
                    "--gradescope",
                    str(gs),
                    "--prairielearn",
                    str(pl),
                    "--server",
                    self.server.url,
                ],
                out,
                err,
            )
            self.assertEqual(code, 0, err.getvalue())
            g = json.loads(gs.read_text())
            check_gradescope(self, g)
            check_prairielearn(self, json.loads(pl.read_text()))
            self.assertEqual(g["score"], 0)
            self.assertIn("the answers file answers.toml is missing", g["output"])
            msgs = {t["number"]: t["output"] for t in g["tests"]}
            self.assertEqual(
                msgs["q1_first_hit"], "no answer: the answers file answers.toml is missing"
            )
            self.assertIn("your program exited with status 2", msgs["tracer_t"])

    def test_a_failing_reference_writes_results_and_exits_1(self) -> None:
        # The server refuses the question's scene (a negative radius): the student scores 0 for
        # that question with the instructor's message, the results file is written, and the
        # exit status and stderr tell the instructor.
        with tempfile.TemporaryDirectory() as tmp:
            root = pathlib.Path(tmp)
            (root / "q.toml").write_text(
                "[[question]]\nid = 'broken'\npoints = 1\nask = 't'\n"
                "ray = { origin = [0, 0, 0], direction = [0, 0, 1] }\n"
                "scene = { objects = [{ type = 'sphere', center = [0, 0, 5], radius = -1 }] }\n"
                "[[question]]\nid = 'fine'\npoints = 1\nask = 't'\n"
                "ray = { origin = [0, 0, 0], direction = [0, 0, 1] }\n"
                "scene = { objects = [{ type = 'sphere', center = [0, 0, 5], radius = 1 }] }\n"
            )
            (root / "answers.toml").write_text("broken = 4.0\nfine = 4.0\n")
            gs = root / "results.json"
            err = io.StringIO()
            code = main(
                [
                    "grade",
                    str(root / "q.toml"),
                    "--answers",
                    str(root / "answers.toml"),
                    "--gradescope",
                    str(gs),
                    "--server",
                    self.server.url,
                ],
                io.StringIO(),
                err,
            )
            self.assertEqual(code, 1, err.getvalue())
            self.assertIn("question broken could not be graded", err.getvalue())
            self.assertIn("invalid_scene", err.getvalue())
            g = json.loads(gs.read_text())
            check_gradescope(self, g)
            msgs = {t["number"]: (t["score"], t["output"]) for t in g["tests"]}
            self.assertEqual(msgs["fine"][0], 1)
            self.assertEqual(msgs["broken"][0], 0)
            self.assertIn("the reference could not be computed (instructor:", msgs["broken"][1])

    def test_malformed_answers_and_values(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            bad = pathlib.Path(tmp) / "answers.toml"
            bad.write_text('q1_first_hit = "sphere 3\n')  # unterminated string
            a = load_answers(bad)
            self.assertIn("malformed", a.problem)
            report = self.grader.grade(a, None)
            self.assertEqual(report.score, 0)
            self.assertTrue(
                all(
                    r.message.startswith(("no answer", "your program exited"))
                    for r in report.results
                )
            )
        odd = Answers(
            {
                "q1_t": "seven",
                "q1_hits": [8, "x"],
                "q3_hit": True,
                "q2_full_phong": ["I1", "banana"],
            }
        )
        by_id = {r.question.id: r for r in self.grader.grade(odd, None).results}
        self.assertIn("could not read your answer: 'seven' is not a number", by_id["q1_t"].message)
        self.assertIn("could not read your answer", by_id["q1_hits"].message)
        self.assertIn("needs a list of 3 answers", by_id["q3_hit"].message)
        self.assertIn("not a ray-tree point", by_id["q2_full_phong"].message)
        self.assertIn("no answer for q1_point", by_id["q1_point"].message)

    def test_lenient_answers(self) -> None:
        ok = Answers(
            {
                "q1_first_hit": 3,
                "q2_full_phong": "I_1, i2, 3",
                "q2_ambient_only": [4, 5],
                "q3_hit": ["yes", "no", 1],
                "q1_hits": "7.27 8 10.73 12",
            }
        )
        by_id = {r.question.id: r for r in self.grader.grade(ok, None).results}
        for qid in ("q1_first_hit", "q2_full_phong", "q2_ambient_only", "q3_hit"):
            self.assertTrue(by_id[qid].passed, f"{qid}: {by_id[qid].message}")

    def test_per_question_timeout_holds(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            sub = pathlib.Path(tmp)
            (sub / "tracer.py").write_text("import time\ntime.sleep(30)\n")
            qset = parse_questions(
                {
                    "question": [
                        {
                            "id": "slow",
                            "scene": dict(TUTORIAL),
                            "ask": "t",
                            "timeout_s": 1,
                            "rays": [[0, 0, 0, 0, 0, 1]],
                            "program": ["{python}", "{submission}/tracer.py"],
                        },
                        {
                            "id": "fast",
                            "scene": dict(TUTORIAL),
                            "ask": "first_hit",
                            "index_base": 1,
                            "ray": {"origin": [0, 0, 0], "direction": [0, 0, 1]},
                        },
                    ]
                },
                sub,
            )
            report = Grader(qset, self.server.url).grade(Answers({"fast": 3}), sub)
        slow, fast = report.results
        self.assertEqual(slow.message, "your program did not finish within 1 s")
        self.assertLess(slow.seconds, 10)
        self.assertTrue(fast.passed)

    def test_local_server_started_when_none_is_given(self) -> None:
        env_binary = os.environ.get("RAYCASTD_BINARY") or str(self.server.binary)
        out, err = io.StringIO(), io.StringIO()
        env = {k: v for k, v in os.environ.items() if k != "RAYCASTD_URL"}
        with mock.patch.dict(os.environ, env, clear=True):
            code = main(
                [
                    "grade",
                    str(QUESTIONS),
                    "--answers",
                    str(CORRECT / "answers.toml"),
                    "--submission",
                    str(CORRECT),
                    "--server-binary",
                    env_binary,
                    "--json",
                ],
                out,
                err,
            )
        self.assertEqual(code, 0, err.getvalue())
        self.assertEqual(json.loads(out.getvalue())["score"], MAX_POINTS)


class GradingScriptsTest(ServerTestCase):
    """run_autograder and the PrairieLearn run.sh in the folder layouts those platforms use."""

    def test_gradescope_autograder_zip_and_run_autograder(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            root = pathlib.Path(tmp)
            env = {
                **os.environ,
                "AUTOGRADER_ROOT": str(root),
                "RAYCASTD_SERVER": str(self.server.binary),
            }
            env.pop("RAYCASTD_URL", None)
            made = subprocess.run(
                [
                    str(GRADING / "gradescope" / "make_autograder.sh"),
                    str(TUTORIAL7),
                    str(root / "ag.zip"),
                ],
                env=env,
                capture_output=True,
                text=True,
                timeout=120,
            )
            self.assertEqual(made.returncode, 0, made.stderr)
            with zipfile.ZipFile(root / "ag.zip") as z:  # as Gradescope unpacks it, modes kept
                names = set(z.namelist())
                for info in z.infolist():
                    z.extract(info, root / "source")
                    mode = info.external_attr >> 16
                    if mode and not info.is_dir():
                        os.chmod(root / "source" / info.filename, mode & 0o777)
            self.assertLessEqual(
                {
                    "setup.sh",
                    "run_autograder",
                    "bin/raycastd",
                    "python/raycastd/cli.py",
                    "questions/questions.toml",
                },
                names,
            )
            self.assertFalse(any(n.startswith("questions/submissions") for n in names))
            shutil.copytree(WRONG, root / "submission")
            (root / "submission" / "answers.json").rename(
                root / "submission" / "answers.toml"
            )  # JSON is read too
            env.pop("RAYCASTD_SERVER")  # the zip's bin/raycastd is used
            run = subprocess.run(
                [str(root / "source" / "run_autograder")],
                env=env,
                capture_output=True,
                text=True,
                timeout=120,
            )
            self.assertEqual(run.returncode, 0, run.stderr)
            doc = json.loads((root / "results" / "results.json").read_text())
            self.assertTrue((root / "results" / "tracer_image-difference.png").is_file())
        check_gradescope(self, doc)
        self.assertTrue(0 < doc["score"] < MAX_POINTS)
        self.assertIn("total:", run.stdout)

    def test_prairielearn_run_sh(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            root = pathlib.Path(tmp)
            kit = root / "serverFilesCourse" / "raycastd"
            kit.mkdir(parents=True)
            (kit / "python").symlink_to(PACKAGE_ROOT)
            (root / "tests").symlink_to(TUTORIAL7)
            shutil.copytree(CORRECT, root / "student")
            env = {
                **os.environ,
                "GRADE_ROOT": str(root),
                "RAYCASTD_SERVER": str(self.server.binary),
            }
            env.pop("RAYCASTD_URL", None)
            run = subprocess.run(
                [str(GRADING / "prairielearn" / "run.sh")],
                env=env,
                capture_output=True,
                text=True,
                timeout=120,
            )
            self.assertEqual(run.returncode, 0, run.stderr)
            doc = json.loads((root / "results" / "results.json").read_text())
        check_prairielearn(self, doc)
        self.assertEqual(doc["score"], 1.0)


class ToleranceTest(unittest.TestCase):
    def test_relabs_sigfigs_decimals(self) -> None:
        ra = Tolerance()
        self.assertTrue(ra.accepts(7.27, 7.267949192431123))
        self.assertFalse(ra.accepts(7.4, 7.267949192431123))
        self.assertTrue(Tolerance.parse({"sigfigs": 3}).accepts(7.27, 7.2679))
        self.assertFalse(Tolerance.parse({"sigfigs": 4}).accepts(7.27, 7.2679))
        self.assertTrue(Tolerance.parse({"decimals": 2}).accepts(10.73, 10.732))
        self.assertFalse(Tolerance.parse({"decimals": 2}).accepts(10.72, 10.732))
        self.assertTrue(Tolerance.parse({"rtol": 0, "atol": 0.5}).accepts(1.4, 1.0))
        self.assertFalse(ra.accepts(float("inf"), 1.0))
        self.assertTrue(ra.accepts(float("inf"), float("inf")))
        with self.assertRaises(ValueError):
            Tolerance.parse({"sigfig": 3})

    def test_default_atol_is_float32_aware_and_scales_with_the_scene(self) -> None:
        ra = Tolerance()
        # A float32 tracer's x of a point on the axis, in a scene of size 10 and of size 1e4.
        self.assertTrue(ra.accepts(-2e-6, 0.0, scale=10))
        self.assertFalse(ra.accepts(-2e-6, 0.0, scale=0.01))
        self.assertTrue(ra.accepts(3e-3, 0.0, scale=1e4))
        self.assertFalse(ra.accepts(3e-3, 0.0, scale=10))
        # An atol written by the instructor is used as written.
        self.assertFalse(Tolerance.parse({"atol": 1e-9}).accepts(-2e-6, 0.0, scale=1e4))


class QuestionFileTest(unittest.TestCase):
    def test_mistakes_name_the_question_and_key(self) -> None:
        cases = [
            (
                {"question": [{"id": "a", "scene": dict(TUTORIAL), "ask": "colour"}]},
                "ask must be one of",
            ),
            (
                {"question": [{"id": "a", "scene": dict(TUTORIAL), "ask": "t"}]},
                "exactly one of ray and rays",
            ),
            (
                {
                    "question": [
                        {
                            "id": "a",
                            "scene": dict(TUTORIAL),
                            "ask": "t",
                            "ray": [0, 0, 0, 0, 0, 1],
                            "pionts": 2,
                        }
                    ]
                },
                "unknown keys pionts",
            ),
            (
                {
                    "question": [
                        {"id": "a", "scene": "nope.json", "ask": "t", "ray": [0, 0, 0, 0, 0, 1]}
                    ]
                },
                "cannot read scene file nope.json",
            ),
            (
                {"question": [{"id": "a", "scene": dict(TUTORIAL), "ask": "image"}]},
                "needs answer_file",
            ),
            ({"question": []}, "no [[question]] tables"),
        ]
        for data, message in cases:
            with self.assertRaises(QuestionFileError) as cm:
                parse_questions(data, pathlib.Path("."))
            self.assertIn(message, str(cm.exception))

    def test_grade_reports_a_broken_question_file(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            q = pathlib.Path(tmp) / "q.toml"
            q.write_text("[[question]]\nid = 'x'\nask = 't'\n")
            err = io.StringIO()
            self.assertEqual(
                main(["grade", str(q), "--server", "http://127.0.0.1:9"], io.StringIO(), err), 1
            )
            self.assertIn("scene is required", err.getvalue())


if __name__ == "__main__":
    unittest.main()


class FindServerTest(unittest.TestCase):
    def test_a_script_named_raycastd_on_path_is_never_the_server(self) -> None:
        from raycastd.server import ServerNotFound, find_server

        with tempfile.TemporaryDirectory() as tmp:
            script = pathlib.Path(tmp) / "raycastd"
            script.write_text('#!/bin/sh\nexec python3 -m raycastd "$@"\n')
            script.chmod(0o755)
            env = {"PATH": tmp}
            with mock.patch.dict(os.environ, env, clear=True):
                try:
                    found = find_server()
                except ServerNotFound as exc:
                    self.assertIn("a script, not the server", str(exc))
                else:
                    self.assertNotEqual(found, script)
            binary = os.environ.get("RAYCASTD_BINARY")
            if binary:
                with mock.patch.dict(
                    os.environ, {"PATH": tmp, "RAYCASTD_SERVER": binary}, clear=True
                ):
                    self.assertEqual(str(find_server()), binary)
