"""Question files: TOML written by course staff (clients/grading/README.md has the reference).

    [grading]
    title = "Tutorial 7"
    tolerance = { rtol = 1e-2 }          # or { sigfigs = 3 } or { decimals = 2 }; per question too

    [scenes.spheres]                     # a named scene: inline, or { file = "scene.json" }
    objects = [{ type = "sphere", center = [0, 0, 10], radius = 2 }]

    [[question]]
    id = "q1"
    points = 2
    scene = "spheres"                    # a [scenes] name, a file, or an inline table
    ray = { origin = [0, 0, 0], direction = [0, 0, 1] }
    ask = "first_hit"

Parsing checks everything a grading run needs up front, so a mistake in the file is reported
with the question's id and key before any student is graded.
"""

from __future__ import annotations

import json
import math
import pathlib

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: python3-tomli (Debian, Ubuntu) is the same parser
    import tomli as tomllib  # type: ignore[no-redef]
from dataclasses import dataclass, field
from typing import Any, Mapping

from raycastd.grading.tolerance import Tolerance

#: What a question can ask, and what it is asked about.
RAY_ASKS = {"first_hit", "t", "hit_point", "normal", "hits", "triangle_hit"}
TREE_ASKS = {"ambient_only", "full_phong", "ray_tree_points"}
POINT_ASKS = {"closest_point", "inside"}
IMAGE_ASKS = {"image"}
ASKS = RAY_ASKS | TREE_ASKS | POINT_ASKS | IMAGE_ASKS

QUESTION_KEYS = {
    "id",
    "points",
    "ask",
    "scene",
    "ray",
    "rays",
    "point",
    "points_at",
    "prompt",
    "visible",
    "tolerance",
    "timeout_s",
    "index_base",
    "object",
    "max_depth",
    "precision",
    "answer_file",
    "program",
    "expected",
    "normal_sign",
    "camera",
    "width",
    "height",
    "spp",
    "shading",
    "pixel_tolerance",
    "max_bad_fraction",
    "partial_credit",
    "name",
}
GRADING_KEYS = {"title", "tolerance", "timeout_s", "index_base", "program", "visible", "answers"}


class QuestionFileError(ValueError):
    """The question file is wrong; the message names the question and the key."""


@dataclass
class ImageSpec:
    """What an `image` question renders and how closely the student's picture must match."""

    width: int = 160
    height: int = 120
    spp: int = 1
    shading: str = "normal"
    camera: dict | None = None
    max_depth: int | None = None
    pixel_tolerance: int = 8  # per channel, out of 255
    max_bad_fraction: float = 0.01  # share of pixels allowed to differ by more
    partial_credit: bool = True  # linear from max_bad_fraction (full) to everything (0)


@dataclass
class Question:
    """One question, with every default filled in."""

    id: str
    points: float
    ask: str
    scene: dict
    scene_label: str
    prompt: str = ""
    rays: list[dict] = field(default_factory=list)
    query_points: list[list[float]] = field(default_factory=list)
    many: bool = False  # `rays`/`points_at` (answer is a list, one per item) vs `ray`/`point`
    visible: bool = True
    tolerance: Tolerance = field(default_factory=Tolerance)
    timeout_s: float = 30.0
    index_base: int = 0
    # triangle_hit's object: a name as written, or an index made 0-based (the file's follows
    # index_base, as students' answers do)
    object: str | int | None = None
    max_depth: int | None = None
    precision: str | None = None
    answer_file: str | None = None
    program: list[str] | None = None
    # the instructor's reference, checked and normalised at load time (one value, or one per
    # item): first_hit's is (0-based index, name) or None, t's a float (inf: a miss), …
    expected: Any = None
    normal_sign: str = "exact"
    image: ImageSpec | None = None

    @property
    def title(self) -> str:
        return f"{self.id}: {self.prompt}" if self.prompt else self.id


@dataclass
class QuestionSet:
    """A parsed question file."""

    title: str
    questions: list[Question]
    base_dir: pathlib.Path
    answers: str | None = None  # default student answer file name inside a submission


def load_questions(path: str | pathlib.Path) -> QuestionSet:
    """Parses and checks a question file; raises QuestionFileError."""
    path = pathlib.Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise QuestionFileError(f"{path}: {exc}") from None
    return parse_questions(data, path.parent, str(path))


def parse_questions(
    data: Mapping[str, Any], base_dir: pathlib.Path, name: str = "<questions>"
) -> QuestionSet:
    g = dict(data.get("grading", {}))
    _no_unknown(g, GRADING_KEYS, f"{name} [grading]")
    try:
        tol = Tolerance.parse(g.get("tolerance"))
    except ValueError as exc:
        raise QuestionFileError(f"{name} [grading] tolerance: {exc}") from None
    scenes = {
        k: _scene(v, base_dir, f"{name} [scenes.{k}]") for k, v in data.get("scenes", {}).items()
    }
    qs = data.get("question", [])
    if not isinstance(qs, list) or not qs:
        raise QuestionFileError(f"{name}: no [[question]] tables")
    out: list[Question] = []
    seen: set[str] = set()
    for i, q in enumerate(qs):
        where = f"{name} question {i + 1}" + (
            f" ({q.get('id')})" if isinstance(q, dict) and q.get("id") else ""
        )
        try:
            question = _question(q, g, tol, scenes, base_dir)
        except (ValueError, TypeError, KeyError) as exc:
            raise QuestionFileError(f"{where}: {exc}") from None
        if question.id in seen:
            raise QuestionFileError(f"{where}: duplicate id {question.id!r}")
        seen.add(question.id)
        out.append(question)
    return QuestionSet(str(g.get("title", "")), out, base_dir, g.get("answers"))


def _question(
    q: Mapping[str, Any],
    g: Mapping[str, Any],
    tol: Tolerance,
    scenes: dict[str, tuple[dict, str]],
    base_dir: pathlib.Path,
) -> Question:
    if not isinstance(q, Mapping):
        raise TypeError("a question must be a table")
    _no_unknown(q, QUESTION_KEYS, "question")
    qid = q.get("id")
    if not isinstance(qid, str) or not qid.strip():
        raise ValueError("id must be a non-empty string")
    ask = q.get("ask")
    if ask not in ASKS:
        raise ValueError(f"ask must be one of {', '.join(sorted(ASKS))}, not {ask!r}")
    points = q.get("points", 1)
    if not isinstance(points, (int, float)) or isinstance(points, bool) or points < 0:
        raise ValueError(f"points must be a number ≥ 0, not {points!r}")
    if "scene" not in q:
        raise ValueError("scene is required (a [scenes] name, a file, or an inline table)")
    spec = q["scene"]
    if isinstance(spec, str) and spec in scenes:
        scene, label = scenes[spec]
    else:
        scene, label = _scene(spec, base_dir, "scene")
    question = Question(
        id=qid,
        points=float(points),
        ask=ask,
        scene=scene,
        scene_label=label,
        prompt=str(q.get("prompt", q.get("name", ""))),
        visible=bool(q.get("visible", g.get("visible", True))),
        tolerance=Tolerance.parse(q.get("tolerance"), tol),
        timeout_s=float(q.get("timeout_s", g.get("timeout_s", 30.0))),
        index_base=int(q.get("index_base", g.get("index_base", 0))),
        object=q.get("object"),
        max_depth=q.get("max_depth"),
        precision=q.get("precision"),
        answer_file=q.get("answer_file"),
        program=_program(q.get("program", g.get("program"))),
        expected=q.get("expected"),
        normal_sign=str(q.get("normal_sign", "exact")),
    )
    if question.normal_sign not in ("exact", "either"):
        raise ValueError("normal_sign must be 'exact' or 'either'")
    if question.index_base not in (0, 1):
        raise ValueError("index_base must be 0 or 1")
    if ask in RAY_ASKS | TREE_ASKS:
        question.rays, question.many = _items(q, "ray", "rays", _ray)
    elif ask in POINT_ASKS:
        question.query_points, question.many = _items(q, "point", "points_at", _vec3)
    else:
        question.image = _image(q)
        if not question.answer_file and not question.program:
            raise ValueError(
                "an image question needs answer_file (a PNG in the submission) or program"
            )
    if question.program and not question.answer_file:
        question.answer_file = f"{qid}.png" if ask == "image" else f"{qid}.csv"
    if question.answer_file and ask not in ("t", "image", "hits", "triangle_hit", "inside"):
        raise ValueError(
            f"answer_file (program output) is read for t, hits, triangle_hit, inside and image, not {ask}"
        )
    names = object_names(scene)
    if question.object is not None:
        if ask != "triangle_hit":
            raise ValueError(f"object is read by triangle_hit questions only, not {ask}")
        if not has_mesh(scene):
            question.object = _object(question.object, names, question.index_base, "object")
        elif not isinstance(question.object, str) or not question.object.strip():
            # as for first_hit's expected: the server numbers a mesh's parts
            raise ValueError(
                "object: in a scene with a mesh the objects are numbered by the server; "
                "name the object instead"
            )
    if question.expected is not None:
        question.expected = _expected(question, names)
    return question


def object_names(scene: Mapping[str, Any]) -> list[str]:
    """The names raycastd gives a scene document's objects, by index: an object's `name`, else
    `"<type> <index+1>"` (docs/api.md, "Names"): `sphere 3` is the third object of the scene."""
    objects = scene.get("objects")
    names = []
    for i, o in enumerate(objects if isinstance(objects, list) else []):
        o = o if isinstance(o, Mapping) else {}
        name = o.get("name")
        names.append(name if isinstance(name, str) else f"{o.get('type', 'object')} {i + 1}")
    return names


def has_mesh(scene: Mapping[str, Any]) -> bool:
    """Whether a scene document has a mesh object, whose parts the server names and numbers."""
    objects = scene.get("objects")
    return any(
        isinstance(o, Mapping) and o.get("type") == "mesh"
        for o in (objects if isinstance(objects, list) else [])
    )


def norm_name(s: str) -> str:
    """An object's name as names are compared: case and whitespace ignored."""
    return "".join(s.split()).lower()


def _listing(names: list[str], base: int) -> str:
    if not names:
        return "the scene has no objects"
    shown = ", ".join(f"{i + base} = {n}" for i, n in enumerate(names[:12]))
    return f"its objects are {shown}" + (", …" if len(names) > 12 else "")


def _object(v: Any, names: list[str], base: int, where: str) -> int | str:
    """An object named in the question file: an index (per index_base, as students answer) is
    returned 0-based; a name is checked against the scene's and returned as written."""
    if isinstance(v, int) and not isinstance(v, bool):
        if base <= v < base + len(names):
            return v - base
        raise ValueError(
            f"{where} = {v} is not an object of the scene (index_base = {base}: "
            f"{_listing(names, base)})"
        )
    if isinstance(v, str) and v.strip():
        if any(norm_name(n) == norm_name(v) for n in names):
            return v
        raise ValueError(
            f"{where} = {v!r} names no object of the scene ({_listing(names, base)}; "
            "an index is written as a number)"
        )
    raise ValueError(f"{where} must be an object's name or index, not {v!r}")


def _is_miss(v: Any) -> bool:
    from raycastd.grading.compare import is_miss_word  # compare imports this module

    return (isinstance(v, str) or v == -1) and is_miss_word(v)


def _expected(q: Question, names: list[str]) -> Any:
    """The instructor's `expected`, checked and put in the form the reference takes (one value,
    or one per item with `rays` / `points_at`), so that a wrong one stops the run here."""
    n = len(q.rays or q.query_points)
    if q.many:
        if not isinstance(q.expected, list) or len(q.expected) != n:
            raise ValueError(
                f"expected must be a list of {n} values, one per "
                f"{'ray' if q.rays else 'point'}, not {q.expected!r}"
            )
        return [_expected_one(q, v, names, f"expected[{i}]") for i, v in enumerate(q.expected)]
    return _expected_one(q, q.expected, names, "expected")


def _expected_one(q: Question, v: Any, names: list[str], where: str) -> Any:
    ask = q.ask
    if ask == "first_hit":  # (object index, name), or None for no hit
        if _is_miss(v):
            return None
        if has_mesh(q.scene):
            # A mesh object becomes as many objects as its file has parts, named and numbered
            # by the server: the document's list says neither, so the name is compared as
            # written (index -1), and an index cannot be resolved here.
            if isinstance(v, str) and v.strip() and not v.strip().isdigit():
                return (-1, v)
            raise ValueError(
                f"{where} = {v!r}: in a scene with a mesh the objects are numbered by the server; "
                "name the object instead"
            )
        if isinstance(v, str) and v.strip().isdigit():
            v = int(v)
        if isinstance(v, int) and not isinstance(v, bool):
            i = _object(v, names, q.index_base, where)
            return (i, names[i])  # type: ignore[index]
        if isinstance(v, str):
            _object(v, names, q.index_base, where)
            return next((i, n) for i, n in enumerate(names) if norm_name(n) == norm_name(v))
        raise ValueError(f'{where} must be an object\'s name or index, or "none", not {v!r}')
    if ask == "t":  # a number; inf for a miss
        if _is_miss(v):
            return float("inf")
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            return float(v)
        raise ValueError(f'{where} must be a number (or "none" for a miss), not {v!r}')
    if ask in ("hit_point", "normal", "closest_point"):
        if _is_miss(v):
            return None
        return _vec3(v, where)
    if ask == "hits":
        if isinstance(v, list) and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in v
        ):
            return [float(x) for x in v if not math.isinf(x)]
        raise ValueError(f"{where} must be a list of numbers (every t along the ray), not {v!r}")
    if ask in ("triangle_hit", "inside"):
        if isinstance(v, bool):
            return v
        raise ValueError(f"{where} must be true or false, not {v!r}")
    if ask == "ray_tree_points":
        if isinstance(v, int) and not isinstance(v, bool) and v >= 0:
            return v
        raise ValueError(f"{where} must be an integer ≥ 0, not {v!r}")
    raise ValueError(f"expected cannot be given for {ask} (its reference comes from raycastd only)")


def _items(q: Mapping[str, Any], one: str, many: str, convert: Any) -> tuple[list, bool]:
    if (one in q) == (many in q):
        raise ValueError(f"give exactly one of {one} and {many}")
    if one in q:
        return [convert(q[one], one)], False
    items = q[many]
    if isinstance(items, str):
        raise ValueError(f"{many} must be a list")
    if not items:
        raise ValueError(f"{many} is empty")
    return [convert(v, f"{many}[{i}]") for i, v in enumerate(items)], True


def _ray(v: Any, where: str) -> dict:
    if isinstance(v, Mapping):
        ray = {
            "origin": _vec3(v.get("origin"), where + ".origin"),
            "direction": _vec3(v.get("direction"), where + ".direction"),
        }
        for k in ("tmin", "tmax"):
            if k in v:
                ray[k] = float(v[k])
        return ray
    if isinstance(v, list) and len(v) == 6:
        return {"origin": _vec3(v[:3], where), "direction": _vec3(v[3:], where)}
    raise ValueError(f"{where} must be {{origin = [..], direction = [..]}} or 6 numbers")


def _vec3(v: Any, where: str) -> list[float]:
    if (
        not isinstance(v, list)
        or len(v) != 3
        or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
    ):
        raise ValueError(f"{where} must be 3 numbers, not {v!r}")
    return [float(x) for x in v]


def _program(v: Any) -> list[str] | None:
    if v is None:
        return None
    if isinstance(v, str):
        return v.split()
    if isinstance(v, list) and all(isinstance(x, str) for x in v) and v:
        return list(v)
    raise ValueError("program must be a command line (a string, or a list of strings)")


def _image(q: Mapping[str, Any]) -> ImageSpec:
    spec = ImageSpec()
    for key in ("width", "height", "spp", "pixel_tolerance", "max_depth"):
        if key in q:
            if not isinstance(q[key], int) or q[key] < 0:
                raise ValueError(f"{key} must be an integer")
            setattr(spec, key, q[key])
    if "shading" in q:
        spec.shading = str(q["shading"])
    if "camera" in q:
        if not isinstance(q["camera"], Mapping):
            raise ValueError("camera must be a table {position, look_at, up, fov_y_deg}")
        spec.camera = dict(q["camera"])
    if "max_bad_fraction" in q:
        spec.max_bad_fraction = float(q["max_bad_fraction"])
        if not 0 <= spec.max_bad_fraction <= 1:
            raise ValueError("max_bad_fraction must be in [0, 1]")
    spec.partial_credit = bool(q.get("partial_credit", True))
    return spec


def _scene(spec: Any, base_dir: pathlib.Path, where: str) -> tuple[dict, str]:
    """(scene document, label) from an inline table, `{file = …}` or a file name."""
    if isinstance(spec, Mapping) and set(spec) == {"file"}:
        spec = spec["file"]
    if isinstance(spec, str):
        path = (base_dir / spec).resolve()
        try:
            doc = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise QuestionFileError(f"{where}: cannot read scene file {spec}: {exc}") from None
        if not isinstance(doc, dict):
            raise QuestionFileError(f"{where}: {spec} is not a scene document")
        return doc, spec
    if isinstance(spec, Mapping):
        if "objects" not in spec:
            raise QuestionFileError(f"{where}: an inline scene needs objects")
        return dict(spec), "inline scene"
    raise QuestionFileError(f"{where}: a scene is a [scenes] name, a file, or a table")


def _no_unknown(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    unknown = set(table) - allowed
    if unknown:
        raise QuestionFileError(f"{where}: unknown keys {', '.join(sorted(unknown))} (a typo?)")
