"""Grading a submission against a question file.

For each question: read the student's answer (from the answers file, or from a file their
program wrote), compute the reference with raycastd (or take the instructor's `expected`),
compare item by item (ray by ray, point by point, tree point by tree point), and produce a
`QuestionResult` with credit and feedback. Each question runs under its own time limit
(`timeout_s`): a slow server, a student program that hangs, or a huge answer costs that question
only. Nothing the student supplies can stop the run: a missing or malformed file scores the
questions that need it 0 with a message saying why, and the results are written all the same.
"""

from __future__ import annotations

import json
import math
import pathlib
import subprocess
import sys
import tempfile
import threading
import time

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: python3-tomli (Debian, Ubuntu) is the same parser
    import tomli as tomllib  # type: ignore[no-redef]
from dataclasses import dataclass, field
from typing import Any

from raycastd.client import Client
from raycastd.errors import RaycastdError
from raycastd.grading import compare as cmp
from raycastd.grading.images import compare_images
from raycastd.grading.questions import POINT_ASKS, TREE_ASKS, Question, QuestionSet, has_mesh
from raycastd.png import PngError, read_png, write_png
from raycastd.tables import TableError, read_table

MISSING = object()  # no answer given for a question
GRACE_S = 1.0


@dataclass
class QuestionResult:
    """The outcome of one question."""

    question: Question
    credit: float  # in [0, 1]
    message: str  # what the student sees
    images: list[tuple[str, bytes]] = field(default_factory=list)  # (label, PNG bytes)
    seconds: float = 0.0
    # The question could not be graded for a reason of the instructor's, not the student's (its
    # reference failed): `grade` still writes every result, then exits 1 naming it.
    instructor_error: str | None = None

    @property
    def score(self) -> float:
        return round(self.credit * self.question.points, 6)

    @property
    def passed(self) -> bool:
        return self.credit >= 1.0


@dataclass
class Report:
    """Every question's result, in question order, and notes about the run."""

    title: str
    results: list[QuestionResult]
    notes: list[str]
    seconds: float

    @property
    def score(self) -> float:
        return round(sum(r.score for r in self.results), 6)

    @property
    def max_score(self) -> float:
        return sum(r.question.points for r in self.results)


@dataclass
class Answers:
    """The student's answers file: values by question id, or why it could not be read."""

    values: dict[str, Any]
    problem: str | None = None  # set when the file is missing or malformed
    source: str = ""


def load_answers(path: pathlib.Path | None) -> Answers:
    """Reads `id = value` answers from TOML or JSON; never raises."""
    if path is None:
        return Answers({}, "no answers file was given", "")
    name = path.name
    try:
        text = path.read_text()
    except FileNotFoundError:
        return Answers({}, f"the answers file {name} is missing", name)
    except (OSError, UnicodeDecodeError) as exc:
        return Answers({}, f"the answers file {name} could not be read ({exc})", name)
    errors = []
    for kind in ("json", "toml") if path.suffix.lower() == ".json" else ("toml", "json"):
        try:
            data = json.loads(text) if kind == "json" else tomllib.loads(text)
        except (ValueError, tomllib.TOMLDecodeError) as exc:
            errors.append(f"{kind}: {exc}")
            continue
        if not isinstance(data, dict):
            return Answers({}, f"the answers file {name} is not a table of id = value", name)
        return Answers({str(k): v for k, v in data.items()}, None, name)
    return Answers({}, f"the answers file {name} is malformed ({errors[0]})", name)


class Grader:
    """Grades submissions against one question set with one raycastd server at `url`."""

    def __init__(self, qset: QuestionSet, url: str) -> None:
        self.qset = qset
        self.url = url

    def grade(self, answers: Answers, submission: pathlib.Path | None = None) -> Report:
        start = time.monotonic()
        notes = [answers.problem] if answers.problem and self._needs_answers() else []
        results = []
        with tempfile.TemporaryDirectory(prefix="raycastd-grade-") as tmp:
            for q in self.qset.questions:
                work = pathlib.Path(tmp) / _safe(q.id)
                work.mkdir()
                results.append(self._grade_one(q, answers, submission, work))
        return Report(self.qset.title, results, notes, time.monotonic() - start)

    def _needs_answers(self) -> bool:
        return any(not q.answer_file for q in self.qset.questions)

    def _grade_one(
        self, q: Question, answers: Answers, submission: pathlib.Path | None, work: pathlib.Path
    ) -> QuestionResult:
        t0 = time.monotonic()
        box: list[QuestionResult] = []
        failure: list[BaseException] = []

        def run() -> None:
            try:
                box.append(self._evaluate(q, answers, submission, work))
            except BaseException as exc:  # reported below; never ends the run
                failure.append(exc)

        thread = threading.Thread(target=run, name=f"grade-{q.id}", daemon=True)
        thread.start()
        # A grace second past the limit, so that a student program stopped at timeout_s is
        # reported as such; the question as a whole never runs longer than this.
        thread.join(q.timeout_s + GRACE_S)
        if box:
            result = box[0]
        elif thread.is_alive():
            result = QuestionResult(
                q, 0.0, f"grading stopped: took longer than {q.timeout_s + GRACE_S:g} s"
            )
        else:
            # Not the student's doing (their answers and programs are read defensively): a
            # question the kit cannot grade is the instructor's to see, as a failed reference is.
            exc = failure[0] if failure else RuntimeError("no result")
            why = f"{type(exc).__name__}: {exc}"
            result = QuestionResult(
                q, 0.0, f"could not be graded (instructor: {why})", instructor_error=why
            )
        result.seconds = time.monotonic() - t0
        return result

    # -- one question ------------------------------------------------------------------------

    def _evaluate(
        self, q: Question, answers: Answers, submission: pathlib.Path | None, work: pathlib.Path
    ) -> QuestionResult:
        with Client(self.url, timeout=max(1.0, q.timeout_s)) as client:
            try:
                # An image question's camera is settled first: the student's program is given
                # the very camera the reference is rendered with.
                camera = self._image_camera(q, client) if q.ask == "image" else None
            except RaycastdError as exc:
                return _reference_failed(q, exc)
            try:
                value = self._answer(q, answers, submission, work, client, camera)
            except QuestionProblem as p:
                return QuestionResult(q, 0.0, str(p), instructor_error=str(p))
            except StudentProblem as p:
                return QuestionResult(q, 0.0, str(p))
            try:
                if q.ask == "image":
                    return self._image(q, value, client, camera or {})
                refs, scale = self._reference(q, client)
            except RaycastdError as exc:
                return _reference_failed(q, exc)
            return self._compare(q, refs, value, scale)

    def _answer(
        self,
        q: Question,
        answers: Answers,
        submission: pathlib.Path | None,
        work: pathlib.Path,
        client: Client,
        camera: dict | None = None,
    ) -> Any:
        if q.program:
            self._run_program(q, submission, work, client, camera)
            return _read_output(q, work / q.answer_file)  # type: ignore[operator]
        if q.answer_file:
            if submission is None:
                raise StudentProblem(f"no submission folder: {q.answer_file} cannot be read")
            return _read_output(q, submission / q.answer_file)
        if answers.problem:
            raise StudentProblem(f"no answer: {answers.problem}")
        value = answers.values.get(q.id, MISSING)
        if value is MISSING:
            raise StudentProblem(f"no answer for {q.id} in {answers.source}")
        if q.many and not isinstance(value, list):
            raise StudentProblem(
                f"{q.id} needs a list of {len(q.rays or q.query_points)} answers, one per item"
            )
        return value

    def _run_program(
        self,
        q: Question,
        submission: pathlib.Path | None,
        work: pathlib.Path,
        client: Client,
        camera: dict | None = None,
    ) -> None:
        """Writes the question's inputs to `work` and runs the student's program on them."""
        (work / "scene.json").write_text(json.dumps(q.scene, indent=1))
        if q.rays:
            (work / "rays.csv").write_text(
                "".join(
                    ",".join(repr(x) for x in r["origin"] + r["direction"]) + "\n" for r in q.rays
                )
            )
        if q.query_points:
            (work / "points.csv").write_text(
                "".join(",".join(map(repr, p)) + "\n" for p in q.query_points)
            )
        img = q.image
        if camera is None:  # not an image question: the scene's own camera, if it has one
            camera = q.scene.get("camera")
        (work / "camera.json").write_text(json.dumps(camera or {}))
        fields = {
            "submission": str(submission or work),
            "scene": str(work / "scene.json"),
            "rays": str(work / "rays.csv"),
            "points": str(work / "points.csv"),
            "camera": str(work / "camera.json"),
            "output": str(work / q.answer_file),  # type: ignore[operator]
            "width": str(img.width if img else 0),
            "height": str(img.height if img else 0),
            "question": q.id,
            "python": sys.executable,
        }
        try:
            cmd = [part.format(**fields) for part in q.program or []]
        except (KeyError, IndexError, ValueError) as exc:
            raise QuestionProblem(
                f"the question's program line is wrong (instructor): {exc}"
            ) from None
        try:
            done = subprocess.run(
                cmd,
                cwd=str(submission or work),
                stdin=subprocess.DEVNULL,
                capture_output=True,
                timeout=q.timeout_s,
                text=True,
                errors="replace",
            )
        except subprocess.TimeoutExpired:
            raise StudentProblem(f"your program did not finish within {q.timeout_s:g} s") from None
        except OSError as exc:
            raise StudentProblem(f"your program could not be started: {exc}") from None
        if done.returncode != 0:
            tail = "\n".join(done.stderr.strip().splitlines()[-5:])
            raise StudentProblem(
                f"your program exited with status {done.returncode}"
                + (f":\n{tail}" if tail else "")
            )

    def _reference(self, q: Question, client: Client) -> tuple[list[Any], list[float]]:
        """One reference per item, and the scale of each for the default tolerance."""
        extent = _extent(q, client)
        if q.ask in POINT_ASKS:
            scales = [extent] * len(q.query_points)
        else:
            scales = [extent / max(_norm(r["direction"]), 1e-300) for r in q.rays]
        if q.expected is not None:
            refs = q.expected if q.many else [q.expected]
            if len(refs) != len(scales):
                raise RaycastdError(
                    f"expected has {len(refs)} values for {len(scales)} items", code="bad_question"
                )
            return list(refs), scales
        sid = client.scene_id(q.scene)
        if q.ask in TREE_ASKS:
            trees = [
                client.trace(sid, r, max_depth=q.max_depth, precision=q.precision) for r in q.rays
            ]
            return trees, scales
        if q.ask == "closest_point":
            res = client.points(sid, q.query_points, query="closest")["results"]
            return [r["point"] if r.get("found") else None for r in res], scales
        if q.ask == "inside":
            res = client.points(sid, q.query_points, query="occupancy")["results"]
            return [bool(r["inside"]) for r in res], scales
        if q.ask == "hits" or (q.ask == "triangle_hit" and q.object is not None):
            ans = client.intersect(sid, q.rays, mode="all", precision=q.precision)
            if q.ask == "hits":
                return [[h["t"] for h in a["hits"]] for a in ans["hits"]], scales
            return [any(_is_object(h, q.object) for h in a["hits"]) for a in ans["hits"]], scales
        if q.ask == "triangle_hit":
            ans = client.intersect(sid, q.rays, mode="any", precision=q.precision)
            return [bool(a["hit"]) for a in ans["hits"]], scales
        ans = client.intersect(sid, q.rays, mode="closest", precision=q.precision)
        out: list[Any] = []
        for h in ans["hits"]:
            if not h.get("hit"):
                out.append(None if q.ask != "t" else math.inf)
            elif q.ask == "first_hit":
                out.append((h["object"], h["name"]))
            elif q.ask == "t":
                out.append(h["t"])
            elif q.ask == "hit_point":
                out.append(h["point"])
            else:
                out.append(h["normal"])
        return out, scales

    def _compare(
        self, q: Question, refs: list[Any], value: Any, scales: list[float]
    ) -> QuestionResult:
        values = value if q.many else [value]
        if len(values) != len(refs):
            return QuestionResult(
                q, 0.0, f"{len(values)} answers given for {len(refs)} {_items(q)}"
            )
        checks: list[cmp.Check] = []
        for i, (ref, val, scale) in enumerate(zip(refs, values, scales)):
            try:
                checks.append(self._check(q, ref, val, scale))
            except cmp.AnswerError as exc:
                checks.append(cmp.Check(0.0, f"could not read your answer: {exc}"))
        credit = sum(c.credit for c in checks) / len(checks)
        return QuestionResult(q, credit, _message(q, checks))

    def _check(self, q: Question, ref: Any, val: Any, scale: float) -> cmp.Check:
        tol = q.tolerance
        if q.ask == "first_hit":
            # (0-based index, name) or None: the server's, or `expected` as load_questions
            # resolved it against the scene, so a name and an index are both compared
            if ref is not None:
                ref = (int(ref[0]), str(ref[1]))
            return cmp.check_first_hit(ref, val, q)
        if q.ask == "t":
            return cmp.check_scalar(math.inf if ref is None else float(ref), val, tol, scale)
        if q.ask in ("hit_point", "closest_point"):
            return cmp.check_vector(ref, val, tol, scale)
        if q.ask == "normal":
            return cmp.check_vector(ref, val, tol, 1.0, either_sign=q.normal_sign == "either")
        if q.ask == "hits":
            return cmp.check_hits(ref, val, tol, scale)
        if q.ask == "triangle_hit":
            return cmp.check_bool(bool(ref), val, "hit", "miss")
        if q.ask == "inside":
            return cmp.check_bool(bool(ref), val, "inside", "outside")
        summary = ref.get("summary", {}) if isinstance(ref, dict) else {}
        if q.ask == "ray_tree_points":
            return cmp.check_int(int(summary.get("points", ref) if summary else ref), val)
        everything = list(summary.get("full_phong", [])) + list(summary.get("ambient_only", []))
        everything.sort(key=lambda s: int(s[1:]) if s[1:].isdigit() else 0)
        wanted = set(summary.get(q.ask, []))
        return cmp.check_tree_set(wanted, everything, val, q.ask.replace("_", " "))

    def _image_camera(self, q: Question, client: Client) -> dict:
        """The camera of an image question, all four fields: the question's, else the scene's
        own (its document's or its glTF file's, as the scene summary reports it), else the one
        raycastd frames the scene with (`default_camera`, from the summary's bounds and
        default_view). The reference is rendered with it, and the program gets it."""
        spec = q.image
        assert spec is not None
        if spec.camera:
            return _full_camera(spec.camera)
        summary = client.get_scene(client.scene_id(q.scene))
        own = summary.get("camera") or q.scene.get("camera")
        if isinstance(own, dict) and own:
            return _full_camera(own)
        view = summary.get("default_view")
        if view not in ("+z", "-z"):  # a server older than default_view: the same rule
            view = "+z" if has_mesh(q.scene) else "-z"
        aspect = spec.width / spec.height if spec.height else 0.0
        return default_camera(summary.get("bounds"), aspect, view)

    def _image(self, q: Question, value: Any, client: Client, camera: dict) -> QuestionResult:
        spec = q.image
        assert spec is not None
        opts: dict[str, Any] = {"shading": spec.shading}
        if camera:
            opts["camera"] = camera
        if spec.max_depth:
            opts["max_depth"] = spec.max_depth
        png = client.render(client.scene_id(q.scene), spec.width, spec.height, spec.spp, **opts)
        ref = read_png(png)
        check = compare_images(ref, value, spec)
        images: list[tuple[str, bytes]] = []
        if q.visible and check.diff is not None and check.credit < 1.0:
            images = [
                ("reference", write_png(ref)),
                ("yours", write_png(value)),
                ("difference (red: differs)", write_png(check.diff)),
            ]
        if check.credit >= 1.0:
            msg = "correct: " + check.detail if q.visible else "correct"
        else:
            msg = ("incorrect: " + check.detail) if q.visible else "incorrect"
        return QuestionResult(q, check.credit, msg, images)


class StudentProblem(Exception):
    """The student's answer is missing or unreadable; the message is shown as feedback."""


class QuestionProblem(StudentProblem):
    """The question cannot be graded for a reason of the instructor's (`grade` exits 1)."""


def _reference_failed(q: Question, exc: RaycastdError) -> QuestionResult:
    return QuestionResult(
        q,
        0.0,
        f"the reference could not be computed (instructor: {exc})",
        instructor_error=f"its reference failed ({exc})",
    )


#: raycastd's camera fields and their defaults (engine/scene/camera.h).
CAMERA_DEFAULTS = {
    "position": [0.0, 0.0, 0.0],
    "look_at": [0.0, 0.0, 1.0],
    "up": [0.0, 1.0, 0.0],
    "fov_y_deg": 45.0,
}


def _full_camera(camera: dict) -> dict:
    """A camera with every field, those not written taking raycastd's defaults."""
    return {k: camera.get(k, v) for k, v in CAMERA_DEFAULTS.items()}


DEFAULT_CAMERA_FLAT = 1e-6


def default_camera(bounds: dict | None, aspect: float, view: str) -> dict:
    """The camera raycastd renders a scene with when neither the request nor the scene has one
    (engine/scene/scene.cpp `default_camera`, docs/rendering.md "Camera"): it looks at the centre
    of the bounds, fov_y 45° and +y up, from the distance at which their bounding sphere (half
    the diagonal) just fills the narrower field of view, on the side `view` ("+z"/"-z") names;
    bounds flat in y (or x) from 45° above (or beside) on that side."""
    cam = _full_camera({})
    if not bounds or not bounds.get("min") or not bounds.get("max"):
        return cam
    lo, hi = bounds["min"], bounds["max"]
    if any(a > b for a, b in zip(lo, hi)):
        return cam
    centre = [0.5 * (a + b) for a, b in zip(lo, hi)]
    half = 0.5 * math.dist(lo, hi)
    radius = half if half > 0 else 1e-9  # 1e-9 for a point only, as the server does
    half_y = 0.5 * cam["fov_y_deg"] * math.pi / 180.0
    half_x = (
        math.atan(math.tan(half_y) * aspect) if aspect > 0 and math.isfinite(aspect) else half_y
    )
    dist = radius / math.sin(min(half_y, half_x))
    # bounds flat in y (a ground plane) or x are edge-on from ±z: seen from 45° above or beside
    # (engine/scene/scene.h kDefaultCameraFlat)
    e = [b - a for a, b in zip(lo, hi)]
    flat = DEFAULT_CAMERA_FLAT * math.hypot(*e)  # hypot: |e|² underflows at 1e-300
    d = [0.0, 0.0, 1.0 if view == "+z" else -1.0]
    if e[1] <= flat:
        d[1] = 1.0
    elif e[0] <= flat:
        d[0] = 1.0
    n = math.sqrt(sum(x * x for x in d))
    cam["look_at"] = centre
    cam["position"] = [c + (x / n) * dist for c, x in zip(centre, d)]
    return cam


def _read_output(q: Question, path: pathlib.Path) -> Any:
    """The answer a program wrote (or a file in the submission), as the compare step reads it."""
    if not path.is_file():
        raise StudentProblem(f"{path.name} is missing (expected {_what_file(q)})")
    if q.ask == "image":
        try:
            return read_png(path.read_bytes())
        except (PngError, OSError) as exc:
            raise StudentProblem(f"{path.name} is not a readable PNG: {exc}") from None
    try:
        rows = _read_rows(q, path)
    except (TableError, OSError) as exc:
        raise StudentProblem(f"{path.name} is not a table of numbers: {exc}") from None
    if not rows:
        raise StudentProblem(f"{path.name} is empty (expected {_what_file(q)})")
    if q.ask == "hits":
        values: list[Any] = [[v for v in row if not math.isinf(v)] for row in rows]
    else:
        values = [row[0] if row else math.inf for row in rows]
    if q.ask in ("triangle_hit", "inside"):
        values = [bool(v) and not math.isinf(v) for v in values]
    return values if q.many else (values[0] if values else MISSING)


#: The program outputs in which a row may say "nothing here": a miss (t), a ray with no hits
#: (hits), a ray that misses (triangle_hit). There a blank line is such a row.
BLANK_ROW_ASKS = {"t", "hits", "triangle_hit"}


def _read_rows(q: Question, path: pathlib.Path) -> list[list[float]]:
    """The rows of a program's output (`tables.read_table`); for the asks of BLANK_ROW_ASKS a
    blank line is a row of its own (empty: a miss) instead of being skipped, so `8\n\n8\n` is
    three rays, the second a miss. Blank lines past the number of rays at either end of the
    file (a trailing newline, an empty first line) are not rows."""
    rows = read_table(path, blank_rows=q.ask in BLANK_ROW_ASKS)
    wanted = len(q.rays or q.query_points) if q.many else 1
    while len(rows) > wanted and not rows[-1]:
        rows.pop()
    while len(rows) > wanted and not rows[0]:
        rows.pop(0)
    return rows


def _what_file(q: Question) -> str:
    if q.ask == "image":
        return "a PNG image"
    return f"one row per {'ray' if q.rays else 'point'}"


def _message(q: Question, checks: list[cmp.Check]) -> str:
    credit = sum(c.credit for c in checks) / len(checks)
    unreadable = [c.detail for c in checks if c.detail.startswith("could not read")]
    if not q.visible:
        word = "correct" if credit >= 1.0 else "incorrect"
        return word + (": " + "; ".join(unreadable) if unreadable else "")
    if not q.many:
        return ("correct: " if credit >= 1.0 else "incorrect: ") + checks[0].detail
    what = "ray" if q.rays else "point"
    full = sum(c.credit >= 1.0 for c in checks)
    head = f"{full} of {len(checks)} {what}s correct"
    wrong = [f"{what} {i + 1}: {c.detail}" for i, c in enumerate(checks) if c.credit < 1.0]
    return head + (". " + "; ".join(wrong) if wrong else "")


def _items(q: Question) -> str:
    return "rays" if q.rays else "points"


def _is_object(hit: dict, obj: str | int | None) -> bool:
    if isinstance(obj, int):
        return hit.get("object") == obj
    return str(hit.get("name", "")).strip().lower() == str(obj).strip().lower()


def _extent(q: Question, client: Client) -> float:
    """The scene's size for the default tolerance: its largest |coordinate| or diagonal, and
    the rays' origins and query points."""
    sizes = [1.0]
    try:
        b = client.get_scene(client.scene_id(q.scene)).get("bounds")
    except RaycastdError:
        b = None
    if b:
        sizes += [abs(v) for v in b["min"] + b["max"]]
        sizes.append(math.dist(b["min"], b["max"]))
    for r in q.rays:
        sizes += [abs(v) for v in r["origin"]]
    for p in q.query_points:
        sizes += [abs(v) for v in p]
    return max(sizes)


def _norm(v: list[float]) -> float:
    return math.sqrt(sum(x * x for x in v))


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text) or "q"


def grade_files(
    qset: QuestionSet,
    url: str,
    answers_path: pathlib.Path | None,
    submission: pathlib.Path | None,
) -> Report:
    """Grades one submission (answers file and/or submission folder)."""
    submission = submission.resolve() if submission is not None else None
    if answers_path is None and submission is not None:
        answers_path = find_answers(qset, submission)
    return Grader(qset, url).grade(load_answers(answers_path), submission)


def find_answers(qset: QuestionSet, submission: pathlib.Path) -> pathlib.Path:
    """The answers file in a submission folder: `[grading] answers`, else answers.toml/.json."""
    names = [qset.answers] if qset.answers else ["answers.toml", "answers.json"]
    for name in names:
        if (submission / name).is_file():
            return submission / name
    return submission / names[0]
