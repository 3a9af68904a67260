"""The raycastd client: one method per endpoint of the HTTP API (docs/api.md), JSON in and out.

`Client` keeps one HTTP/1.1 connection alive across calls (the server serves a keep-alive client
on one worker thread), so a grading script or a batch of binary chunks pays the TCP handshake
once. Errors are the typed exceptions of `raycastd.errors`. The array queries (`cast_rays`,
`compute_distance`, ...) come from `raycastd.arrays.ArrayQueries` and use the binary forms.
"""

from __future__ import annotations

import base64
import http.client
import json
import math
import os
import pathlib
import posixpath
import re
import select
import socket
import time
import urllib.parse
from typing import Any, Callable, Iterable, Mapping, Sequence, Union

from raycastd.arrays import ArrayQueries
from raycastd.errors import (
    ClientTimeout,
    ConnectionFailed,
    ModelLoadFailed,
    RaycastdError,
    error_from_response,
)

DEFAULT_URL = "http://127.0.0.1:8080"

#: A scene as the methods accept it: a registered id (`"sc_…"`), a scene document (dict), or a
#: file (`pathlib.Path`: a `.json` document or a model file, registered on first use).
SceneRef = Union[str, Mapping[str, Any], pathlib.Path]

#: A ray: `{"origin", "direction", "tmin"?, "tmax"?}`, `(origin, direction[, tmin, tmax])`, or six
#: numbers `ox, oy, oz, dx, dy, dz`.
RayLike = Union[Mapping[str, Any], Sequence[Any]]

#: Called with (progress in [0, 1], the job's status document) while a render job runs.
ProgressCallback = Callable[[float, dict], None]

#: The `format` of an inline mesh object (`data_base64`) for each model file extension.
MODEL_FORMATS = {
    ".glb": "glb",
    ".gltf": "gltf",
    ".obj": "obj",
    ".stl": "stl",
    ".ply": "ply",
    ".off": "off",
}

MODEL_TYPES = {
    ".json": "application/json",
    ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json",
    ".obj": "model/obj",
    ".stl": "model/stl",
    ".ply": "application/x-ply",
    ".off": "model/off",
}


class Response:
    """One HTTP answer: status, lower-case headers and the body bytes."""

    def __init__(self, status: int, headers: dict[str, str], body: bytes) -> None:
        self.status = status
        self.headers = headers
        self.body = body

    def json(self) -> Any:
        return json.loads(self.body)


class Client(ArrayQueries):
    """A keep-alive connection to one raycastd server; use it as a context manager.

    `url` defaults to `$RAYCASTD_URL`, then `http://127.0.0.1:8080`. `timeout` (seconds) bounds
    each socket operation. `token` is sent as `Authorization: Bearer …` (needed for writes when
    the server runs with `--token`). `chunk_rays` is how many rays or points one binary request
    carries. `arrays` picks what the array queries return: `"numpy"`, `"list"`, or `"auto"`
    (NumPy when it is installed).
    """

    def __init__(
        self,
        url: str | None = None,
        timeout: float = 60.0,
        token: str | None = None,
        *,
        chunk_rays: int = 1 << 18,
        arrays: str = "auto",
    ) -> None:
        self.url = (url or os.environ.get("RAYCASTD_URL") or DEFAULT_URL).rstrip("/")
        parsed = urllib.parse.urlparse(self.url)
        if parsed.scheme not in ("http", "https") or not parsed.hostname:
            raise ValueError(f"not an http(s) URL: {self.url!r}")
        self._https = parsed.scheme == "https"
        self._host = parsed.hostname
        self._port = parsed.port or (443 if self._https else 80)
        self._prefix = parsed.path.rstrip("/")
        self.timeout = timeout
        self.token = token
        self.chunk_rays = chunk_rays
        super().__init__(arrays)
        self._conn: http.client.HTTPConnection | None = None
        self._used = False  # whether the open connection has carried a request already
        self._scene_ids: dict[str, str] = {}  # registered documents and files, by content
        # The files each .gltf (by path and modification time) names: parsed once, not on every
        # call that names it.
        self._named_files: dict[str, list[pathlib.Path]] = {}
        self._obj_texts: dict[str, bytes] = {}  # an .obj's bytes, by path and modification time
        self._mtl_parses: dict[str, list[str]] = {}  # an .mtl's map_Kd names, likewise

    # -- lifecycle ---------------------------------------------------------------------------

    def close(self) -> None:
        """Closes the connection (the next call opens a new one)."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Client({self.url!r})"

    # -- transport ---------------------------------------------------------------------------

    def _connect(self) -> http.client.HTTPConnection:
        if self._conn is None:
            cls = http.client.HTTPSConnection if self._https else http.client.HTTPConnection
            self._conn = cls(self._host, self._port, timeout=self.timeout)
            self._used = False
        return self._conn

    def request(
        self,
        method: str,
        path: str,
        body: bytes | None = None,
        content_type: str | None = None,
        *,
        query: Mapping[str, Any] | None = None,
    ) -> Response:
        """Sends one request and returns the answer; raises the typed error on a 4xx/5xx."""
        target = self._prefix + path
        if query:
            target += "?" + urllib.parse.urlencode(
                {k: v for k, v in query.items() if v is not None}
            )
        headers = {"Content-Type": content_type} if content_type else {}
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        url = self.url + path
        pure = _pure(method, path)
        for attempt in (0, 1):
            conn = self._connect()
            if self._used and _dropped(conn):
                # The server closed the kept-alive connection while it sat idle (its keep-alive
                # timeout): a fresh one, before anything is sent on the old.
                self.close()
                conn = self._connect()
            reused = self._used
            reading = False  # whether the answer's head had come (the error is then in its body)
            try:
                conn.request(method, target, body=body, headers=headers)
                self._used = True
                res = conn.getresponse()
                reading = True
                data = res.read()
            except socket.timeout as exc:
                self.close()
                raise ClientTimeout(
                    f"no answer from {url} within {self.timeout} s", code="timeout", url=url
                ) from exc
            except (ConnectionError, http.client.HTTPException, OSError) as exc:
                self.close()
                # A kept-alive connection the server closed just as the request went (its idle
                # timeout, after _dropped looked) fails on first use without an answer. So does
                # one whose server had the request and then died, which cannot be told apart
                # from it here: only a pure request is sent once more (a render may have started
                # a job), and never once an answer has begun.
                stale = isinstance(
                    exc, (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError)
                )
                if attempt == 0 and reused and stale and not reading and pure:
                    continue
                # An answer cut short: behind a balancer, the replica died while writing it, and
                # the balancer cannot send the request elsewhere once it has passed the header
                # on (docs/deploy.md). A pure query is safe to ask once more.
                cut = isinstance(exc, (http.client.IncompleteRead, ConnectionResetError))
                if attempt == 0 and cut and pure:
                    continue
                raise ConnectionFailed(
                    f"cannot reach raycastd at {self.url} ({method} {path}): {exc}",
                    code="connection_failed",
                    url=url,
                ) from exc
            hdrs = {k.lower(): v for k, v in res.getheaders()}
            if res.will_close:
                self.close()
            if res.status >= 400:
                raise error_from_response(res.status, hdrs, data, url)
            return Response(res.status, hdrs, data)
        raise AssertionError("unreachable")

    def _json(
        self, method: str, path: str, payload: Any = None, *, query: Mapping[str, Any] | None = None
    ) -> Any:
        body = None if payload is None else dumps(payload)
        res = self.request(method, path, body, "application/json" if body else None, query=query)
        if res.headers.get("content-type", "").startswith("application/json"):
            return res.json()
        return res.body.decode()

    # -- scenes ------------------------------------------------------------------------------

    def add_scene(
        self, scene: Mapping[str, Any] | bytes | pathlib.Path, content_type: str | None = None
    ) -> dict:
        """Registers a scene document (dict), a file (Path: `.json` document or model) or model
        bytes (give `content_type`, else the server tells by the bytes). Returns the summary
        (`id`, `objects`, `bounds`, `warnings`, …); the same content gives the same id."""
        if isinstance(scene, pathlib.Path):
            content_type = content_type or MODEL_TYPES.get(scene.suffix.lower())
            body = scene.read_bytes()
            if content_type == "model/gltf+json":
                body = embed_gltf_files(body, scene.parent)
            elif content_type == "model/obj":
                doc = obj_document(body, scene.parent, scene.stem)
                if doc is not None:
                    body, content_type = dumps(doc), "application/json"
        elif isinstance(scene, (bytes, bytearray)):
            body = bytes(scene)
        else:
            body = dumps(scene)
            content_type = content_type or "application/json"
        res = self.request("POST", "/v1/scenes", body, content_type or "application/octet-stream")
        return res.json()

    def list_scenes(self) -> list[dict]:
        """Summaries of every registered scene."""
        return self._json("GET", "/v1/scenes")["scenes"]

    def get_scene(self, scene_id: str) -> dict:
        """The summary of one scene; NotFound (`scene_not_found`) when there is none."""
        return self._json("GET", f"/v1/scenes/{_quote(scene_id)}")

    def delete_scene(self, scene_id: str) -> dict:
        """Deletes a scene: `{"id", "deleted": true}`."""
        self._scene_ids = {k: v for k, v in self._scene_ids.items() if v != scene_id}
        return self._json("DELETE", f"/v1/scenes/{_quote(scene_id)}")

    def scene_id(self, scene: SceneRef) -> str:
        """The id of `scene`, registering a document or file the first time it is seen."""
        if isinstance(scene, str):
            return scene
        if isinstance(scene, pathlib.Path):
            key = "file:" + str(scene.resolve()) + ":" + str(scene.stat().st_mtime_ns)
            kind = MODEL_TYPES.get(scene.suffix.lower())
            if kind in ("model/gltf+json", "model/obj"):
                # The files it carries count too: an edited .bin or .mtl is a new scene.
                if kind == "model/gltf+json":
                    refs = self._named_files.get(key)
                    if refs is None:
                        refs = self._named_files[key] = gltf_files(scene.read_bytes(), scene.parent)
                else:
                    # Which libraries and textures count depends on the .mtl files too (one may
                    # appear later, or name another texture): looked up on every call, their
                    # parses cached by path and modification time.
                    obj = self._obj_texts.get(key)
                    if obj is None:
                        obj = self._obj_texts[key] = scene.read_bytes()
                    _, refs = obj_files(obj, scene.parent, self._mtl_parses)
                for f in refs:
                    key += f":{f}:{_mtime(f)}"
        else:
            key = "doc:" + json.dumps(scene, sort_keys=True)
        if key not in self._scene_ids:
            self._scene_ids[key] = self.add_scene(scene)["id"]  # type: ignore[arg-type]
        return self._scene_ids[key]

    # -- queries -----------------------------------------------------------------------------

    def intersect(
        self,
        scene: SceneRef,
        rays: Iterable[RayLike],
        mode: str | None = None,
        precision: str | None = None,
        fields: Sequence[str] | None = None,
    ) -> dict:
        """JSON intersect: `{"precision", "mode", "hits": [one per ray]}`. A scene document is
        sent inline (stateless `/v1/intersect`); an id or file queries the registered scene."""
        body: dict[str, Any] = {"rays": [ray_json(r) for r in rays]}
        _put(body, mode=mode, precision=precision, fields=list(fields) if fields else None)
        if isinstance(scene, Mapping):
            return self._json("POST", "/v1/intersect", {"scene": dict(scene), **body})
        return self._json("POST", f"/v1/scenes/{_quote(self.scene_id(scene))}/intersect", body)

    def points(
        self,
        scene: SceneRef,
        points: Iterable[Sequence[float]],
        query: str = "closest",
        max_distance: float | None = None,
    ) -> dict:
        """Closest points, distances or inside/outside of points (API.md `points`):
        `{"query", "results": [one per point]}`."""
        body: dict[str, Any] = {"points": [list(map(float, p)) for p in points], "query": query}
        _put(body, max_distance=max_distance)
        if isinstance(scene, Mapping):
            return self._json("POST", "/v1/points", {"scene": dict(scene), **body})
        return self._json("POST", f"/v1/scenes/{_quote(self.scene_id(scene))}/points", body)

    def trace(
        self,
        scene: SceneRef,
        ray: RayLike,
        max_depth: int | None = None,
        precision: str | None = None,
    ) -> dict:
        """The Whitted ray tree of one ray: `{"tree": node or null, "summary", ...}`."""
        body: dict[str, Any] = {"ray": ray_json(ray)}
        _put(body, max_depth=max_depth, precision=precision)
        return self._json("POST", f"/v1/scenes/{_quote(self.scene_id(scene))}/trace", body)

    def explain(
        self, scene: Mapping[str, Any] | pathlib.Path, ray: RayLike, markdown: bool = False
    ) -> Any:
        """The worked solution for one ray: a dict, or Markdown with LaTeX (a str).

        `scene` is a scene document (dict) or a file (Path): a `.json` document, or a model file
        (`.glb .gltf .obj .stl .ply .off`), sent inline as one mesh object (`scene_document`).
        `POST /v1/explain` takes the scene itself, so a registered id cannot be explained: a
        str raises ValueError saying so, as does a file that is not a scene."""
        if isinstance(scene, pathlib.Path):
            doc = scene_document(scene)
            if doc is None:
                raise ValueError(
                    f"{scene}: explain cannot tell the model format of a {scene.suffix or 'file'} "
                    f"file; name it {' '.join(MODEL_FORMATS)}, or pass a scene document"
                )
        elif isinstance(scene, Mapping):
            doc = dict(scene)
        elif isinstance(scene, str) and not scene.startswith("sc_"):
            raise TypeError(f"explain takes a file as a pathlib.Path: pathlib.Path({scene!r})")
        elif isinstance(scene, str):
            raise ValueError(
                f"explain takes the scene itself (a scene document or a pathlib.Path), not "
                f"{scene!r}: POST /v1/explain has no form for a registered id; pass the "
                "document or file the scene was registered from"
            )
        else:
            raise TypeError(f"explain takes a scene document or a pathlib.Path, not {scene!r}")
        query = {"format": "markdown"} if markdown else None
        return self._json("POST", "/v1/explain", {"scene": doc, "ray": ray_json(ray)}, query=query)

    # -- rendering and jobs ------------------------------------------------------------------

    def render(
        self,
        scene: SceneRef,
        width: int | None = None,
        height: int | None = None,
        spp: int | None = None,
        *,
        progress: bool | ProgressCallback = False,
        poll_s: float = 0.25,
        **options: Any,
    ) -> bytes:
        """Renders an image and returns its bytes (PNG unless `format=` says otherwise).

        `options` are the other body fields (`camera`, `sampling`, `shading`, `lighting`,
        `max_depth`, `precision`, `background`, `format`). With `progress` (True, or a callback
        taking `(fraction, job_status)`) the render runs as an async job that is polled every
        `poll_s` seconds, and cancelled if the wait is interrupted."""
        body: dict[str, Any] = {}
        _put(body, width=width, height=height, spp=spp, **options)
        path = f"/v1/scenes/{_quote(self.scene_id(scene))}/render"
        if not progress:
            return self.request("POST", path, dumps(body), "application/json").body
        callback = progress if callable(progress) else None
        job = self._json("POST", path, {**body, "async": True})["job"]
        try:
            self.wait_job(job, callback, poll_s)
        except BaseException:
            try:
                self.cancel_job(job)
            except RaycastdError:
                pass
            raise
        return self.job_image(job)

    def job(self, job_id: str) -> dict:
        """A job's status: `state`, `progress` (0..1), `eta_s`, `elapsed_s`, …"""
        return self._json("GET", f"/v1/jobs/{_quote(job_id)}")

    def job_image(self, job_id: str) -> bytes:
        """The image of a finished job (raises while it is not done)."""
        res = self.request("GET", f"/v1/jobs/{_quote(job_id)}/image")
        if res.status == 202:
            raise RaycastdError(f"job {job_id} is not done yet", code="job_not_done", status=202)
        return res.body

    def cancel_job(self, job_id: str) -> dict:
        """Cancels a queued or running job, or forgets a finished one."""
        return self._json("DELETE", f"/v1/jobs/{_quote(job_id)}")

    def wait_job(
        self, job_id: str, progress: ProgressCallback | None = None, poll_s: float = 0.25
    ) -> dict:
        """Polls a job until it is done; raises RaycastdError when it failed or was cancelled."""
        while True:
            status = self.job(job_id)
            if progress is not None:
                progress(float(status.get("progress") or 0.0), status)
            state = status.get("state")
            if state == "done":
                return status
            if state in ("failed", "cancelled"):
                err = status.get("error") or {}
                raise RaycastdError(
                    err.get("message", f"job {job_id} {state}")
                    if isinstance(err, dict)
                    else str(err),
                    code=err.get("code", f"job_{state}")
                    if isinstance(err, dict)
                    else f"job_{state}",
                )
            time.sleep(poll_s)

    # -- server ------------------------------------------------------------------------------

    def health(self) -> dict:
        """`{"status": "ok"}`."""
        return self._json("GET", "/v1/health")

    def info(self) -> dict:
        """Version, Embree version, threads, limits, scenes and memory."""
        return self._json("GET", "/v1/info")


def ray_json(ray: RayLike) -> dict:
    """A ray in the JSON form of the API from any `RayLike`."""
    if isinstance(ray, Mapping):
        return dict(ray)
    items = list(ray)
    if len(items) in (6, 8) and all(isinstance(v, (int, float)) for v in items):
        out: dict[str, Any] = {"origin": items[0:3], "direction": items[3:6]}
        if len(items) == 8:
            out["tmin"], out["tmax"] = items[6], items[7]
    elif len(items) in (2, 3, 4):
        out = {"origin": list(items[0]), "direction": list(items[1])}
        if len(items) >= 3:
            out["tmin"] = items[2]
        if len(items) == 4:
            out["tmax"] = items[3]
    else:
        raise ValueError(f"not a ray: {ray!r}")
    if out.get("tmax") == math.inf:  # JSON cannot carry inf; the server's default is +inf
        del out["tmax"]
    return out


def dumps(value: Any) -> bytes:
    """JSON bytes of `value`; NumPy arrays and scalars are written as lists and numbers."""
    return json.dumps(value, default=_plain).encode()


def _plain(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def _put(body: dict[str, Any], **fields: Any) -> None:
    body.update({k: v for k, v in fields.items() if v is not None})


# The requests that change nothing on the server (API.md): GETs, the queries, and registration,
# whose id is the content's hash (a second post answers 200 with the same id). The same set as
# deploy/nginx.conf's retried locations.
_PURE_POST = re.compile(
    r"^/v1/(intersect|explain|points|scenes|scenes/[A-Za-z0-9_]+/(intersect|trace|points))$"
)


def _inside(folder: pathlib.Path, path: pathlib.Path) -> bool:
    """Whether `path`, symlinks resolved, is `folder` or lies inside it."""
    root, resolved = folder.resolve(), path.resolve()
    return root == resolved or root in resolved.parents


def _gltf_file(folder: pathlib.Path, uri: str, where: str) -> pathlib.Path:
    """The file a glTF `uri` names beside the `.gltf` in `folder`: a relative reference,
    percent-decoded byte by byte (glTF 2.0 §3.2, as the server decodes it). One with a scheme
    (`file:`, `http:`), a host or an absolute path, or one that climbs out of the folder, is
    refused (ModelLoadFailed at `where`), as the server refuses them in its scene root: packing a
    `.gltf` must not send a file from elsewhere on this machine."""
    parts = urllib.parse.urlsplit(uri)
    relative = os.fsdecode(urllib.parse.unquote_to_bytes(parts.path))
    if parts.scheme or parts.netloc or not relative or pathlib.PurePath(relative).is_absolute():
        raise ModelLoadFailed(
            f"the glTF file names {uri!r}: only a file beside it (a relative reference) can be "
            "sent with it",
            code="model_load_failed",
            path=where,
        )
    path = folder / relative
    if not _inside(folder, path):
        raise ModelLoadFailed(
            f"the glTF file names {uri!r}, outside its folder {folder}",
            code="model_load_failed",
            path=where,
        )
    return path


def _gltf_doc(gltf: bytes) -> dict | None:
    try:
        doc = json.loads(gltf)
    except ValueError:
        return None  # not JSON: the server says what is wrong with it
    return doc if isinstance(doc, dict) else None


def _gltf_references(doc: dict):
    """(kind, index, entry, uri) of each buffer and image that names something by `uri`, other
    than a data URI."""
    for kind in ("buffers", "images"):
        entries = doc.get(kind)
        if not isinstance(entries, list):
            continue
        for i, entry in enumerate(entries):
            uri = entry.get("uri") if isinstance(entry, dict) else None
            if isinstance(uri, str) and not uri.startswith("data:"):
                yield kind, i, entry, uri


def gltf_files(gltf: bytes, folder: pathlib.Path) -> list[pathlib.Path]:
    """The files beside a `.gltf` that embed_gltf_files would carry (for a cache key)."""
    doc = _gltf_doc(gltf)
    out = []
    for kind, i, _, uri in _gltf_references(doc) if doc else ():
        out.append(_gltf_file(folder, uri, f"{kind}[{i}].uri"))
    return out


def _image_media_type(data: bytes) -> str | None:
    """PNG or JPEG by the file's signature: the data URI prefixes the server's glTF reader takes
    for images (tinygltf's: image/png, image/jpeg); None for anything else."""
    if data.startswith(b"\x89PNG\r\n\x1a\n"):
        return "image/png"
    if data.startswith(b"\xff\xd8\xff"):
        return "image/jpeg"
    return None


def embed_gltf_files(gltf: bytes, folder: pathlib.Path, images: bool = True) -> bytes:
    """A `.gltf` whose buffers or images are files beside it, with those files carried inside
    it as base64 data URIs (glTF 2.0 §3.6.1.1, §3.8.4.2): the server takes only self-contained
    uploads (a model's `uri`s are read inside its scene root alone, docs/api.md). A file that
    refers to nothing outside itself is returned as it is.

    A buffer that cannot be read, or a `uri` that is not a relative reference inside the
    `.gltf`'s folder, raises ModelLoadFailed (no status: the client's own) naming it
    (`buffers[0].uri`). An image that cannot be read, or is neither PNG nor JPEG, is left as it
    is named: the server then warns that it cannot read it and uses the material's colour
    alone, as it does for any image it cannot decode. The encoded file is about 4/3 of the files'
    size, which the server's --max-body-mb bounds. With `images=False` only the buffers are
    carried (for the stateless queries, whose scenes decode no texture)."""
    doc = _gltf_doc(gltf)
    if doc is None:
        return gltf
    changed = False
    read: dict[pathlib.Path, bytes] = {}  # a file named twice is read once
    for kind, i, entry, uri in list(_gltf_references(doc)):
        if kind == "images" and not images:
            continue
        where = f"{kind}[{i}].uri"
        path = _gltf_file(folder, uri, where)
        if path not in read:
            try:
                read[path] = path.read_bytes()
            except OSError as exc:
                if kind == "images":
                    continue
                raise ModelLoadFailed(
                    f"the glTF file names {uri!r}, which cannot be read at {path}: "
                    f"{exc.strerror or exc}",
                    code="model_load_failed",
                    path=where,
                ) from exc
        data = read[path]
        if kind == "buffers":
            media = "application/octet-stream"
        else:
            media = _image_media_type(data)
            if media is None:
                continue
        entry["uri"] = f"data:{media};base64," + base64.b64encode(data).decode("ascii")
        changed = True
    return json.dumps(doc, separators=(",", ":")).encode() if changed else gltf


# How the server reads an OBJ and its MTL (engine/load/obj_reader.cpp, text_scan.h), so that the
# client carries exactly the files the server will ask for: lines end at \r, \n or \r\n; in an
# OBJ a backslash at the end of a line joins the next one (with a space); '#' starts a comment,
# except in a map_Kd line, whose file name may hold one; words are separated by ASCII blanks
# only.
_LINE_ENDS = re.compile(r"\r\n|\r|\n")
_BLANKS = re.compile(r"[ \t\v\f]+")
_BLANK_CHARS = " \t\v\f"
# A number as std::from_chars reads one, after the server's parse_double drops one leading '+'.
_DECIMAL = re.compile(r"-?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)
# RFC 3986 §3.1's scheme, or a drive letter: refused by the server (check_resource_uri).
_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:")
# map_Kd options and how many arguments each takes (obj_reader.cpp's table); -o, -s and -t
# take up to three numbers.
_MTL_OPTION_ARITY = {
    "-blendu": 1,
    "-blendv": 1,
    "-boost": 1,
    "-mm": 2,
    "-texres": 1,
    "-clamp": 1,
    "-bm": 1,
    "-imfchan": 1,
    "-cc": 1,
    "-type": 1,
}


def _statements(text: str, continued: bool) -> list[str]:
    lines = _LINE_ENDS.split(text)
    if not continued:
        return lines
    out, i = [], 0
    while i < len(lines):
        line, i = lines[i], i + 1
        if not line.endswith("\\"):
            out.append(line)
            continue
        parts = [line[:-1]]
        while i < len(lines):
            more, i = lines[i], i + 1
            parts.append(more[:-1] if more.endswith("\\") else more)
            if not more.endswith("\\"):
                break
        out.append(" ".join(parts))
    return out


def _tokens(line: str, comments: bool = True) -> list[str]:
    return [t for t in _BLANKS.split(line.split("#", 1)[0] if comments else line) if t]


def _rest_of_line(line: str, keyword: str) -> str:
    rest = line[line.find(keyword) + len(keyword) :]
    return rest.split("#", 1)[0].strip(_BLANK_CHARS)


def _is_number(token: str) -> bool:
    """Whether map_Kd's -o, -s and -t take `token` as a number: parse_double reads it (one
    leading '+' dropped, then std::from_chars, which refuses a value out of double's range) and
    it is finite."""
    if token.startswith("+"):
        token = token[1:]
    if _DECIMAL.fullmatch(token) is None:
        return False
    value = float(token)
    mantissa = re.split("[eE]", token)[0]
    underflow = value == 0.0 and re.search("[1-9]", mantissa) is not None
    return math.isfinite(value) and not underflow


def obj_libraries(obj: bytes) -> list[list[str]]:
    """The material libraries an OBJ names, one list per `mtllib` statement: the whole
    argument first (a name with spaces), then each word when there are several, as the server
    tries them (it takes the whole argument if it reads, else every word that reads). Windows
    separators are turned into '/' and one leading './' dropped, as the server does."""
    out = []
    for line in _statements(obj.decode("utf-8", "replace"), continued=True):
        t = _tokens(line)
        if len(t) < 2 or t[0] != "mtllib":
            continue
        names = [_rest_of_line(line, "mtllib")] + (t[1:] if len(t) > 2 else [])
        fixed = []
        for name in names:
            name = name.replace("\\", "/")
            fixed.append(name[2:] if name.startswith("./") else name)
        out.append(fixed)
    return out


def mtl_textures(mtl: str) -> list[str]:
    """The `map_Kd` file names of an MTL (the maps the server samples), relative to the MTL,
    as the server parses them: options skipped by its table, the rest of the words joined by
    a space ('#' included), Windows separators turned into '/', leading './' dropped."""
    out = []
    for line in _statements(mtl, continued=False):
        t = _tokens(line)
        if not t or t[0] != "map_Kd":
            continue
        t = _tokens(line, comments=False)  # its first word is map_Kd: no comment cuts it
        if len(t) < 2:
            continue
        i = 1
        while i < len(t) and len(t[i]) > 1 and t[i][0] == "-":
            opt = t[i]
            i += 1
            if opt in ("-o", "-s", "-t"):
                k = 0
                while k < 3 and i < len(t) and _is_number(t[i]):
                    i, k = i + 1, k + 1
                continue
            if opt not in _MTL_OPTION_ARITY:
                i -= 1
                break  # not an option after all: part of the file name
            i += _MTL_OPTION_ARITY[opt]
        name = " ".join(t[i:]).replace("\\", "/")
        while name.startswith("./"):
            name = name[2:]
        if name:
            out.append(name)
    return out


def _beside(folder: pathlib.Path, name: str) -> tuple[str, pathlib.Path] | None:
    """`name` (relative to the OBJ) normalised as the server normalises a path ("a/./b/../c" is
    "a/c"), and the file it is inside `folder`; None for a name the server would refuse or that
    leaves the folder (absolute, a scheme or drive, a climb out, also through a symlink)."""
    if not name or name.startswith("/") or _SCHEME.match(name) or "\0" in name:
        return None
    key = posixpath.normpath(name)
    if key == ".." or key.startswith("../") or key.startswith("/"):
        return None
    path = folder / key
    return (key, path) if _inside(folder, path) else None


def _mtime(path: pathlib.Path) -> int:
    try:
        return path.stat().st_mtime_ns
    except OSError:
        return -1


def obj_files(
    obj: bytes, folder: pathlib.Path, parsed: dict | None = None
) -> tuple[dict[str, pathlib.Path], list[pathlib.Path]]:
    """The files beside an OBJ in `folder` that the server will ask for, as
    ({name relative to the OBJ, normalised: file}, every file looked for): the material
    libraries its `mtllib` statements name, chosen as the server chooses them, and the PNG or
    JPEG `map_Kd` textures those name. A file that is absent, unreadable, out of the folder, or
    an image of another kind (which the server cannot decode) is not carried; the server then
    warns that it cannot read it. The second list, present or not, keys a cache (an .mtl that
    appears later, or names another texture, is a new scene). `parsed` caches MTL parses by
    path and modification time."""
    parsed = {} if parsed is None else parsed
    carried: dict[str, pathlib.Path] = {}
    looked: list[pathlib.Path] = []
    for names in obj_libraries(obj):
        readable = []
        for name in names:
            found = _beside(folder, name)
            if found is None:
                continue
            looked.append(found[1])
            if found[1].is_file() and os.access(found[1], os.R_OK):
                readable.append((name, found))
        # The whole argument when it reads, else every word that does.
        chosen = readable[:1] if readable and readable[0][0] == names[0] else readable
        for name, (key, path) in chosen:
            stamp = f"{path}:{_mtime(path)}"
            textures = parsed.get(stamp)
            if textures is None:
                try:
                    textures = parsed[stamp] = mtl_textures(path.read_text("utf-8", "replace"))
                except OSError:
                    continue
            carried[key] = path
            mtl_dir = name[: name.rfind("/") + 1]
            for texture in textures:
                found = _beside(folder, mtl_dir + texture)
                if found is None:
                    continue
                looked.append(found[1])
                try:
                    with open(found[1], "rb") as f:
                        head = f.read(8)
                except OSError:
                    continue
                if _image_media_type(head) is not None:
                    carried[found[0]] = found[1]
    return carried, looked


def obj_document(obj: bytes, folder: pathlib.Path, name: str) -> dict | None:
    """An OBJ and the files beside it that the server will ask for (obj_files) as a scene
    document of one inline mesh object carrying them in `files`; None when there are none (it
    is then sent as it is). The server reads no file an upload names, so an OBJ's .mtl and
    textures travel this way. A file that turns unreadable meanwhile is left out, as an absent
    one is: the server warns that it cannot read it."""
    files, _ = obj_files(obj, folder)
    carried = {}
    for key, path in files.items():
        try:
            carried[key] = base64.b64encode(path.read_bytes()).decode("ascii")
        except OSError:
            continue
    if not carried:
        return None
    mesh = {
        "type": "mesh",
        "name": name,
        "format": "obj",
        "data_base64": base64.b64encode(obj).decode("ascii"),
        "files": carried,
    }
    return {"objects": [mesh]}


def scene_document(path: pathlib.Path) -> dict | None:
    """A file as a scene document that the stateless queries (`/v1/intersect`, `/v1/points`,
    `/v1/explain`) carry inline, so that nothing is registered: a `.json` file is the document
    it holds (ValueError when it is not JSON or not an object); a model file
    (`.glb .gltf .obj .stl .ply .off`) is one inline mesh object named after the file
    (`data_base64`), a `.gltf` with the buffers beside it embedded (embed_gltf_files; images are
    left out, as those scenes decode none) and an `.obj` with its material libraries and
    textures in `files` (obj_document). A glTF is then one object, as a `mesh` object of a
    document is, where registering the file makes one object per mesh instance. None for an
    extension that tells no format (the server tells those by their bytes only on
    registration). OSError when the file cannot be read."""
    suffix = path.suffix.lower()
    if suffix == ".json":
        try:
            doc = json.loads(path.read_bytes())
        except ValueError as exc:
            raise ValueError(f"{path}: not a JSON scene document ({exc})") from None
        if not isinstance(doc, dict):
            raise ValueError(f"{path}: a scene document is a JSON object, not {type(doc).__name__}")
        return doc
    fmt = MODEL_FORMATS.get(suffix)
    if fmt is None:
        return None
    body = path.read_bytes()
    if fmt == "obj":
        doc = obj_document(body, path.parent, path.stem)
        if doc is not None:
            return doc
    elif fmt == "gltf":
        body = embed_gltf_files(body, path.parent, images=False)
    mesh = {
        "type": "mesh",
        "name": path.stem,
        "format": fmt,
        "data_base64": base64.b64encode(body).decode("ascii"),
    }
    return {"objects": [mesh]}


def _dropped(conn: http.client.HTTPConnection) -> bool:
    """Whether the server has closed (or written unasked on) a connection kept alive between
    requests: its socket is readable with nothing asked. As urllib3 checks a pooled connection
    before it reuses it, with poll() where there is one (select() takes no descriptor past
    1023)."""
    sock = conn.sock
    if sock is None:
        return False  # not connected yet: http.client connects on the request
    if sock.fileno() < 0:
        return True  # closed under us
    if hasattr(select, "poll"):
        poller = select.poll()
        poller.register(sock, select.POLLIN)
        return bool(poller.poll(0))
    readable, _, _ = select.select([sock], [], [], 0)
    return bool(readable)


def _pure(method: str, path: str) -> bool:
    return method in ("GET", "HEAD") or (method == "POST" and _PURE_POST.match(path) is not None)


def _quote(part: str) -> str:
    return urllib.parse.quote(part, safe="")
