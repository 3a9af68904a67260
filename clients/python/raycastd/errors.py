"""Typed errors of the raycastd API (docs/api.md, "Errors").

Every error answer of the server becomes one exception whose class follows the HTTP status
family, and which carries the API's stable `code`, the human `message`, the JSON pointer `path`
of the offending input (or None), the HTTP `status` and the `request_id` from `X-Request-Id`.
A server that cannot be reached at all is a `ConnectionFailed` naming the URL that was tried.
"""

from __future__ import annotations

import json


class RaycastdError(Exception):
    """Base class of every error raised by the client."""

    def __init__(
        self,
        message: str,
        *,
        code: str = "error",
        status: int | None = None,
        path: str | None = None,
        request_id: str | None = None,
        url: str | None = None,
    ) -> None:
        self.code = code
        self.message = message
        self.status = status
        self.path = path
        self.request_id = request_id
        self.url = url
        super().__init__(str(self))

    def __str__(self) -> str:
        head = f"{self.status} {self.code}" if self.status else self.code
        text = f"{head}: {self.message}"
        if self.path:
            text += f" (at {self.path})"
        if self.request_id:
            text += f" [request {self.request_id}]"
        return text


class ConnectionFailed(RaycastdError):
    """The server could not be reached (refused, reset, DNS, TLS); `url` is the one tried."""


class ClientTimeout(ConnectionFailed):
    """The server did not answer within the client's timeout."""


class ClientError(RaycastdError):
    """A 4xx answer: the request was wrong."""


class BadRequest(ClientError):
    """400: bad_json, invalid_scene, invalid_ray, invalid_request, unsupported_format."""


class Unauthorized(ClientError):
    """401 unauthorized: a write without the server's bearer token."""


class NotFound(ClientError):
    """404: scene_not_found, job_not_found, or not_found (no such endpoint)."""


class MethodNotAllowed(ClientError):
    """405 method_not_allowed."""


class TooLarge(ClientError):
    """413/414 too_large: body, rays, pixels, triangles or URL over the server's limits."""


class ModelLoadFailed(ClientError):
    """422 model_load_failed: the model parsed but is not usable."""


class ServerError(RaycastdError):
    """A 5xx answer: the server could not do the work."""


class Busy(ServerError):
    """503 busy or timeout; `retry_after` is the server's Retry-After in seconds, if given."""

    def __init__(self, message: str, *, retry_after: float | None = None, **kw: object) -> None:
        self.retry_after = retry_after
        super().__init__(message, **kw)  # type: ignore[arg-type]


class InsufficientStorage(ServerError):
    """507 insufficient_storage: nothing was registered or deleted."""


class InternalError(ServerError):
    """500 internal (a server bug, logged under the request id)."""


_BY_STATUS: dict[int, type[RaycastdError]] = {
    400: BadRequest,
    401: Unauthorized,
    404: NotFound,
    405: MethodNotAllowed,
    413: TooLarge,
    414: TooLarge,
    422: ModelLoadFailed,
    500: InternalError,
    503: Busy,
    507: InsufficientStorage,
}


def error_from_response(
    status: int, headers: dict[str, str], body: bytes, url: str
) -> RaycastdError:
    """The exception for one error answer; `headers` has lower-case names."""
    code, message, path = "http_error", "", None
    try:
        err = json.loads(body)["error"]
        code = str(err.get("code", code))
        message = str(err.get("message", ""))
        path = err.get("path")
    except (ValueError, KeyError, TypeError):
        message = body[:300].decode(errors="replace").strip() or f"HTTP {status}"
    cls = _BY_STATUS.get(status) or (ServerError if status >= 500 else ClientError)
    kw: dict[str, object] = {
        "code": code,
        "status": status,
        "path": path,
        "request_id": headers.get("x-request-id"),
        "url": url,
    }
    if cls is Busy:
        retry = headers.get("retry-after")
        try:
            kw["retry_after"] = float(retry) if retry is not None else None
        except ValueError:
            kw["retry_after"] = None
    return cls(message, **kw)  # type: ignore[arg-type]
