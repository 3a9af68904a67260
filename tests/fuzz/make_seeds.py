#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets (tests/fuzz/run.sh calls it).

    make_seeds.py --out build/fuzz/corpus [--models ../shared/data/models]

Each target gets a folder OUT/<target>/ of small inputs in its own input format (see the
fuzz_<target>.cpp headers): documents and requests generated here, and, when the models folder
is there, the published models of shared/data/models (valid and broken ones) up to the target's
size limit. The models are read at run time and never copied into the repository. Files are
named by a hash of their content, so running it again adds nothing twice.
"""

import argparse
import base64
import hashlib
import json
import os
import random
import re
import struct
import sys

# fuzz_support.h: a model, then optionally the bytes every URI it names reads as.
RESOURCE_MARKER = b"\n--raycastd-fuzz-resource--\n"
# Seeds larger than the target's -max_len (run.sh) would be cut short by libFuzzer.
MAX_MODEL_SEED = {"gltf": 65536, "mesh_formats": 32768, "scene_doc": 32768}
MESH_FORMATS = ["obj", "ply", "stl", "off"]  # fuzz_mesh_formats.cpp: first byte mod 4


def write(out, target, data):
    if isinstance(data, str):
        data = data.encode()
    folder = os.path.join(out, target)
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "seed-" + hashlib.sha1(data).hexdigest()[:16])
    if not os.path.exists(path):
        with open(path, "wb") as f:
            f.write(data)


def model_files(models):
    """(path, extension) of every model file under `models`, smallest first."""
    found = []
    for root, _, names in os.walk(models):
        for n in names:
            ext = n.rsplit(".", 1)[-1].lower() if "." in n else ""
            if ext in ("gltf", "glb", "obj", "ply", "stl", "off"):
                p = os.path.join(root, n)
                found.append((os.path.getsize(p), p, ext))
    return [(p, ext) for _, p, ext in sorted(found)]


def first_resource(path, data, ext):
    """The bytes of the first external file a .gltf or .obj names, or None."""
    folder = os.path.dirname(path)
    uri = None
    if ext == "gltf":
        try:
            doc = json.loads(data)
            for b in doc.get("buffers", []):
                u = b.get("uri", "")
                if u and not u.startswith("data:"):
                    uri = u
                    break
        except (ValueError, AttributeError):
            return None
    elif ext == "obj":
        m = re.search(rb"^mtllib\s+(\S+)", data, re.M)
        uri = m.group(1).decode(errors="replace") if m else None
    if not uri:
        return None
    p = os.path.join(folder, uri.replace("%20", " "))
    if not os.path.isfile(p):
        return None
    with open(p, "rb") as f:
        return f.read()


def model_seeds(out, models):
    for path, ext in model_files(models):
        with open(path, "rb") as f:
            data = f.read()
        resource = first_resource(path, data, ext)
        whole = data + RESOURCE_MARKER + resource if resource is not None else data
        if ext in ("gltf", "glb"):
            if len(whole) <= MAX_MODEL_SEED["gltf"]:
                write(out, "gltf", whole)
            elif len(data) <= MAX_MODEL_SEED["gltf"]:
                write(out, "gltf", data)
        else:
            prefix = bytes([MESH_FORMATS.index(ext)])
            if len(whole) + 1 <= MAX_MODEL_SEED["mesh_formats"]:
                write(out, "mesh_formats", prefix + whole)
        # POST /v1/scenes takes a whole model as its body, and a document can carry it inline.
        if len(data) <= MAX_MODEL_SEED["scene_doc"] // 2 and ext != "gltf":
            write(out, "scene_doc", data)
            doc = {"objects": [{"type": "mesh", "format": ext, "name": os.path.basename(path),
                                "data_base64": base64.b64encode(data).decode()}]}
            write(out, "scene_doc", json.dumps(doc))


def scene_docs():
    """Scene documents (docs/api.md, "Scene document") touching every kind of member."""
    sphere = {"type": "sphere", "center": [0, 0, 5], "radius": 1}
    tri = {"type": "triangle", "vertices": [[0, 0, 3], [1, 0, 3], [0, 1, 3]], "name": "t"}
    docs = [
        {"objects": [sphere]},
        {"objects": [sphere, tri]},
        {"objects": []},
        {"objects": [dict(sphere, material="glass"), tri],
         "materials": {"glass": {"transparency": 0.9, "ior": 1.5, "diffuse": [0.2, 0.2, 0.2],
                                 "specular": [1, 1, 1], "shininess": 50, "reflectivity": 0.1,
                                 "emissive": [0, 0, 0]}},
         "lights": [{"type": "ambient", "intensity": [0.2, 0.2, 0.2]},
                    {"type": "point", "position": [5, 5, 0], "intensity": [1, 1, 1]},
                    {"type": "directional", "direction": [0, -1, 0]}],
         "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, 1, 0],
                    "fov_y_deg": 45}},
        {"objects": [{"type": "sphere", "center": [1e300, -1e-300, 0], "radius": 1e-300}]},
        {"objects": [{"type": "triangle", "vertices": [[0, 0, 0], [0, 0, 0], [0, 0, 0]]}]},
        {"objects": [dict(sphere, radius=-1)]},
        {"objects": [dict(sphere, difuse=[1, 0, 0])], "extra": {"a": [1, [2, {"b": None}]]}},
    ]
    for uri in ["tri.obj", "tri.stl", "quad.off", "tri.ply", "models/tri.gltf", "../tri.obj",
                "models/../tri.obj", "/etc/passwd", "missing.obj", "models/bin/tri.bin"]:
        docs.append({"objects": [{"type": "mesh", "uri": uri, "material": "red"}],
                     "materials": {"red": {"diffuse": [1, 0, 0]}}})
    docs.append({"objects": [{"type": "mesh", "uri": "tri.obj",
                              "transform": {"translate": [1, 2, 3], "rotate_deg": [0, 90, 0],
                                            "scale": [1, -1, 2]}},
                             {"type": "mesh", "uri": "quad.off", "format": "off",
                              "transform": {"scale": 2}}]})
    docs.append({"objects": [{"type": "mesh", "format": "obj",
                              "data_base64": base64.b64encode(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                                              b"f 1 2 3\n").decode()}]})
    # Many primitives, so that the scene is built with Embree rather than by brute force.
    rnd = random.Random(13)
    docs.append({"objects": [{"type": "sphere", "radius": rnd.uniform(0.1, 1),
                              "center": [rnd.uniform(-9, 9) for _ in range(3)]}
                             for _ in range(24)]})
    return [json.dumps(d) for d in docs] + ['{"objects": [', "[]", "", "{}", "null",
                                            '{"asset": {"version": "2.0"}}']


def ray(o=(0, 0, 0), d=(0, 0, 1), **extra):
    r = {"origin": list(o), "direction": list(d)}
    r.update(extra)
    return r


def intersect_bodies():
    """Intersect requests: the scanner's fast shape and what makes it give up or refuse."""
    bodies = [
        {"rays": [ray()]},
        {"rays": []},
        {"rays": [ray((-1, 0.5, 2e3), (1, 2, 3), tmin=-1, tmax=5)], "mode": "all",
         "precision": "exact", "fields": ["t", "object"], "client": {"x": [1, {"y": 2}]}},
        {"rays": [ray(note="x", extra=[1, [2]])], "mode": "count", "precision": "fast"},
        {"rays": [ray(d=(0, 0, 0))]},
        {"rays": [ray(tmin=3, tmax=1)]},
        {"rays": [ray()] * 9},
        {"mode": "any", "fields": ["t", "t_err", "point", "normal", "front_face", "object", "name",
                                   "primitive", "barycentric"], "rays": [ray(), ray((1, 1, 1))]},
        {"rays": [ray()], "mode": "nearest"},
        {"rays": [ray()], "fields": ["colour"]},
    ]
    texts = [json.dumps(b) for b in bodies]
    texts += [
        '{"rays":[{"origin":[-0,-0.0,0e0],"direction":[1e-320,4.9e-324,1]}]}',
        '{"rays":[{"origin":[1e308,-1e308,18446744073709551615],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[1e400,0,0],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[9223372036854775807,-9223372036854775808,1.0],"direction":[0,1,0]}]}',
        '{"rays":[{"origin":[0,0,0],"direction":[0,0,1],"tmin":-0,"tmax":1E+2}]}',
        '{"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"mode":"\\u0061ll"}',
        '{"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"mode":"all","mode":"any"}',
        '{"rays":[{"origin":[0,0,0],"origin":[1,1,1],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[0,0],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[0,0,0,0],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":["0",0,0],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[0,0,0],"direction":[0,0,1]}]} x',
        ' \t\r\n{"rays":[{"origin":[ 0 , 0 , 0 ],"direction":[0,0,1]}]}\n',
        '{"rays":{"origin":[0,0,0]}}',
        '{"rays":[null]}',
        '{"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"fields":[]}',
        '{"r\\u00e4ys":[]}',
        '{"rays":[{"origin":[01,0,0],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[.5,0,0],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[1.,0,0],"direction":[0,0,1]}]}',
        '{"rays":[{"origin":[-,0,0],"direction":[0,0,1]}]}',
    ]
    return texts


def binary_rays(rnd, dtype, n, bad=None):
    fmt = "<8f" if dtype == "float32" else "<8d"
    out = b""
    for i in range(n):
        v = [rnd.uniform(-10, 10) for _ in range(6)] + [0.0, float("inf")]
        if bad is not None and i == n // 2:
            v[bad[0]] = bad[1]
        out += struct.pack(fmt, *v)
    return out


def binary_seeds(out):
    rnd = random.Random(7)
    for dtype, flag in (("float32", 0), ("float64", 1)):
        for n in (0, 1, 3, 16):
            write(out, "binary_rays", bytes([flag | (31 << 1)]) + binary_rays(rnd, dtype, n))
        for bad in ((0, float("nan")), (3, float("inf")), (6, 5.0), (7, float("-inf")),
                    (4, 1e-30), (5, 3e38)):
            write(out, "binary_rays", bytes([flag | (31 << 1)]) + binary_rays(rnd, dtype, 5, bad))
        write(out, "binary_rays", bytes([flag | (2 << 1)]) + binary_rays(rnd, dtype, 4))
        write(out, "binary_rays", bytes([flag]) + binary_rays(rnd, dtype, 2)[:-3])


def http_seeds(out, docs, bodies):
    shapes = {  # fuzz_http_routes.cpp's kShapes, by index
        "scenes_json": 1, "scenes": 2, "scenes_glb": 3, "scenes_obj": 4, "scenes_form": 5,
        "scenes_ply": 6, "intersect": 7, "scene_intersect": 8, "binary32": 9, "binary64": 10,
        "binary_count": 11, "trace": 12, "render": 13, "explain": 14, "render_bare": 15,
        "explain_md": 16,
    }

    def post(shape, body):
        write(out, "http_routes", bytes([shapes[shape]]) + (body if isinstance(body, bytes)
                                                            else body.encode()))

    for d in docs[:6]:
        post("scenes_json", d)
        post("scenes_form", d)
    post("scenes", docs[1])
    post("scenes_obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    post("scenes_ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty "
                       "float y\nproperty float z\nelement face 1\nproperty list uchar int "
                       "vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    post("scenes_glb", b"glTF\x02\x00\x00\x00\x0c\x00\x00\x00")
    for b in bodies[:8]:
        post("scene_intersect", b)
        post("intersect", json.dumps({"scene": json.loads(docs[1]), **json.loads(b)}))
    rnd = random.Random(3)
    post("binary32", binary_rays(rnd, "float32", 4))
    post("binary64", binary_rays(rnd, "float64", 3))
    post("binary_count", binary_rays(rnd, "float32", 2, (3, float("nan"))))
    trace = {"ray": ray(), "max_depth": 3, "precision": "exact"}
    post("trace", json.dumps(trace))
    post("trace", '{"ray": {"origin": [0, 0, 0]}}')
    post("render", json.dumps({"width": 8, "height": 6, "spp": 1, "max_depth": 2,
                               "shading": "phong", "format": "png", "precision": "fast"}))
    post("render", json.dumps({"width": 4, "height": 4, "async": True, "format": "ppm"}))
    post("render", json.dumps({"width": 100000, "height": 100000}))
    post("render_bare", "")
    explain = {"scene": json.loads(docs[3]), "ray": ray()}
    post("explain", json.dumps(explain))
    post("explain_md", json.dumps(explain))
    raw = [
        "GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n",
        "GET /v1/info HTTP/1.1\r\nHost: x\r\n\r\nGET /v1/scenes HTTP/1.1\r\nHost: x\r\n\r\n",
        "HEAD /v1/openapi.json HTTP/1.1\r\n\r\n",
        "GET / HTTP/1.1\r\n\r\n",
        "GET /web/../../../etc/passwd HTTP/1.1\r\n\r\n",
        "GET /web/%2e%2e/%2e%2e/etc/passwd HTTP/1.1\r\n\r\n",
        "DELETE /v1/scenes/sc_nothing HTTP/1.1\r\n\r\n",
        "GET /v1/jobs/jb_1/image HTTP/1.1\r\n\r\n",
        "DELETE /v1/jobs/jb_1 HTTP/1.1\r\n\r\n",
        "PUT /v1/scenes HTTP/1.1\r\nContent-Length: 2\r\n\r\n{}",
        "TRACE /v1/health HTTP/1.1\r\n\r\n",
        "OPTIONS * HTTP/1.1\r\n\r\n",
        "POST /v1/scenes HTTP/1.1\r\nContent-Length: -5\r\n\r\n",
        "POST /v1/scenes HTTP/1.1\r\nContent-Length: 2\r\nContent-Length: 3\r\n\r\n{}",
        "POST /v1/scenes HTTP/1.1\r\nContent-Length: 99999999999999999999999\r\n\r\n",
        "POST /v1/scenes HTTP/1.1\r\nContent-Length: 100\r\n\r\n{\"objects\":[]}",
        "POST /v1/scenes HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n4\r\n{\"ob\r\n0\r\n\r\n",
        "POST /v1/scenes HTTP/1.1\r\nTransfer-Encoding: chunked\r\nContent-Length: 3\r\n\r\n",
        "POST /v1/scenes HTTP/1.1\r\nExpect: 100-continue\r\nContent-Length: 14\r\n\r\n"
        "{\"objects\":[]}",
        "POST /v1/scenes HTTP/1.1\r\nContent-Encoding: gzip\r\nContent-Length: 4\r\n\r\nabcd",
        "POST /v1/intersect HTTP/1.1\nContent-Length: 2\n\n{}",
        "GET /v1/health HTTP/1.0\r\n\r\n",
        "GET /v1/health\r\n\r\n",
        "GET /" + "a" * 9000 + " HTTP/1.1\r\n\r\n",
        "GET /v1/health HTTP/1.1\r\nX: " + "b" * 17000 + "\r\n\r\n",
        "GET /v1/health HTTP/1.1\r\nRange: bytes=5-1\r\n\r\n",
        "\x00\xff\r\n\r\n",
        "",
    ]
    for r in raw:
        write(out, "http_routes", b"\x00" + r.encode("latin-1"))


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", required=True)
    p.add_argument("--models", default=os.path.join(here, "..", "..", "..", "shared", "data",
                                                    "models"))
    opts = p.parse_args()
    docs = scene_docs()
    bodies = intersect_bodies()
    for d in docs:
        write(opts.out, "scene_doc", d)
    for b in bodies:
        write(opts.out, "ray_scanner", b)
    binary_seeds(opts.out)
    http_seeds(opts.out, docs, bodies)
    # Hand-made models, so that every target has seeds without shared/.
    write(opts.out, "gltf", '{"asset":{"version":"2.0"}}')
    write(opts.out, "mesh_formats", b"\x00v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    write(opts.out, "mesh_formats", b"\x03OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    if os.path.isdir(opts.models):
        model_seeds(opts.out, opts.models)
    else:
        print("make_seeds: no models at %s: seeding from generated inputs only" % opts.models,
              file=sys.stderr)


if __name__ == "__main__":
    main()
