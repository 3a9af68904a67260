"""`raycastd grade`: grade a submission and write Gradescope / PrairieLearn / text results."""

from __future__ import annotations

import argparse
import os
import pathlib
from typing import Any

from raycastd.grading import results
from raycastd.grading.grader import Report, grade_files
from raycastd.grading.questions import QuestionFileError, load_questions
from raycastd.server import LocalServer


def add_grade_parser(sub: Any, common: argparse.ArgumentParser) -> None:
    g = sub.add_parser(
        "grade",
        parents=[common],
        help="grade a submission against a question file",
        description=(
            "Grade a student's answers (a TOML/JSON file of id = value) and/or the output of "
            "their program against a question file. With no --server (and no $RAYCASTD_URL) a "
            "local raycastd server is started on a free loopback port and stopped afterwards."
        ),
    )
    g.add_argument("questions", type=pathlib.Path, metavar="QUESTIONS.toml")
    g.add_argument("--answers", type=pathlib.Path, metavar="FILE", help="the student's answers")
    g.add_argument(
        "--submission",
        type=pathlib.Path,
        metavar="DIR",
        help="the submission folder (answers.toml/.json, program, output files)",
    )
    g.add_argument(
        "--gradescope", type=pathlib.Path, metavar="FILE", help="write Gradescope results.json"
    )
    g.add_argument(
        "--prairielearn", type=pathlib.Path, metavar="FILE", help="write PrairieLearn results.json"
    )
    g.add_argument(
        "--report", type=pathlib.Path, metavar="FILE", help="write the text report (- for stdout)"
    )
    g.add_argument(
        "--server-binary",
        metavar="PATH",
        help=(
            "the raycastd server to start (default: $RAYCASTD_SERVER, $RAYCASTD_BINARY, PATH, "
            "the build tree); a binary named here or in those variables must exist"
        ),
    )


def run_grade(args: argparse.Namespace, io: Any) -> int:
    """Loads the questions, grades, writes every output asked for; returns the exit status."""
    try:
        qset = load_questions(args.questions)
    except QuestionFileError as exc:
        io.message(f"raycastd grade: {exc}")
        return 1
    url = getattr(args, "server", None) or os.environ.get("RAYCASTD_URL")
    if url:
        report = grade_files(qset, url, args.answers, args.submission)
    else:
        try:
            binary = named_server_binary(args.server_binary)
        except ValueError as exc:
            io.message(f"raycastd grade: {exc}")
            return 1
        scene_root = str(args.questions.resolve().parent)
        with LocalServer(binary, ["--scene-root", scene_root, "--threads", "8"]) as server:
            report = grade_files(qset, server.url, args.answers, args.submission)
    write_outputs(report, args, io)
    # A question that could not be graded (its reference failed, its `expected` or program line
    # is wrong) is the instructor's problem, and must not pass unnoticed as a student's 0: the
    # results stay written, the exit status says it (1, as for an API error).
    broken = [r for r in report.results if r.instructor_error]
    for r in broken:
        io.message(
            f"raycastd grade: question {r.question.id} could not be graded: {r.instructor_error}"
        )
    return 1 if broken else 0


def named_server_binary(argument: str | None) -> str | None:
    """The server binary named explicitly (--server-binary, else $RAYCASTD_SERVER, else
    $RAYCASTD_BINARY: the first one given), checked; None when none is named, for
    `find_server`'s search. A named binary that does not exist or cannot run is an error naming
    it, never skipped for another one found elsewhere."""
    for where, value in (
        ("--server-binary", argument),
        ("$RAYCASTD_SERVER", os.environ.get("RAYCASTD_SERVER")),
        ("$RAYCASTD_BINARY", os.environ.get("RAYCASTD_BINARY")),
    ):
        if not value:
            continue
        path = pathlib.Path(value)
        if not path.exists():
            raise ValueError(f"the server binary {value} ({where}) does not exist")
        if not path.is_file() or not os.access(path, os.X_OK):
            raise ValueError(f"the server binary {value} ({where}) is not an executable file")
        try:
            with path.open("rb") as f:
                script = f.read(2) == b"#!"
        except OSError as exc:
            raise ValueError(f"the server binary {value} ({where}) cannot be read: {exc}") from None
        if script:
            raise ValueError(
                f"the server binary {value} ({where}) is a script, not the raycastd server"
            )
        return value
    return None


def write_outputs(report: Report, args: argparse.Namespace, io: Any) -> None:
    if args.gradescope:
        results.write_json(args.gradescope, results.gradescope(report, args.gradescope.parent))
        io.message(f"wrote {args.gradescope}")
    if args.prairielearn:
        results.write_json(args.prairielearn, results.prairielearn(report))
        io.message(f"wrote {args.prairielearn}")
    text = results.text_report(report)
    if args.report and str(args.report) != "-":
        args.report.parent.mkdir(parents=True, exist_ok=True)
        args.report.write_text(text)
        io.message(f"wrote {args.report}")
    if io.json_mode:
        io.result(
            {
                "score": report.score,
                "max_score": report.max_score,
                "notes": report.notes,
                "questions": [
                    {
                        "id": r.question.id,
                        "score": r.score,
                        "max_score": r.question.points,
                        "message": r.message,
                    }
                    for r in report.results
                ],
            }
        )
    elif str(args.report) == "-" or not (args.gradescope or args.prairielearn or args.report):
        io.out.write(text)
    else:
        io.message(f"score: {report.score:g} / {report.max_score:g}")
