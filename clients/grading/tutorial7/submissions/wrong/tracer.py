#!/usr/bin/env python3
"""A student's tiny ray tracer with the classic sphere bug: it takes the larger root of the
quadratic (where the ray leaves the sphere) instead of the smaller one, so its t values are too
large and its picture shows the spheres' far sides. Otherwise the same as ../correct/tracer.py.

The grading kit runs it twice (see ../../questions.toml, `program`):

    tracer.py t     SCENE.json RAYS.csv OUT.csv          # the first t of each ray ("inf": miss)
    tracer.py image SCENE.json CAMERA.json W H OUT.png   # each pixel's normal as (n + 1) / 2

Spheres: substitute l(t) = p + t·v into |x − c|² = r² and (wrongly) take the larger root.
Triangles: the plane ⟨n, x⟩ = ⟨n, a⟩ with n = ac × ab, then the inside test "da×db, db×dc,
dc×da point the same way". The camera is raycastd's pinhole (docs/rendering.md): the ray through
pixel (x + ½, y + ½) has direction f + (2x/W − 1)·tan(fov/2)·(W/H)·r + (1 − 2y/H)·tan(fov/2)·u,
r = normalize(f × up), u = r × f.
"""

import json
import math
import struct
import sys
import zlib


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def normalize(a):
    n = math.sqrt(dot(a, a))
    return [a[0] / n, a[1] / n, a[2] / n]


def sphere_roots(p, v, center, radius):
    """The real roots of A·t² + B·t + C = 0, ascending."""
    f = sub(p, center)
    a, b, c = dot(v, v), 2 * dot(f, v), dot(f, f) - radius * radius
    disc = b * b - 4 * a * c
    if disc < 0:
        return []
    s = math.sqrt(disc)
    return sorted([(-b - s) / (2 * a), (-b + s) / (2 * a)])


def hit_sphere(p, v, obj):
    roots = sphere_roots(p, v, obj["center"], obj["radius"])
    if roots and roots[-1] >= 0:
        return roots[-1]  # the bug: the larger root, where the ray leaves the sphere
    return None


def hit_triangle(p, v, obj):
    a, b, c = obj["vertices"]
    n = cross(sub(c, a), sub(b, a))
    nv = dot(n, v)
    if nv == 0:
        return None
    t = (dot(n, a) - dot(n, p)) / nv
    if t < 0:
        return None
    d = [p[i] + t * v[i] for i in range(3)]
    da, db, dc = sub(a, d), sub(b, d), sub(c, d)
    x1, x2, x3 = cross(da, db), cross(db, dc), cross(dc, da)
    if dot(x1, x2) >= 0 and dot(x2, x3) >= 0 and dot(x3, x1) >= 0:
        return t
    return None


def first_hit(scene, p, v):
    """(t, object) of the nearest hit, or (inf, None)."""
    best, best_obj = math.inf, None
    for obj in scene["objects"]:
        t = hit_sphere(p, v, obj) if obj["type"] == "sphere" else hit_triangle(p, v, obj)
        if t is not None and t < best:
            best, best_obj = t, obj
    return best, best_obj


def normal_at(obj, point):
    if obj["type"] == "sphere":
        return normalize(sub(point, obj["center"]))
    a, b, c = obj["vertices"]
    return normalize(cross(sub(b, a), sub(c, a)))


def trace_t(scene_file, rays_file, out_file):
    scene = json.load(open(scene_file))
    with open(out_file, "w") as out:
        for line in open(rays_file):
            if line.strip():
                r = [float(x) for x in line.split(",")]
                t, _ = first_hit(scene, r[0:3], r[3:6])
                out.write(("inf" if math.isinf(t) else repr(t)) + "\n")


def render(scene_file, camera_file, width, height, out_file):
    scene = json.load(open(scene_file))
    cam = json.load(open(camera_file))
    pos = cam["position"]
    f = normalize(sub(cam["look_at"], pos))
    r = normalize(cross(f, cam["up"]))
    u = cross(r, f)
    th = math.tan(math.radians(cam["fov_y_deg"]) / 2)
    rows = []
    for y in range(height):
        row = bytearray([0])  # PNG filter type 0 for this row
        for x in range(width):
            sx = (2 * (x + 0.5) / width - 1) * th * width / height
            sy = (1 - 2 * (y + 0.5) / height) * th
            d = normalize([f[i] + sx * r[i] + sy * u[i] for i in range(3)])
            t, obj = first_hit(scene, pos, d)
            if obj is None:
                row += bytes(3)
            else:
                n = normal_at(obj, [pos[i] + t * d[i] for i in range(3)])
                row += bytes(round((c + 1) / 2 * 255) for c in n)
        rows.append(bytes(row))
    write_png(out_file, width, height, b"".join(rows))


def write_png(path, width, height, raw):
    def chunk(kind, body):
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header))
        f.write(chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


if __name__ == "__main__":
    if sys.argv[1:2] == ["t"] and len(sys.argv) == 5:
        trace_t(*sys.argv[2:5])
    elif sys.argv[1:2] == ["image"] and len(sys.argv) == 7:
        render(sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), sys.argv[6])
    else:
        sys.exit(__doc__)
