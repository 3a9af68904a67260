"""The three outputs of a grading run: Gradescope's and PrairieLearn's `results.json`, and a
text report for people.

Gradescope (autograder specification): top-level `score` (points), `execution_time`, `output`,
`visibility`, `stdout_visibility`, and `tests`, each with `name`, `number`, `score`,
`max_score`, `status` (`passed`/`failed`), `output` and `visibility`. Images cannot be embedded
there, so each is written as a PNG beside the results file and named in the test's output.

PrairieLearn (external grading, `/grade/results/results.json`): `gradable`, `score` in [0, 1],
`message`, `output`, `images` (`{label, url: data:image/png;base64,…}`) and `tests`, each with
`name`, `description`, `points`, `max_points`, `message`, `output` and `images`.
"""

from __future__ import annotations

import base64
import json
import pathlib
from typing import Any

from raycastd.grading.grader import Report

GRADESCOPE_VISIBILITY = "visible"
PRAIRIELEARN_MAX_BYTES = 900_000


def gradescope(report: Report, images_dir: pathlib.Path | None = None) -> dict[str, Any]:
    """The Gradescope results document; images go to `images_dir` when it is given."""
    tests = []
    for r in report.results:
        output = r.message
        if images_dir is not None:
            for label, png in r.images:
                name = f"{_safe(r.question.id)}-{_safe(label.split(' ')[0])}.png"
                images_dir.mkdir(parents=True, exist_ok=True)
                (images_dir / name).write_bytes(png)
                output += f"\n{label}: {name}"
        tests.append(
            {
                "name": r.question.title,
                "number": r.question.id,
                "score": r.score,
                "max_score": r.question.points,
                "status": "passed" if r.passed else "failed",
                "output": output,
                "visibility": GRADESCOPE_VISIBILITY,
            }
        )
    return {
        "score": report.score,
        "execution_time": round(report.seconds, 3),
        "output": _summary(report),
        "visibility": GRADESCOPE_VISIBILITY,
        "stdout_visibility": "hidden",
        "tests": tests,
    }


def prairielearn(report: Report) -> dict[str, Any]:
    """The PrairieLearn external-grader results document."""
    tests = []
    for r in report.results:
        test: dict[str, Any] = {
            "name": r.question.id,
            "description": r.question.prompt,
            "points": r.score,
            "max_points": r.question.points,
            "message": r.message,
            "output": "",
        }
        if r.images:
            test["images"] = [{"label": label, "url": data_url(png)} for label, png in r.images]
        tests.append(test)
    doc: dict[str, Any] = {
        "gradable": True,
        "score": round(report.score / report.max_score, 6) if report.max_score else 0.0,
        "message": _summary(report),
        "output": text_report(report),
        "images": [],
        "tests": tests,
    }
    if len(json.dumps(doc)) > PRAIRIELEARN_MAX_BYTES:  # PrairieLearn refuses results over 1 MB
        for test in tests:
            test.pop("images", None)
        doc["message"] += "; images left out (results over 1 MB)"
    return doc


def text_report(report: Report) -> str:
    """One line a question, then the total."""
    lines = [report.title] if report.title else []
    lines += [f"note: {n}" for n in report.notes]
    for r in report.results:
        mark = "PASS" if r.passed else ("PART" if r.credit > 0 else "FAIL")
        lines.append(
            f"[{mark}] {r.question.id} ({_pts(r.score)}/{_pts(r.question.points)}): {r.message}"
        )
        lines += [f"       image: {label}" for label, _ in r.images]
    lines.append(f"total: {_pts(report.score)} / {_pts(report.max_score)}")
    return "\n".join(lines) + "\n"


def data_url(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode()


def write_json(path: pathlib.Path, doc: dict[str, Any]) -> None:
    """Writes a results document (its folder created), replacing the file atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(doc, indent=2) + "\n")
    tmp.replace(path)


def _summary(report: Report) -> str:
    head = f"{_pts(report.score)} / {_pts(report.max_score)} points"
    return "; ".join([head] + report.notes)


def _pts(v: float) -> str:
    return f"{v:.4g}"


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in text)
