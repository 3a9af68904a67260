"""The stdlib PNG reader/writer and the CSV/.npy tables (no server needed)."""

from __future__ import annotations

import io
import pathlib
import struct
import tempfile
import unittest
import zlib

from support import numpy

from raycastd.png import Image, PngError, read_png, write_png
from raycastd.tables import TableError, npy_bytes, read_csv, read_npy, read_table, write_table


def png(
    width: int,
    height: int,
    color: int,
    depth: int,
    rows: list[bytes],
    extra: bytes = b"",
    interlace: int = 0,
) -> bytes:
    """A PNG whose rows (filter byte included) are given as they are to be stored."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, depth, color, 0, 0, interlace)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + extra
        + chunk(b"IDAT", zlib.compress(b"".join(rows)))
        + chunk(b"IEND", b"")
    )


def filtered(kind: int, raw: list[bytes], bpp: int) -> list[bytes]:
    """Rows encoded with one PNG filter (spec §9.2), to check the reader undoes each."""
    out, prev = [], bytes(len(raw[0]))
    for row in raw:
        enc = bytearray()
        for i, x in enumerate(row):
            a = row[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if kind == 0:
                pred = 0
            elif kind == 1:
                pred = a
            elif kind == 2:
                pred = b
            elif kind == 3:
                pred = (a + b) >> 1
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            enc.append((x - pred) & 0xFF)
        out.append(bytes([kind]) + bytes(enc))
        prev = row
    return out


class PngTest(unittest.TestCase):
    RAW = [
        bytes((x * 37 + y * 11 + c * 5) & 0xFF for x in range(5) for c in range(3))
        for y in range(4)
    ]

    def test_round_trip(self) -> None:
        img = Image(5, 4, b"".join(self.RAW))
        back = read_png(write_png(img))
        self.assertEqual((back.width, back.height, back.pixels), (5, 4, img.pixels))
        self.assertEqual(back.pixel(1, 0), tuple(self.RAW[0][3:6]))

    def test_every_filter(self) -> None:
        for kind in range(5):
            img = read_png(png(5, 4, 2, 8, filtered(kind, self.RAW, 3)))
            self.assertEqual(img.pixels, b"".join(self.RAW), f"filter {kind}")

    def test_rgba_grey_palette_16_bit(self) -> None:
        rgba = [bytes([0, 10, 20, 30, 255, 40, 50, 60, 0]) for _ in range(2)]  # filter 0, 2 px RGBA
        self.assertEqual(
            read_png(png(2, 2, 6, 8, rgba)).pixels, bytes([10, 20, 30, 40, 50, 60]) * 2
        )
        self.assertEqual(
            read_png(png(2, 1, 0, 8, [b"\x00\x07\x09"])).pixels, bytes([7, 7, 7, 9, 9, 9])
        )
        plte = struct.pack(">I", 6) + b"PLTE" + bytes([1, 2, 3, 4, 5, 6])
        plte += struct.pack(">I", zlib.crc32(b"PLTE" + bytes([1, 2, 3, 4, 5, 6])))
        self.assertEqual(
            read_png(png(2, 1, 3, 8, [b"\x00\x01\x00"], plte)).pixels, bytes([4, 5, 6, 1, 2, 3])
        )
        self.assertEqual(
            read_png(png(2, 1, 3, 1, [b"\x00\x40"], plte)).pixels, bytes([1, 2, 3, 4, 5, 6])
        )
        wide = b"\x00" + bytes([200, 1, 100, 2, 50, 3])
        self.assertEqual(read_png(png(1, 1, 2, 16, [wide])).pixels, bytes([200, 100, 50]))

    def test_refuses_what_it_cannot_read(self) -> None:
        good = write_png(Image(1, 1, b"\x01\x02\x03"))
        for data, message in (
            (b"GIF89a", "bad signature"),
            (good[:-20], "truncated"),
            (good[:20] + bytes([good[20] ^ 1]) + good[21:], "bad CRC"),
            (png(1, 1, 2, 8, [b"\x00\x01\x02\x03"], interlace=1), "interlaced"),
            (png(1, 1, 2, 8, [b"\x07\x01\x02\x03"]), "unknown row filter 7"),
        ):
            with self.assertRaises(PngError) as cm:
                read_png(data)
            self.assertIn(message, str(cm.exception))


class TablesTest(unittest.TestCase):
    def test_csv(self) -> None:
        rows = read_csv("t\n7.5\n\ninf\nmiss\n# comment\n1e3, 2\n3 4\n")
        self.assertEqual(rows, [[7.5], [float("inf")], [float("inf")], [1000.0, 2.0], [3.0, 4.0]])
        with self.assertRaises(TableError) as cm:
            read_csv("1\nseven\n", "t.csv")
        self.assertIn("t.csv:2", str(cm.exception))

    def test_npy_without_numpy(self) -> None:
        data = npy_bytes([[1.0, 2.0], [3.0, float("inf")]])
        self.assertEqual(read_npy(data), [[1.0, 2.0], [3.0, float("inf")]])
        with self.assertRaises(TableError):
            read_npy(b"\x93NUMPY\x01\x00" + struct.pack("<H", 10) + b"{'a': 1}\n ")
        with tempfile.TemporaryDirectory() as tmp:
            for name in ("x.csv", "x.npy"):
                path = pathlib.Path(tmp) / name
                write_table(path, [[1.5, float("inf")]], "a,b")
                self.assertEqual(read_table(path), [[1.5, float("inf")]])

    @unittest.skipIf(numpy is None, "NumPy is not installed")
    def test_npy_written_by_numpy(self) -> None:
        np = numpy
        for arr in (
            np.arange(6, dtype=np.float32).reshape(3, 2),
            np.asfortranarray(np.arange(6.0).reshape(2, 3)),
            np.array([1, 2, 3], dtype=">i4"),
            np.array([True, False]),
        ):
            buf = io.BytesIO()
            np.save(buf, arr)
            want = arr.reshape(len(arr), -1).astype(float).tolist()
            self.assertEqual(read_npy(buf.getvalue()), want)
        self.assertEqual(np.load(io.BytesIO(npy_bytes([[1.0, 2.0]]))).tolist(), [[1.0, 2.0]])


if __name__ == "__main__":
    unittest.main()
