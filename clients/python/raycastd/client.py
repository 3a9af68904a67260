"""raycastd client: one method per endpoint, JSON in and out, binary batches without numpy.

Errors come back as RaycastdError carrying the API's stable `code`, the HTTP status, the message
and the JSON pointer of the offending input (docs/api.md, "Errors").
"""

from __future__ import annotations

import http.client
import json
import math
import struct
import urllib.parse
from dataclasses import dataclass
from typing import Any, Iterable, Sequence

Vec3 = Sequence[float]


class RaycastdError(Exception):
    """An error answer of the API."""

    def __init__(self, status: int, code: str, message: str, path: str | None) -> None:
        super().__init__(f"{status} {code}: {message}" + (f" (at {path})" if path else ""))
        self.status = status
        self.code = code
        self.message = message
        self.path = path


@dataclass
class BinaryHit:
    """One record of the binary `closest` answer; `hit` is False on a miss."""

    t: float
    object: int
    primitive: int
    u: float
    v: float
    normal: tuple[float, float, float]

    @property
    def hit(self) -> bool:
        return not math.isinf(self.t)


class Client:
    """A keep-alive connection to one raycastd server."""

    def __init__(self, base_url: str = "http://127.0.0.1:8080", timeout: float = 120.0) -> None:
        parsed = urllib.parse.urlparse(base_url)
        self._host = parsed.hostname or "127.0.0.1"
        self._port = parsed.port or 80
        self._timeout = timeout
        self._conn: http.client.HTTPConnection | None = None

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- transport ---------------------------------------------------------------------------

    def _request(
        self, method: str, path: str, body: bytes | None = None, content_type: str | None = None
    ) -> tuple[int, dict[str, str], bytes]:
        headers = {"Content-Type": content_type} if content_type else {}
        for attempt in (0, 1):  # one retry when a kept-alive connection was closed meanwhile
            if self._conn is None:
                self._conn = http.client.HTTPConnection(self._host, self._port, timeout=self._timeout)
            try:
                self._conn.request(method, path, body=body, headers=headers)
                res = self._conn.getresponse()
                data = res.read()
                return res.status, {k.lower(): v for k, v in res.getheaders()}, data
            except (ConnectionError, http.client.HTTPException):
                self.close()
                if attempt:
                    raise
        raise AssertionError("unreachable")

    def _json(self, method: str, path: str, payload: Any = None, content_type: str = "application/json") -> Any:
        body = None
        if payload is not None:
            body = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
        status, headers, data = self._request(method, path, body, content_type if body is not None else None)
        if status >= 400:
            raise _error(status, data)
        if headers.get("content-type", "").startswith("application/json"):
            return json.loads(data)
        return data.decode()

    # -- endpoints ---------------------------------------------------------------------------

    def health(self) -> dict:
        return self._json("GET", "/v1/health")

    def info(self) -> dict:
        return self._json("GET", "/v1/info")

    def intersect(self, scene: dict, rays: Iterable[dict], **options: Any) -> dict:
        """Stateless query: `scene` is a scene document, `options` mode/precision/fields."""
        return self._json("POST", "/v1/intersect", {"scene": scene, "rays": list(rays), **options})

    def explain(self, scene: dict, ray: dict, markdown: bool = False) -> Any:
        path = "/v1/explain" + ("?format=markdown" if markdown else "")
        return self._json("POST", path, {"scene": scene, "ray": ray})

    def register(self, scene: dict | bytes, content_type: str = "application/json") -> dict:
        """Registers a scene document (dict) or a model file (bytes with its content type)."""
        return self._json("POST", "/v1/scenes", scene, content_type)

    def scenes(self) -> list[dict]:
        return self._json("GET", "/v1/scenes")["scenes"]

    def scene(self, scene_id: str) -> dict:
        return self._json("GET", f"/v1/scenes/{scene_id}")

    def delete(self, scene_id: str) -> dict:
        return self._json("DELETE", f"/v1/scenes/{scene_id}")

    def query(self, scene_id: str, rays: Iterable[dict], **options: Any) -> dict:
        return self._json("POST", f"/v1/scenes/{scene_id}/intersect", {"rays": list(rays), **options})

    def query_binary(
        self,
        scene_id: str,
        rays: Sequence[tuple[Vec3, Vec3, float, float]],
        precision: str = "refined",
        dtype: str = "float64",
    ) -> list[BinaryHit]:
        """Closest hits of (origin, direction, tmin, tmax) tuples through the binary form."""
        fmt = "<8d" if dtype == "float64" else "<8f"
        body = b"".join(struct.pack(fmt, *o, *d, tmin, tmax) for o, d, tmin, tmax in rays)
        query = urllib.parse.urlencode({"mode": "closest", "precision": precision, "dtype": dtype})
        status, _, data = self._request(
            "POST", f"/v1/scenes/{scene_id}/intersect?{query}", body, "application/octet-stream"
        )
        if status >= 400:
            raise _error(status, data)
        rec = struct.Struct("<dII5d" if dtype == "float64" else "<fII5f")
        hits = []
        for t, obj, prim, u, v, nx, ny, nz in rec.iter_unpack(data):
            hits.append(BinaryHit(t, obj, prim, u, v, (nx, ny, nz)))
        return hits


def _error(status: int, data: bytes) -> RaycastdError:
    try:
        err = json.loads(data)["error"]
        return RaycastdError(status, err.get("code", "?"), err.get("message", ""), err.get("path"))
    except (ValueError, KeyError, TypeError):
        return RaycastdError(status, "?", data[:200].decode(errors="replace"), None)
