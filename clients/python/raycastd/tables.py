"""Reading and writing tables of numbers: CSV and NumPy's `.npy`, with or without NumPy.

Used for `--rays FILE` on the command line and for a student program's output in grading. A
table is a list of rows of floats. CSV cells may be empty or `inf`/`miss`/`none` (read as +inf:
a ray that hits nothing) and a first row that is not numeric is taken as a header. The `.npy`
reader follows the format's specification (version 1–3 headers) for little- and big-endian
float, int and bool arrays in C or Fortran order, so a student's `numpy.save` output is read
even where NumPy is not installed.
"""

from __future__ import annotations

import ast
import csv
import io
import math
import pathlib
import struct
from typing import Sequence

MISS_WORDS = {"", "inf", "+inf", "infinity", "miss", "none", "null", "nan"}


class TableError(ValueError):
    """A file that is not a table of numbers; the message names the file and the place."""


def read_table(path: str | pathlib.Path, blank_rows: bool = False) -> list[list[float]]:
    """Rows of floats from a `.npy` or a CSV/text file (1-D `.npy`: one value a row).
    `blank_rows`: a blank line of a text file is an empty row instead of being skipped."""
    path = pathlib.Path(path)
    data = path.read_bytes()
    if path.suffix.lower() == ".npy" or data.startswith(b"\x93NUMPY"):
        return read_npy(data, str(path))
    return read_csv(data.decode("utf-8-sig", errors="replace"), str(path), blank_rows)


def read_csv(text: str, name: str = "<csv>", blank_rows: bool = False) -> list[list[float]]:
    """Rows of floats from CSV text (commas, or whitespace when a line has no comma). A blank
    line is skipped, or with `blank_rows` an empty row; a `#` line is a comment; a first line
    that is not numbers is a header."""
    rows: list[list[float]] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            if blank_rows:
                rows.append([])
            continue
        if line.lstrip().startswith("#"):
            continue
        cells = next(csv.reader([line])) if "," in line else line.split()
        try:
            rows.append([_cell(c) for c in cells])
        except ValueError:
            if lineno == _first_line(text):
                continue  # a header row
            raise TableError(f"{name}:{lineno}: not a number in {line.strip()!r}") from None
    return rows


def _first_line(text: str) -> int:
    for lineno, line in enumerate(text.splitlines(), 1):
        if line.strip() and not line.lstrip().startswith("#"):
            return lineno
    return 0


def _cell(text: str) -> float:
    t = text.strip().lower()
    if t in MISS_WORDS:
        return math.inf
    return float(t)


def read_npy(data: bytes, name: str = "<npy>") -> list[list[float]]:
    """Rows of floats from the bytes of a `.npy` file of 1 or 2 dimensions."""
    if not data.startswith(b"\x93NUMPY") or len(data) < 10:
        raise TableError(f"{name}: not a .npy file")
    major = data[6]
    if major == 1:
        (hlen,) = struct.unpack_from("<H", data, 8)
        start = 10
    else:
        (hlen,) = struct.unpack_from("<I", data, 8)
        start = 12
    try:
        header = ast.literal_eval(data[start : start + hlen].decode("latin1"))
        descr, fortran, shape = header["descr"], header["fortran_order"], tuple(header["shape"])
    except (ValueError, SyntaxError, KeyError, TypeError) as exc:
        raise TableError(f"{name}: unreadable .npy header ({exc})") from None
    codes = {"f4": "f", "f8": "d", "i4": "i", "i8": "q", "u4": "I", "u8": "Q", "b1": "?", "f2": "e"}
    if not isinstance(descr, str) or descr[1:] not in codes or descr[0] not in "<>|=":
        raise TableError(f"{name}: .npy of dtype {descr!r} is not a table of numbers")
    if len(shape) not in (1, 2):
        raise TableError(f"{name}: .npy of shape {shape}; expected 1 or 2 dimensions")
    n = math.prod(shape)
    endian = ">" if descr[0] == ">" else "<"
    fmt = f"{endian}{n}{codes[descr[1:]]}"
    body = data[start + hlen :]
    if len(body) < struct.calcsize(fmt):
        raise TableError(f"{name}: .npy data shorter than its shape {shape}")
    flat = [float(v) for v in struct.unpack_from(fmt, body)]
    if len(shape) == 1:
        return [[v] for v in flat]
    rows, cols = shape
    if fortran:
        return [[flat[c * rows + r] for c in range(cols)] for r in range(rows)]
    return [flat[r * cols : (r + 1) * cols] for r in range(rows)]


def write_table(
    path: str | pathlib.Path, rows: Sequence[Sequence[float]], header: str = ""
) -> None:
    """Writes rows as `.npy` (float64, 2-D) or CSV by the file's extension. In CSV an int (an
    id, a count) is written as an integer (`2`, `-1`), a float as the shortest text that reads
    back to it, and an infinite float as `inf`."""
    path = pathlib.Path(path)
    if path.suffix.lower() == ".npy":
        path.write_bytes(npy_bytes(rows))
        return
    buf = io.StringIO()
    if header:
        buf.write(header + "\n")
    for row in rows:
        buf.write(",".join(_csv_cell(v) for v in row) + "\n")
    path.write_text(buf.getvalue())


def _csv_cell(v: float) -> str:
    if isinstance(v, int) or (hasattr(v, "dtype") and v.dtype.kind in "iub"):
        return str(int(v))
    return repr(float(v)) if math.isfinite(v) else "inf"


def npy_bytes(rows: Sequence[Sequence[float]]) -> bytes:
    """A version-1 `.npy` file of float64 holding `rows` (all of one length)."""
    cols = len(rows[0]) if rows else 0
    header = repr({"descr": "<f8", "fortran_order": False, "shape": (len(rows), cols)})
    pad = 64 - (10 + len(header) + 1) % 64
    head = (header + " " * pad + "\n").encode("latin1")
    flat = [float(v) for row in rows for v in row]
    return (
        b"\x93NUMPY\x01\x00"
        + struct.pack("<H", len(head))
        + head
        + struct.pack(f"<{len(flat)}d", *flat)
    )
