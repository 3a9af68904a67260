"""A small PNG reader and writer (standard library: zlib and struct), for grading renders.

Reads what ray tracers and image libraries write: non-interlaced PNG of colour type grey (0),
RGB (2), palette (3), grey + alpha (4) and RGBA (6), 8 or 16 bits per sample (and 1/2/4-bit
grey and palette), with any of the five row filters (PNG spec, ISO/IEC 15948 §9). Everything
is converted to 8-bit RGB: alpha is dropped (a render is opaque), 16-bit samples keep their
high byte. Interlaced (Adam7) files are refused with a clear message. Writes 8-bit RGB with
filter 0 (none) and zlib level 6.
"""

from __future__ import annotations

import struct
import zlib

SIGNATURE = b"\x89PNG\r\n\x1a\n"


class PngError(ValueError):
    """The bytes are not a PNG this reader understands; the message says why."""


class Image:
    """An 8-bit RGB image: `pixels` holds width × height × 3 bytes, rows top to bottom."""

    def __init__(self, width: int, height: int, pixels: bytes | bytearray) -> None:
        if len(pixels) != width * height * 3:
            raise ValueError(f"{len(pixels)} bytes for a {width}x{height} RGB image")
        self.width = width
        self.height = height
        self.pixels = bytes(pixels)

    def pixel(self, x: int, y: int) -> tuple[int, int, int]:
        i = 3 * (y * self.width + x)
        return self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]

    def __repr__(self) -> str:
        return f"Image({self.width}x{self.height})"


def read_png(data: bytes) -> Image:
    """Decodes a PNG file's bytes to 8-bit RGB; raises PngError on anything it cannot read."""
    if not data.startswith(SIGNATURE):
        raise PngError("not a PNG file (bad signature)")
    pos = len(SIGNATURE)
    header: tuple[int, ...] | None = None
    palette = b""
    idat = bytearray()
    while pos + 8 <= len(data):
        (length,) = struct.unpack_from(">I", data, pos)
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if len(body) != length or pos + 12 + length > len(data):
            raise PngError(f"truncated {kind.decode(errors='replace')} chunk")
        (crc,) = struct.unpack_from(">I", data, pos + 8 + length)
        if zlib.crc32(kind + body) != crc:
            raise PngError(f"bad CRC in {kind.decode(errors='replace')} chunk")
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"PLTE":
            palette = body
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
    if header is None:
        raise PngError("no IHDR chunk")
    width, height, depth, color, _, _, interlace = header
    if interlace:
        raise PngError("interlaced (Adam7) PNG is not supported; write it non-interlaced")
    channels = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}.get(color)
    if channels is None or depth not in (1, 2, 4, 8, 16) or (depth < 8 and color not in (0, 3)):
        raise PngError(f"unsupported PNG: colour type {color}, bit depth {depth}")
    if width == 0 or height == 0:
        raise PngError("PNG of zero size")
    try:
        raw = zlib.decompress(bytes(idat))
    except zlib.error as exc:
        raise PngError(f"corrupt image data: {exc}") from exc
    bits = channels * depth
    stride = (width * bits + 7) // 8
    if len(raw) < height * (stride + 1):
        raise PngError("image data shorter than the header says")
    rows = _unfilter(raw, height, stride, max(1, bits // 8))
    return Image(width, height, _to_rgb(rows, width, depth, color, palette))


def _unfilter(raw: bytes, height: int, stride: int, bpp: int) -> list[bytearray]:
    """Undoes the per-row filters (None, Sub, Up, Average, Paeth; PNG spec §9.2)."""
    rows: list[bytearray] = []
    prev = bytearray(stride)
    for y in range(height):
        start = y * (stride + 1)
        kind = raw[start]
        row = bytearray(raw[start + 1 : start + 1 + stride])
        if kind == 1:
            for i in range(bpp, stride):
                row[i] = (row[i] + row[i - bpp]) & 0xFF
        elif kind == 2:
            row = bytearray((a + b) & 0xFF for a, b in zip(row, prev))
        elif kind == 3:
            for i in range(stride):
                left = row[i - bpp] if i >= bpp else 0
                row[i] = (row[i] + ((left + prev[i]) >> 1)) & 0xFF
        elif kind == 4:
            for i in range(stride):
                a = row[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                row[i] = (row[i] + pred) & 0xFF
        elif kind != 0:
            raise PngError(f"unknown row filter {kind} in row {y}")
        rows.append(row)
        prev = row
    return rows


def _to_rgb(rows: list[bytearray], width: int, depth: int, color: int, palette: bytes) -> bytearray:
    out = bytearray()
    for row in rows:
        if depth < 8:
            per_byte = 8 // depth
            mask = (1 << depth) - 1
            samples = [
                (row[i // per_byte] >> (8 - depth * (i % per_byte + 1))) & mask
                for i in range(width)
            ]
            if color == 0:
                scale = 255 // mask
                for s in samples:
                    out += bytes((s * scale,) * 3)
            else:
                for s in samples:
                    out += _palette(palette, s)
            continue
        step = depth // 8
        hi = row[::step] if step > 1 else row  # 16-bit samples: keep the high byte
        if color == 2:
            out += hi
        elif color == 6:
            out += bytes(b for i, b in enumerate(hi) if i % 4 != 3)
        elif color == 0:
            for g in hi:
                out += bytes((g, g, g))
        elif color == 4:
            for g in hi[::2]:
                out += bytes((g, g, g))
        else:
            for s in row:
                out += _palette(palette, s)
    return out


def _palette(palette: bytes, index: int) -> bytes:
    if 3 * index + 3 > len(palette):
        raise PngError(f"palette index {index} out of range")
    return palette[3 * index : 3 * index + 3]


def write_png(image: Image) -> bytes:
    """Encodes an 8-bit RGB image as PNG bytes."""
    stride = image.width * 3
    raw = b"".join(
        b"\x00" + image.pixels[y * stride : (y + 1) * stride] for y in range(image.height)
    )

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    ihdr = struct.pack(">IIBBBBB", image.width, image.height, 8, 2, 0, 0, 0)
    return (
        SIGNATURE
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(raw, 6))
        + chunk(b"IEND", b"")
    )
