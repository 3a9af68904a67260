"""Starting a local raycastd server: for grading containers (no network) and for tests.

The server binary is found, in this order: the `binary` argument; `$RAYCASTD_SERVER`;
`$RAYCASTD_BINARY` (what ctest passes); `raycastd` on `PATH` when it is a native executable (a
Python console script of that name is skipped, so an installed client can never start itself);
then next to the package: `bin/raycastd` beside the package's folder or one level up (the
layout of the Gradescope zip, `python/raycastd` + `bin/raycastd`), and the build trees when it
runs from a checkout (`build/{release,asan,debug}/server/raycastd`).
"""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import threading
from typing import Sequence

from raycastd.errors import RaycastdError

ENV_SERVER = "RAYCASTD_SERVER"


class ServerNotFound(RaycastdError):
    """No raycastd server binary was found (the message lists where it looked)."""


class ServerFailed(RaycastdError):
    """The server binary ran but did not start listening."""


def find_server(binary: str | os.PathLike[str] | None = None) -> pathlib.Path:
    """The raycastd server binary to run; raises ServerNotFound naming every place tried."""
    tried: list[str] = []
    candidates: list[tuple[str, str | None]] = [
        ("argument", str(binary) if binary else None),
        (f"${ENV_SERVER}", os.environ.get(ENV_SERVER)),
        ("$RAYCASTD_BINARY", os.environ.get("RAYCASTD_BINARY")),
    ]
    for where, value in candidates:
        if value:
            path = pathlib.Path(value)
            if _is_native(path):
                return path
            tried.append(f"{where}={value} (not an executable binary)")
    on_path = shutil.which("raycastd")
    if on_path and _is_native(pathlib.Path(on_path)):
        return pathlib.Path(on_path)
    tried.append(f"PATH ({on_path + ': a script, not the server' if on_path else 'none'})")
    here = pathlib.Path(__file__).resolve()
    beside = [here.parents[1] / "bin" / "raycastd", here.parents[2] / "bin" / "raycastd"]
    builds = [
        here.parents[3] / "build" / p / "server" / "raycastd" for p in ("release", "asan", "debug")
    ]
    for path in beside + builds:
        if _is_native(path):
            return path
        tried.append(str(path))
    raise ServerNotFound(
        "no raycastd server binary found; set $RAYCASTD_SERVER to its path. Tried: "
        + "; ".join(tried),
        code="server_not_found",
    )


def _is_native(path: pathlib.Path) -> bool:
    """An executable file that is not a script (ELF or Mach-O, not `#!`)."""
    try:
        if not (path.is_file() and os.access(path, os.X_OK)):
            return False
        with path.open("rb") as f:
            return f.read(2) != b"#!"
    except OSError:
        return False


class LocalServer:
    """A raycastd process on a free loopback port, stopped on `close()` / leaving `with`.

    `url` is set once the server prints `raycastd listening on http://HOST:PORT`. `args` are
    extra flags (`--scene-root DIR`, `--threads 4`, …). The server's stderr goes to `stderr`
    (default: discarded, so a test's output stays readable)."""

    def __init__(
        self,
        binary: str | os.PathLike[str] | None = None,
        args: Sequence[str] = (),
        *,
        start_timeout: float = 20.0,
        stderr: int | None = subprocess.DEVNULL,
    ) -> None:
        self.binary = find_server(binary)
        cmd = [str(self.binary), "--host", "127.0.0.1", "--port", "0", *args]
        self._proc = subprocess.Popen(
            cmd, stdout=subprocess.PIPE, stderr=stderr, stdin=subprocess.DEVNULL, text=True
        )
        self.url = self._await_url(start_timeout)

    def _await_url(self, timeout: float) -> str:
        assert self._proc.stdout is not None
        line: list[str] = []
        reader = threading.Thread(target=lambda: line.append(self._proc.stdout.readline()))
        reader.daemon = True
        reader.start()
        reader.join(timeout)
        text = line[0].strip() if line else ""
        if "listening on " not in text:
            self.close()
            raise ServerFailed(
                f"{self.binary} did not start within {timeout} s"
                + (f" (printed {text!r})" if text else "")
                + (f", exit status {self._proc.returncode}" if self._proc.returncode else ""),
                code="server_failed",
            )
        # The pipe stays open and unread: the server prints nothing more on stdout.
        return text.rsplit("listening on ", 1)[1]

    @property
    def pid(self) -> int:
        return self._proc.pid

    def close(self) -> None:
        """Stops the server (SIGTERM, then SIGKILL after 5 s) and reaps it."""
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(5)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        if self._proc.stdout is not None:
            self._proc.stdout.close()

    def __enter__(self) -> "LocalServer":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
