"""Shared by the client tests: the package on sys.path, a real raycastd per test class, scenes.

The server binary is `$RAYCASTD_BINARY` (ctest passes `$<TARGET_FILE:raycastd>`), else what
`raycastd.server.find_server` finds. Each test class starts its own server on a free loopback
port (`--port 0`) and stops it afterwards.
"""

from __future__ import annotations

import json
import os
import pathlib
import struct
import sys
import unittest
import zlib

HERE = pathlib.Path(__file__).resolve().parent
PACKAGE_ROOT = HERE.parent
REPO = PACKAGE_ROOT.parents[1]
sys.path.insert(0, str(PACKAGE_ROOT))

from raycastd import Client  # noqa: E402
from raycastd.server import LocalServer  # noqa: E402

EXAMPLES = REPO / "clients" / "examples"
GRADING = REPO / "clients" / "grading"
TUTORIAL7 = GRADING / "tutorial7"

TUTORIAL = {
    "objects": [
        {"type": "sphere", "center": [0, 0, 10], "radius": 2},
        {"type": "sphere", "center": [0, 3, 8], "radius": 2},
        {"type": "sphere", "center": [0, 1, 9], "radius": 2},
    ]
}
RAY = {"origin": [0, 0, 0], "direction": [0, 0, 1]}
TRIANGLE = {
    "objects": [{"type": "triangle", "name": "abc", "vertices": [[0, 0, 5], [2, 0, 5], [0, 2, 5]]}]
}

try:
    import numpy
except ImportError:  # the list paths are tested without it; NumPy tests skip
    numpy = None


class ServerTestCase(unittest.TestCase):
    """Starts one raycastd for the class: `cls.server.url`, `cls.client`."""

    server: LocalServer
    client: Client

    @classmethod
    def setUpClass(cls) -> None:
        cls.server = LocalServer(os.environ.get("RAYCASTD_BINARY") or None, ["--threads", "8"])
        cls.client = Client(cls.server.url)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.client.close()
        cls.server.close()


def red_png() -> bytes:
    """A 1×1 8-bit RGB PNG, one red texel, written by hand."""
    raw = b"\x00\xff\x00\x00"
    chunks = [
        (b"IHDR", struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)),
        (b"IDAT", zlib.compress(raw)),
        (b"IEND", b""),
    ]
    return b"\x89PNG\r\n\x1a\n" + b"".join(
        struct.pack(">I", len(c)) + t + c + struct.pack(">I", zlib.crc32(t + c)) for t, c in chunks
    )


def write_obj_with_files(
    folder: pathlib.Path, mtllib: str = "sub/tri.mtl", kd: str = "1 1 1"
) -> pathlib.Path:
    """A one-triangle OBJ (the triangle of TRIANGLE, at z = 5) with texture coordinates, whose
    material library `mtllib` (written beside it when it is sub/tri.mtl) gives it a red PNG
    texture, named with an option and Windows separators (`map_Kd -s 1 1 1 .\\tex\\red.png`,
    relative to the library: sub/tex/red.png), as exporters on Windows write them."""
    (folder / "sub" / "tex").mkdir(parents=True, exist_ok=True)
    (folder / "sub" / "tex" / "red.png").write_bytes(red_png())
    (folder / "sub" / "tri.mtl").write_text(
        f"newmtl red\nKd {kd}\nKs 0 0 0\nmap_Kd -s 1 1 1 .\\tex\\red.png\n"
    )
    path = folder / "tri.obj"
    path.write_text(
        f"mtllib {mtllib}\nv 0 0 5\nv 2 0 5\nv 0 2 5\nvt 0 0\nvt 1 0\nvt 0 1\n"
        "usemtl red\nf 1/1 2/2 3/3\n"
    )
    return path


def write_gltf_with_files(
    folder: pathlib.Path, name: str = "tri.gltf", z: float = 5.0, image_uri: str = "red.png"
) -> pathlib.Path:
    """A one-triangle glTF (the triangle of TRIANGLE, at `z`) whose positions and texture
    coordinates are a separate .bin file ("tri data.bin", named percent-encoded) and whose
    base colour is a separate 1×1 red PNG (`image_uri`), as exporters write a `.gltf`."""
    positions = struct.pack("<9f", 0, 0, z, 2, 0, z, 0, 2, z)
    uvs = struct.pack("<6f", 0, 0, 1, 0, 0, 1)
    (folder / "tri data.bin").write_bytes(positions + uvs)
    (folder / "red.png").write_bytes(red_png())
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "tri%20data.bin", "byteLength": len(positions) + len(uvs)}],
        "bufferViews": [
            {"buffer": 0, "byteLength": len(positions)},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(uvs)},
        ],
        "accessors": [
            {
                "bufferView": 0,
                "componentType": 5126,
                "count": 3,
                "type": "VEC3",
                "min": [0, 0, z],
                "max": [2, 2, z],
            },
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
        ],
        "images": [{"uri": image_uri}],
        "textures": [{"source": 0}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": 0}]}
        ],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    path = folder / name
    path.write_text(json.dumps(doc))
    return path
