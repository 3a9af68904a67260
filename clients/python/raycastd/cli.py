"""The `raycastd` command line: `python3 -m raycastd NOUN VERB …` (installed as `rcd`).

Results go to stdout (machine-readable JSON with `--json`), messages and errors to stderr. Exit
status: 0 done, 1 the API answered an error or could not be reached (its code is printed), or
an output file could not be written, 2 usage. SCENE arguments are a registered id (`sc_…`) or a
file (a `.json` scene document or a model file). The queries (`intersect --ray`, `points`,
`explain`) send a file inline to the stateless endpoints, so they register nothing and need no
token; what the API answers only for a registered scene (`render`, `trace`, `intersect --rays`,
whose binary form needs one) registers the file on the fly (content-addressed: the same file,
the same id), a write.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import pathlib
import re
import sys
from typing import Any, Callable, Sequence, TextIO

from raycastd.client import MODEL_FORMATS, MODEL_TYPES, Client, SceneRef, scene_document
from raycastd.errors import RaycastdError, Unauthorized
from raycastd.tables import TableError, read_table, write_table

PROG = "raycastd"
SCENE_ID = re.compile(r"^sc_[0-9A-Za-z]+$")


class UsageError(Exception):
    """A command line that cannot be carried out as written (exit status 2)."""


class OutputFailed(Exception):
    """A result that could not be written to its file (exit status 1)."""


# -- argument parsing -----------------------------------------------------------------------


def vector(text: str, n: int = 3) -> list[float]:
    """`x,y,z` → [x, y, z]."""
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not {n} comma-separated numbers") from None
    if len(values) != n:
        raise argparse.ArgumentTypeError(
            f"{text!r} has {_plural(len(values), 'number')}, expected {n}"
        )
    return values


def ray_arg(text: str) -> dict[str, Any]:
    """`ox,oy,oz:dx,dy,dz[:tmin[:tmax]]` → a JSON ray."""
    parts = text.split(":")
    if len(parts) not in (2, 3, 4):
        raise argparse.ArgumentTypeError(f"{text!r}: a ray is ORIGIN:DIRECTION[:TMIN[:TMAX]]")
    ray: dict[str, Any] = {"origin": vector(parts[0]), "direction": vector(parts[1])}
    try:
        if len(parts) >= 3:
            ray["tmin"] = float(parts[2])
        if len(parts) == 4:
            ray["tmax"] = float(parts[3])
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: tmin/tmax must be numbers") from None
    return ray


def size_arg(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"(\d+)[xX](\d+)", text)
    if not m:
        raise argparse.ArgumentTypeError(f"{text!r}: a size is WIDTHxHEIGHT, e.g. 800x600")
    return int(m.group(1)), int(m.group(2))


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--server",
        default=argparse.SUPPRESS,
        metavar="URL",
        help="the raycastd server (default: $RAYCASTD_URL, then http://127.0.0.1:8080)",
    )
    common.add_argument(
        "--json", action="store_true", default=argparse.SUPPRESS, help="machine output on stdout"
    )
    common.add_argument(
        "--timeout", type=float, default=argparse.SUPPRESS, metavar="S", help="seconds (60)"
    )
    common.add_argument(
        "--token", default=argparse.SUPPRESS, help="bearer token for writes ($RAYCASTD_TOKEN)"
    )

    p = argparse.ArgumentParser(
        prog=prog,
        parents=[common],
        description="Ray queries, renders, ray trees, worked solutions and grading with raycastd.",
        epilog="Exit status: 0 ok, 1 API error (its code is printed), 2 usage.",
    )
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)

    def cmd(name: str, help_: str, **kw: Any) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=help_, description=help_, parents=[common], **kw)

    scene = cmd("scene", "register, list, show and delete scenes")
    verbs = scene.add_subparsers(dest="verb", metavar="VERB", required=True)
    add = verbs.add_parser("add", help="register scene documents or model files", parents=[common])
    add.add_argument("files", nargs="+", type=pathlib.Path, metavar="FILE")
    verbs.add_parser("list", help="list registered scenes", parents=[common])
    show = verbs.add_parser("show", help="one scene's summary", parents=[common])
    show.add_argument("id")
    rm = verbs.add_parser("rm", help="delete scenes", parents=[common])
    rm.add_argument("ids", nargs="+", metavar="ID")

    def rays_options(q: argparse.ArgumentParser) -> None:
        q.add_argument("scene", metavar="SCENE", help="scene id or file")
        q.add_argument(
            "--ray",
            action="append",
            type=ray_arg,
            default=[],
            metavar="O:D",
            help="ox,oy,oz:dx,dy,dz[:tmin[:tmax]] (repeatable)",
        )
        q.add_argument(
            "--rays",
            type=pathlib.Path,
            metavar="FILE",
            help=".npy or .csv of rows ox oy oz dx dy dz [tmin tmax], sent in binary",
        )
        q.add_argument("--precision", choices=["fast", "refined", "exact"])

    q = cmd("intersect", "cast rays into a scene")
    rays_options(q)
    q.add_argument("--mode", choices=["closest", "any", "all", "count"], default="closest")
    q.add_argument("--fields", help="comma-separated fields of a JSON hit record")
    q.add_argument(
        "-o", "--output", type=pathlib.Path, help="write --rays results to FILE (.csv or .npy)"
    )

    q = cmd("points", "closest points, distances, inside/outside")
    q.add_argument("scene", metavar="SCENE", help="scene id or file")
    q.add_argument("--point", action="append", type=vector, default=[], metavar="X,Y,Z")
    q.add_argument("--points", type=pathlib.Path, metavar="FILE", help=".npy or .csv of x y z")
    q.add_argument(
        "--query",
        choices=["closest", "distance", "signed_distance", "occupancy"],
        default="closest",
    )
    q.add_argument("--max-distance", type=float)

    q = cmd("render", "render an image")
    q.add_argument("scene", metavar="SCENE", help="scene id or file")
    q.add_argument("-o", "--output", type=pathlib.Path, required=True, metavar="FILE")
    q.add_argument("--size", type=size_arg, metavar="WxH", help="image size (640x480)")
    q.add_argument("--spp", type=int, help="samples per pixel (1)")
    q.add_argument(
        "--sampling",
        choices=["uniform", "adaptive"],
        help="uniform (default): spp samples in every pixel; adaptive: the extra ones only "
        "where a pixel differs from a neighbour",
    )
    q.add_argument("--max-depth", type=int)
    q.add_argument("--shading", choices=["phong", "normal", "depth", "object_id", "barycentric"])
    q.add_argument(
        "--lighting",
        choices=["auto", "scene", "headlight"],
        help="auto (default): the scene's lights, or a headlight when it has none",
    )
    q.add_argument("--precision", choices=["fast", "refined", "exact"])
    q.add_argument("--format", choices=["png", "ppm", "pfm", "exr"], help="default: by -o suffix")
    q.add_argument("--camera", help="camera JSON, or a file holding it")
    q.add_argument(
        "--progress",
        choices=["auto", "always", "never"],
        default="auto",
        help="a progress bar on stderr (auto: when stderr is a terminal)",
    )

    q = cmd("trace", "the Whitted ray tree of one ray")
    q.add_argument("scene", metavar="SCENE", help="scene id or file")
    q.add_argument("--ray", type=ray_arg, required=True, metavar="O:D")
    q.add_argument("--max-depth", type=int)
    q.add_argument("--precision", choices=["fast", "refined", "exact"])

    q = cmd("explain", "the worked solution a student would write")
    q.add_argument(
        "scene",
        metavar="SCENE",
        help="a scene document (.json) or a model file, sent inline (not a registered id)",
    )
    q.add_argument("--ray", type=ray_arg, required=True, metavar="O:D")
    q.add_argument("--markdown", action="store_true", help="Markdown with LaTeX")

    cmd("health", "is the server up")
    cmd("info", "server version, limits, scenes and memory")

    from raycastd.grading.cli import add_grade_parser

    add_grade_parser(sub, common)
    return p


# -- running --------------------------------------------------------------------------------


class Output:
    """Where a command writes: results to `out`, messages to `err`; JSON mode or text."""

    def __init__(self, json_mode: bool, out: TextIO, err: TextIO) -> None:
        self.json_mode = json_mode
        self.out = out
        self.err = err

    def result(self, data: Any, text: Callable[[], str] | str | None = None) -> None:
        if self.json_mode or text is None:
            self.out.write(json.dumps(data, indent=2, default=_json_default) + "\n")
        else:
            self.out.write((text() if callable(text) else text).rstrip("\n") + "\n")

    def message(self, text: str) -> None:
        self.err.write(text + "\n")


def main(
    argv: Sequence[str] | None = None,
    out: TextIO | None = None,
    err: TextIO | None = None,
    prog: str = PROG,
) -> int:
    """Runs the command line; returns the exit status."""
    out = out or sys.stdout
    err = err or sys.stderr
    parser = build_parser(prog)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) or a usage error (2)
        return int(exc.code or 0)
    io = Output(getattr(args, "json", False), out, err)
    try:
        if args.command == "grade":
            from raycastd.grading.cli import run_grade

            return run_grade(args, io)
        with Client(
            getattr(args, "server", None),
            timeout=getattr(args, "timeout", 60.0),
            token=getattr(args, "token", None) or os.environ.get("RAYCASTD_TOKEN"),
        ) as client:
            return COMMANDS[args.command](client, args, io)
    except UsageError as exc:
        err.write(f"{prog}: usage: {exc}\n")
        return 2
    except RaycastdError as exc:
        err.write(f"{prog}: error: {exc}\n")
        if isinstance(exc, Unauthorized) and getattr(exc, "hint", None):
            err.write(f"{prog}: {exc.hint}\n")
        return 1
    except OutputFailed as exc:
        err.write(f"{prog}: error: {exc}\n")
        return 1
    except KeyboardInterrupt:
        err.write(f"{prog}: interrupted\n")
        return 130


def scene_ref(text: str) -> SceneRef:
    """A SCENE argument: an existing file, else a scene id."""
    path = pathlib.Path(text)
    if path.is_file():
        return path
    if SCENE_ID.match(text):
        return text
    raise UsageError(f"SCENE {text!r} is neither a file nor a scene id (sc_…)")


def scene_arg(client: Client, text: str, io: Output, why: str) -> str:
    """A SCENE argument as a registered scene's id: a file is registered first, and the
    warnings the server has about it are printed as `scene add` prints them (a material library
    it could not read, an unknown key); an id is taken as it is. Registering is a write: when
    the server wants its token for it (401), the error says `why` the command needed a
    registered scene and how to pass the token."""
    ref = scene_ref(text)
    if isinstance(ref, pathlib.Path):
        with _write_needed(client, f"{why}, so {ref} is registered first, a write"):
            summary = client.add_scene(ref)
        for w in summary.get("warnings", []):
            io.message(f"{ref}: warning: {w}")
        return summary["id"]
    return ref


def query_scene(client: Client, text: str, io: Output, what: str) -> SceneRef:
    """A SCENE argument for the stateless queries (`what`: intersect, points): a `.json` scene
    document is sent inline as it is, so that nothing is registered and no token is needed; an
    id as it is. A model file is registered, as before: sent inline it would be one mesh object
    (`scene_document`), where registered its parts are objects of their own, with the names
    and numbers the server gives them (2CylinderEngine.glb: 67 objects against 1), and a hit
    should name the part. A file whose extension tells no model format is registered too (the
    server tells those by their bytes only on registration)."""
    ref = scene_ref(text)
    if not isinstance(ref, pathlib.Path):
        return ref
    if ref.suffix.lower() != ".json":
        why = (
            f"{what} registers a model file, so that its parts are objects of their own as the "
            "server names them"
        )
        return scene_arg(client, text, io, why)
    doc = _document_arg(ref)
    assert doc is not None  # a .json file is a document or a ValueError
    return doc


def _document_arg(path: pathlib.Path) -> dict | None:
    """scene_document(path), its errors as usage errors (one line, exit 2)."""
    try:
        return scene_document(path)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    except OSError as exc:
        raise UsageError(f"cannot read {path}: {exc.strerror or exc}") from None


@contextlib.contextmanager
def _write_needed(client: Client, why: str):
    """Adds to a 401 on a write why the write was needed and how to pass the token."""
    try:
        yield
    except Unauthorized as exc:
        if client.token:
            exc.hint = f"{why}; the server refused the token given (--token or $RAYCASTD_TOKEN)"
        else:
            exc.hint = (
                f"{why}; this server takes writes only with its token: pass --token T "
                "(or set RAYCASTD_TOKEN=T)"
            )
        raise


def _rays_from_args(args: argparse.Namespace) -> tuple[list[dict], list[list[float]] | None]:
    table = None
    if args.rays is not None:
        table = _table(args.rays, (6, 8), "rays")
    if not args.ray and table is None:
        raise UsageError("give at least one --ray or --rays FILE")
    return args.ray, table


def _table(path: pathlib.Path, widths: tuple[int, ...], what: str) -> list[list[float]]:
    try:
        rows = read_table(path)
    except (OSError, TableError) as exc:
        raise UsageError(str(exc)) from None
    for i, row in enumerate(rows):
        if len(row) not in widths:
            raise UsageError(
                f"{path}: row {i + 1} has {_plural(len(row), 'column')}; {what} need {' or '.join(map(str, widths))}"
            )
    return rows


def cmd_scene(client: Client, args: argparse.Namespace, io: Output) -> int:
    if args.verb == "add":
        results = []
        for f in args.files:
            if not f.is_file():
                raise UsageError(f"no such file: {f}")
            if f.suffix.lower() not in MODEL_TYPES:
                io.message(f"{f}: unknown extension; the server will tell the format by its bytes")
            with _write_needed(client, "scene add registers scenes"):
                summary = client.add_scene(f)
            results.append({"file": str(f), **summary})
            for w in summary.get("warnings", []):
                io.message(f"{f}: warning: {w}")
        io.result(
            results if len(results) > 1 else results[0],
            lambda: "\n".join(f"{r['id']}  {r['file']}  {_summary_line(r)}" for r in results),
        )
    elif args.verb == "list":
        scenes = client.list_scenes()
        io.result(
            scenes,
            lambda: "\n".join(f"{s['id']}  {_summary_line(s)}" for s in scenes) or "(no scenes)",
        )
    elif args.verb == "show":
        s = client.get_scene(args.id)
        io.result(s, lambda: scene_text(s))
    else:
        with _write_needed(client, "scene rm deletes scenes"):
            done = [client.delete_scene(i) for i in args.ids]
        io.result(
            done if len(done) > 1 else done[0],
            lambda: "\n".join(f"deleted {d['id']}" for d in done),
        )
    return 0


def _plural(n: Any, word: str, plural: str | None = None) -> str:
    """`1 object`, `2 objects`, `? objects` (n unknown)."""
    if n is None:
        n = "?"
    return f"{n} {word if n == 1 else plural or word + 's'}"


def _summary_line(s: dict) -> str:
    b = s.get("bounds")
    box = f"bounds {b['min']}..{b['max']}" if b else "empty"
    return (
        f"{_plural(s.get('objects'), 'object')}, {_plural(s.get('triangles'), 'triangle')}, "
        f"{_plural(s.get('spheres'), 'sphere')}, {box}"
    )


def scene_text(s: dict) -> str:
    """A scene's summary (`GET /v1/scenes/{id}`) as lines a person reads (`--json`: as it is)."""
    lines = [f"{s.get('id')}: {_summary_line(s)}"]
    features = s.get("features") or {}
    on = [k for k, v in features.items() if v]
    if features:
        lines.append(f"features: {', '.join(on) if on else 'none'}")
    cam = s.get("camera")
    if cam:
        lines.append(
            f"camera: at {_vec(cam['position'])} looking at {_vec(cam['look_at'])}, "
            f"up {_vec(cam['up'])}, fov_y {cam.get('fov_y_deg'):g}°"
        )
    else:
        lines.append(f"camera: none (renders look from {s.get('default_view', '?')})")
    extra = []
    if "memory_bytes" in s:
        extra.append(f"memory {s['memory_bytes']} bytes")
    if "build_ms" in s:
        extra.append(f"built in {s['build_ms']:.3g} ms")
    if extra:
        lines.append(", ".join(extra))
    for t in s.get("topology") or []:
        shape = (
            "closed"
            if t.get("closed")
            else (
                f"open ({_plural(t.get('boundary_edges'), 'boundary edge')}, "
                f"{_plural(t.get('boundary_loops'), 'loop')})"
            )
        )
        lines.append(
            f"mesh {t.get('object')} {t.get('name')!r}: {_plural(t.get('vertices'), 'vertex', 'vertices')}, "
            f"{_plural(t.get('triangles'), 'triangle')}, {shape}, "
            f"{_plural(t.get('components'), 'component')}, inside by {t.get('sign')}"
        )
    warnings = s.get("warnings") or []
    for w in warnings:
        lines.append(f"warning: {w}")
    return "\n".join(lines)


def cmd_intersect(client: Client, args: argparse.Namespace, io: Output) -> int:
    rays, table = _rays_from_args(args)
    if table is None:
        if args.output:
            raise UsageError("-o/--output writes the results of --rays FILE")
        scene = query_scene(client, args.scene, io, "intersect")
        fields = [f.strip() for f in args.fields.split(",") if f.strip()] if args.fields else None
        ans = client.intersect(scene, rays, mode=args.mode, precision=args.precision, fields=fields)
        io.result(ans, lambda: _hits_text(ans, fields))
        return 0
    if args.output:
        check_output(args.output)
    scene = scene_arg(
        client,
        args.scene,
        io,
        "intersect --rays sends its rays in the binary form, which the API answers only for a "
        "registered scene (--ray alone needs none)",
    )
    rows = [_ray_row(r) for r in rays] + [r if len(r) == 8 else r + [0.0, math.inf] for r in table]
    cols = _batch(client, scene, rows, args.mode, args.precision)
    if args.output:
        if args.mode == "all":  # one row per hit: the ray's index and the hit's t
            names = ["ray", "t"]
            out_rows = [[i, t] for i, ts in enumerate(cols["t"]) for t in ts]
        else:
            names = list(cols)
            out_rows = [list(vals) for vals in zip(*cols.values())]
        write_output(args.output, lambda: write_table(args.output, out_rows, ",".join(names)))
        io.message(f"wrote {_plural(len(out_rows), 'row')} ({', '.join(names)}) to {args.output}")
    io.result(
        {
            "mode": args.mode,
            "rays": len(rows),
            **{k: [_finite(v) for v in c] for k, c in cols.items()},
        },
        lambda: _batch_text(cols),
    )
    return 0


def _ray_row(ray: dict) -> list[float]:
    return [*ray["origin"], *ray["direction"], ray.get("tmin", 0.0), ray.get("tmax", math.inf)]


def _batch(
    client: Client, scene: SceneRef, rows: list[list[float]], mode: str, precision: str | None
) -> dict[str, list]:
    """One column list per output of the array query for `mode`, as plain Python values."""
    kw: dict[str, Any] = {
        "origins": [r[0:3] for r in rows],
        "directions": [r[3:6] for r in rows],
        "tmin": [r[6] for r in rows],
        "tmax": [r[7] for r in rows],
        "precision": precision,
    }
    if mode == "closest":
        a = _lists(client.cast_rays(scene, **kw))
        return {
            "t": a["t_hit"],
            "object": [_id(v) for v in a["geometry_ids"]],
            "primitive": [_id(v) for v in a["primitive_ids"]],
        }
    if mode == "any":
        return {"hit": [int(v) for v in _lists(client.test_occlusions(scene, **kw))]}
    if mode == "count":
        return {"count": [int(v) for v in _lists(client.count_intersections(scene, **kw))]}
    a = _lists(client.list_intersections(scene, **kw))
    s = a["ray_splits"]
    return {
        "count": [s[i + 1] - s[i] for i in range(len(rows))],
        "t": [a["t_hit"][s[i] : s[i + 1]] for i in range(len(rows))],
    }


def _lists(value: Any) -> Any:
    """Array query answers as plain lists (NumPy arrays converted)."""
    if isinstance(value, dict):
        return {k: _lists(v) for k, v in value.items()}
    return value.tolist() if hasattr(value, "tolist") else value


def _id(v: int) -> int:
    return -1 if v == 0xFFFFFFFF else int(v)


def _finite(v: Any) -> Any:
    if isinstance(v, list):
        return [_finite(x) for x in v]
    return None if isinstance(v, float) and not math.isfinite(v) else v


def _batch_text(cols: dict[str, list]) -> str:
    names = list(cols)
    lines = ["ray  " + "  ".join(names)]
    for i, vals in enumerate(zip(*cols.values())):
        lines.append(f"{i:<4} " + "  ".join(_fmt(v) for v in vals))
    return "\n".join(lines)


def _fmt(v: Any) -> str:
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    if isinstance(v, float):
        return "miss" if math.isinf(v) else f"{v:.9g}"
    return str(v)


def _hits_text(ans: dict, fields: Sequence[str] | None = None) -> str:
    """One line a ray, showing the fields of each hit the answer has; `t_err`, `front_face` and
    `barycentric` only when `fields` asked for them."""
    asked = set(fields or ())
    lines = []
    for i, h in enumerate(ans["hits"]):
        if "count" in h and "hits" in h:
            ts = ", ".join(_short_hit(x) for x in h["hits"])
            lines.append(f"ray {i}: {_plural(h['count'], 'hit')}" + (f": {ts}" if ts else ""))
        elif "count" in h:
            lines.append(f"ray {i}: {_plural(h['count'], 'crossing')}")
        elif not h.get("hit"):
            lines.append(f"ray {i}: miss")
        else:
            lines.append(f"ray {i}: " + _hit_text(h, asked))
    lines.append(f"(precision: {ans.get('precision')})")
    return "\n".join(lines)


def _who(h: dict) -> str:
    """`sphere 3 (object 2, primitive 0)`, with only the parts the hit record has."""
    ids = [f"{k} {h[k]}" for k in ("object", "primitive") if k in h]
    return " ".join(
        p
        for p in (str(h["name"]) if "name" in h else "", f"({', '.join(ids)})" if ids else "")
        if p
    )


def _short_hit(x: dict) -> str:
    """One hit of `--mode all`: its t and who was hit (name, else object), as far as the record
    says."""
    who = str(x["name"]) if "name" in x else (f"object {x['object']}" if "object" in x else "")
    if "t" in x:
        return f"{x['t']:.9g}" + (f" ({who})" if who else "")
    return who or "hit"


def _hit_text(h: dict, asked: set[str] = frozenset()) -> str:
    parts = []
    who = _who(h)
    if who:
        parts.append(who)
    if "t" in h:
        parts.append(f"t = {h['t']!r}")
    if "t_err" in h and "t_err" in asked:
        parts.append(f"t_err = {h['t_err']:.3g}")
    if "point" in h:
        parts.append("point " + _vec(h["point"]))
    if "normal" in h:
        parts.append("normal " + _vec(h["normal"]))
    if "front_face" in h and "front_face" in asked:
        parts.append("front face" if h["front_face"] else "back face")
    if "barycentric" in h and "barycentric" in asked:
        parts.append("barycentric " + _vec(h["barycentric"]))
    return "hit" + (" " + ", ".join(parts) if parts else "")


def _vec(v: Sequence[float]) -> str:
    return "(" + ", ".join(f"{x:.9g}" for x in v) + ")"


def cmd_points(client: Client, args: argparse.Namespace, io: Output) -> int:
    pts = list(args.point)
    if args.points is not None:
        pts += _table(args.points, (3,), "points")
    if not pts:
        raise UsageError("give at least one --point or --points FILE")
    ans = client.points(
        query_scene(client, args.scene, io, "points"),
        pts,
        query=args.query,
        max_distance=args.max_distance,
    )

    def text() -> str:
        lines = []
        for p, r in zip(pts, ans["results"]):
            if args.query == "closest":
                desc = (
                    f"closest {_vec(r['point'])} on {r.get('name')} at distance {r['distance']:.9g}"
                    if r.get("found")
                    else "no surface within max_distance"
                )
            elif args.query == "occupancy":
                desc = ("inside" if r["inside"] else "outside") + f" (winding {r['winding']:.6g})"
            elif r.get("distance") is not None:
                desc = f"distance {r['distance']:.9g}"
            elif args.query == "signed_distance":  # it searches the whole scene: an empty one
                desc = "no surface in the scene"
            else:
                desc = "no surface within max_distance"
            lines.append(f"{_vec(p)}: {desc}")
        return "\n".join(lines)

    io.result(ans, text)
    return 0


def check_output(path: pathlib.Path, flag: str = "-o") -> None:
    """Refuses (usage, before any request) an output file that cannot be created: its folder
    missing or not a folder, or the path a folder itself."""
    folder = path.parent
    if path.is_dir():
        raise UsageError(f"{flag} {path}: is a folder; give a file name")
    if not folder.exists():
        raise UsageError(f"{flag} {path}: no such folder {folder}")
    if not folder.is_dir():
        raise UsageError(f"{flag} {path}: {folder} is not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"{flag} {path}: cannot write in {folder}")


def write_output(path: pathlib.Path, write: Callable[[], Any]) -> None:
    """Runs `write`; an OSError (disk full, the folder gone meanwhile) is one line, exit 1."""
    try:
        write()
    except OSError as exc:
        raise OutputFailed(f"cannot write {path}: {exc.strerror or exc}") from None


def cmd_render(client: Client, args: argparse.Namespace, io: Output) -> int:
    check_output(args.output)
    opts: dict[str, Any] = {}
    if args.size:
        opts["width"], opts["height"] = args.size
    fmt = args.format or {".ppm": "ppm", ".pfm": "pfm", ".exr": "exr"}.get(
        args.output.suffix.lower()
    )
    for key, value in (
        ("spp", args.spp),
        ("sampling", args.sampling),
        ("max_depth", args.max_depth),
        ("shading", args.shading),
        ("lighting", args.lighting),
        ("precision", args.precision),
        ("format", fmt),
    ):
        if value is not None:
            opts[key] = value
    if args.camera:
        opts["camera"] = _json_arg(args.camera, "--camera")
    tty = io.err.isatty() if hasattr(io.err, "isatty") else False
    show = args.progress == "always" or (args.progress == "auto" and tty)
    progress: Any = ProgressBar(io.err) if show else False
    scene = scene_arg(
        client, args.scene, io, "render needs a registered scene (the API renders no other)"
    )
    image = client.render(scene, progress=progress, **opts)
    if show:
        io.err.write("\n")
    write_output(args.output, lambda: args.output.write_bytes(image))
    size = f"{opts.get('width', 640)}x{opts.get('height', 480)}"
    io.message(f"wrote {args.output} ({size}, {len(image)} bytes)")
    if io.json_mode:
        io.result({"output": str(args.output), "bytes": len(image), "size": size})
    return 0


class ProgressBar:
    """Draws `[#####.....]  50%  eta 1.2 s` on one terminal line."""

    def __init__(self, stream: TextIO, width: int = 30) -> None:
        self.stream = stream
        self.width = width

    def __call__(self, fraction: float, status: dict) -> None:
        n = int(round(fraction * self.width))
        eta = status.get("eta_s")
        tail = f"  eta {eta:.1f} s" if isinstance(eta, (int, float)) and fraction < 1 else ""
        self.stream.write(f"\r[{'#' * n}{'.' * (self.width - n)}] {fraction * 100:3.0f}%{tail}   ")
        self.stream.flush()


def _json_arg(text: str, what: str) -> Any:
    """JSON given inline (`{…}`) or a file holding it."""
    path = pathlib.Path(text)
    if path.is_file():
        try:
            return json.loads(path.read_text())
        except OSError as exc:
            raise UsageError(f"{what}: cannot read {path}: {exc.strerror or exc}") from None
        except ValueError as exc:
            raise UsageError(f"{what}: {path}: not JSON ({exc})") from None
    if not text.lstrip().startswith(("{", "[")):
        if path.exists():
            raise UsageError(f"{what}: {path} is not a file")
        raise UsageError(f"{what}: no such file: {path} (give a file, or the JSON itself)")
    try:
        return json.loads(text)
    except ValueError as exc:
        raise UsageError(f"{what}: not JSON ({exc})") from None


def cmd_trace(client: Client, args: argparse.Namespace, io: Output) -> int:
    ans = client.trace(
        scene_arg(
            client, args.scene, io, "trace needs a registered scene (the API traces no other)"
        ),
        args.ray,
        max_depth=args.max_depth,
        precision=args.precision,
    )
    io.result(ans, lambda: tree_text(ans))
    return 0


def tree_text(ans: dict) -> str:
    """The ray tree as indented lines, then its summary."""
    lines: list[str] = []

    def node(n: dict | None, depth: int, how: str) -> None:
        if n is None:
            return
        pad = "  " * depth
        shadows = ", ".join(
            f"light {s['light']} "
            + (
                f"blocked by {s['blocked_by']}"
                if s.get("blocked_by")
                else ("faces away" if s.get("facing") is False else "clear")
            )
            for s in n.get("shadow_rays", [])
        )
        terms = "full Phong" if len(n.get("terms", [])) > 1 else "ambient only"
        lines.append(
            f"{pad}{how}{n['label']}: {n['name']} at t = {n['t']:.9g}, point {_vec(n['point'])}, "
            f"{terms}" + (f"; shadow rays: {shadows}" if shadows else "")
        )
        node(n.get("reflected"), depth + 1, "reflected → ")
        node(n.get("refracted"), depth + 1, "refracted → ")

    if ans.get("tree") is None:
        lines.append("the ray hits nothing")
    node(ans.get("tree"), 0, "")
    s = ans.get("summary", {})
    lines.append(
        f"{_plural(s.get('points', 0), 'point')}; full Phong: {' '.join(s.get('full_phong', [])) or '-'}; "
        f"ambient only: {' '.join(s.get('ambient_only', [])) or '-'}"
    )
    return "\n".join(lines)


def cmd_explain(client: Client, args: argparse.Namespace, io: Output) -> int:
    path = pathlib.Path(args.scene)
    if not path.is_file():
        if SCENE_ID.match(args.scene):
            raise UsageError(
                f"explain needs the scene itself (a .json document or a model file), not the id "
                f"{args.scene}: the API explains only a scene sent with the question"
            )
        raise UsageError(f"explain needs a scene file: {args.scene} not found")
    doc = _document_arg(path)
    if doc is None:
        raise UsageError(
            f"{path}: explain takes a .json scene document or a model file named "
            f"{' '.join(MODEL_FORMATS)}"
        )
    if args.markdown:
        io.out.write(client.explain(doc, args.ray, markdown=True))
        return 0
    ans = client.explain(doc, args.ray)

    def text() -> str:
        lines = []
        for o in ans["objects"]:
            lines.append(
                f"{o['name']} ({o['type']}): "
                + ("hit at t = %r" % o["t"] if o["hit"] else o.get("reason", "miss"))
            )
            lines += [f"    {s}" for s in o["steps"]]
        fh = ans.get("first_hit")
        lines.append(
            f"first hit: {fh['name']} at t = {fh['t']!r}, point {_vec(fh['point'])}"
            if fh
            else "first hit: none"
        )
        return "\n".join(lines)

    io.result(ans, text)
    return 0


def cmd_health(client: Client, args: argparse.Namespace, io: Output) -> int:
    ans = client.health()
    io.result(ans, f"{client.url}: {ans.get('status')}")
    return 0


def cmd_info(client: Client, args: argparse.Namespace, io: Output) -> int:
    ans = client.info()
    io.result(ans, lambda: "\n".join(f"{k}: {v}" for k, v in ans.items()))
    return 0


COMMANDS: dict[str, Callable[[Client, argparse.Namespace, Output], int]] = {
    "scene": cmd_scene,
    "intersect": cmd_intersect,
    "points": cmd_points,
    "render": cmd_render,
    "trace": cmd_trace,
    "explain": cmd_explain,
    "health": cmd_health,
    "info": cmd_info,
}


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def console_main() -> None:
    """The `rcd` console script."""
    sys.exit(main(prog="rcd"))
