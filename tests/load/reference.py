"""An exact reference for ray/sphere and ray/triangle hits, in Python rationals, and the scene and
ray generators the load suites use.

Inputs are Python floats (exact binary rationals), so fractions.Fraction evaluates the sphere's
quadratic and Moller-Trumbore's triangle test without any rounding. The reference answers None
("ambiguous, do not compare") for rays that a correct double-precision answer could decide either
way: within 1e-6 of a sphere's tangency, within 1e-6 (barycentric) of a triangle's edge, nearly
parallel to a triangle's plane, a root within 1e-9 of tmin/tmax, or two objects hit within 1e-9
of each other.
"""

import base64
import math
import random
import struct
from fractions import Fraction as F

TANGENT_EPS = 1e-6
EDGE_EPS = 1e-6
TIE_EPS = 1e-9


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _fv(v):
    return (F(v[0]), F(v[1]), F(v[2]))


class Ambiguous(Exception):
    pass


def sphere_roots(o, d, c, r):
    """Exact-decided real roots of |o + t d - c|^2 = r^2, as floats (ascending), or [] for a miss.
    Raises Ambiguous within TANGENT_EPS of tangency."""
    of, df, cf, rf = _fv(o), _fv(d), _fv(c), F(r)
    oc = _sub(of, cf)
    A = _dot(df, df)
    Bh = _dot(df, oc)  # B/2
    C = _dot(oc, oc) - rf * rf
    # squared distance from the centre to the line: |oc|^2 - (d.oc)^2/|d|^2
    h2 = _dot(oc, oc) - Bh * Bh / A
    r2 = rf * rf
    if abs(h2 - r2) <= 2 * TANGENT_EPS * r2:
        raise Ambiguous("tangent")
    D = Bh * Bh - A * C  # discriminant / 4
    if D < 0:
        return []
    sq = math.sqrt(float(D))
    b = float(Bh)
    q = -(b + math.copysign(sq, b))  # no cancellation
    a = float(A)
    if q == 0.0:
        return [0.0, 0.0]
    t1, t2 = q / a, float(C) / q
    return sorted((t1, t2))


def triangle_hit(o, d, tri):
    """(t, u, v) of an exact Moller-Trumbore hit on the closed triangle, or None for a miss.
    Raises Ambiguous near an edge or for a ray nearly in the plane."""
    a, b, c = tri
    # float prefilter: far from the triangle, no rationals needed
    e1f, e2f = _sub(b, a), _sub(c, a)
    pf = _cross(d, e2f)
    detf = _dot(e1f, pf)
    scale = math.sqrt(_dot(d, d) * _dot(e1f, e1f) * _dot(e2f, e2f)) or 1.0
    if abs(detf) > 1e-3 * scale:
        tf = _sub(o, a)
        uf = _dot(tf, pf) / detf
        qf = _cross(tf, e1f)
        vf = _dot(d, qf) / detf
        if uf < -1e-3 or vf < -1e-3 or uf + vf > 1.0 + 1e-3:
            return None
    of, df = _fv(o), _fv(d)
    af, bf, cf = _fv(a), _fv(b), _fv(c)
    e1, e2 = _sub(bf, af), _sub(cf, af)
    p = _cross(df, e2)
    det = _dot(e1, p)
    if det == 0:
        n = _cross(e1, e2)
        if n == (0, 0, 0):
            return None  # degenerate: never hit
        return None  # parallel or in the plane: a miss by the contract
    if abs(float(det)) <= 1e-6 * scale:
        raise Ambiguous("nearly parallel")
    tv = _sub(of, af)
    u = _dot(tv, p) / det
    q = _cross(tv, e1)
    v = _dot(df, q) / det
    w = 1 - u - v
    m = min(u, v, w)
    if abs(float(m)) < EDGE_EPS:
        raise Ambiguous("edge")
    if m < 0:
        return None
    t = _dot(e2, q) / det
    return float(t), float(u), float(v)


def closest(scene, o, d, tmin=0.0, tmax=math.inf):
    """The closest hit of a reference scene: {'hit': False} or {'hit': True, 't', 'object',
    'primitive'}; None when ambiguous. `scene` is the list from reference_objects()."""
    cands = []  # (t, object, primitive)
    for idx, obj in enumerate(scene):
        try:
            if obj[0] == "sphere":
                for t in sphere_roots(o, d, obj[1], obj[2]):
                    if _near(t, tmin) or _near(t, tmax):
                        return None
                    if tmin <= t <= tmax:
                        cands.append((t, idx, 0))
                        break
            else:
                best = None
                for prim, tri in enumerate(obj[1]):
                    h = triangle_hit(o, d, tri)
                    if h is None:
                        continue
                    t = h[0]
                    if _near(t, tmin) or _near(t, tmax):
                        return None
                    if tmin <= t <= tmax and (best is None or t < best[0]):
                        best = (t, idx, prim)
                if best is not None:
                    cands.append(best)
        except Ambiguous:
            return None
    if not cands:
        return {"hit": False}
    cands.sort()
    if len(cands) > 1 and _near(cands[0][0], cands[1][0]):
        return None
    t, obj, prim = cands[0]
    return {"hit": True, "t": t, "object": obj, "primitive": prim}


def all_hits(scene, o, d, tmin=0.0, tmax=math.inf):
    """Sorted t of every hit (spheres and lone triangles only), or None when ambiguous."""
    ts = []
    for obj in scene:
        try:
            if obj[0] == "sphere":
                roots = sphere_roots(o, d, obj[1], obj[2])
                for t in roots:
                    if _near(t, tmin) or _near(t, tmax):
                        return None
                    if tmin <= t <= tmax:
                        ts.append(t)
            else:
                for tri in obj[1]:
                    h = triangle_hit(o, d, tri)
                    if h is not None:
                        if _near(h[0], tmin) or _near(h[0], tmax):
                            return None
                        if tmin <= h[0] <= tmax:
                            ts.append(h[0])
        except Ambiguous:
            return None
    ts.sort()
    return ts


def _near(a, b):
    if math.isinf(b) or math.isinf(a):
        return False
    return abs(a - b) <= TIE_EPS * max(1.0, abs(a), abs(b))


def rel_close(a, b, tol):
    return abs(a - b) <= tol * max(abs(a), abs(b), 1e-300)


# --- scenes ---------------------------------------------------------------------------------

def _num(rng, lo, hi):
    return rng.uniform(lo, hi)


def random_small_scene(rng, tag=None, spheres=(1, 6), triangles=(0, 4)):
    """A tutorial-like document of a few spheres and lone triangles (<= 16 primitives, so the
    server answers it on its exact path). `tag` makes the document unique (a name key)."""
    objs = []
    for _ in range(rng.randint(*spheres)):
        objs.append({"type": "sphere",
                     "center": [_num(rng, -4, 4), _num(rng, -4, 4), _num(rng, 6, 14)],
                     "radius": _num(rng, 0.5, 2.5)})
    for _ in range(rng.randint(*triangles)):
        base = [_num(rng, -4, 4), _num(rng, -4, 4), _num(rng, 6, 14)]
        verts = [[base[i] + _num(rng, -2, 2) for i in range(3)] for _ in range(3)]
        objs.append({"type": "triangle", "vertices": verts})
    doc = {"objects": objs}
    if tag is not None:
        doc["name"] = "load %s" % tag
    return doc


def tutorial_scene():
    return {"objects": [
        {"type": "sphere", "center": [0, 0, 10], "radius": 2},
        {"type": "sphere", "center": [0, 3, 8], "radius": 2},
        {"type": "sphere", "center": [0, 1, 9], "radius": 2}]}


def icosphere(subdivisions=2, radius=3.0, center=(0.0, 0.0, 10.0)):
    """(vertices, faces) of an icosphere; coordinates rounded to float32 so a loader reading
    floats or doubles sees the same numbers."""
    t = (1.0 + 5.0 ** 0.5) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
             (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [_unit(v) for v in verts]
    for _ in range(subdivisions):
        cache = {}
        nf = []

        def mid(i, j):
            key = (min(i, j), max(i, j))
            if key not in cache:
                a, b = verts[i], verts[j]
                verts.append(_unit(((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2)))
                cache[key] = len(verts) - 1
            return cache[key]

        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = nf
    out = [tuple(f32(center[k] + radius * v[k]) for k in range(3)) for v in verts]
    return out, faces


def _unit(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / n, v[1] / n, v[2] / n)


def obj_text(verts, faces):
    lines = ["# icosphere generated by tests/load"]
    lines += ["v %r %r %r" % v for v in verts]
    lines += ["f %d %d %d" % (a + 1, b + 1, c + 1) for a, b, c in faces]
    return "\n".join(lines) + "\n"


def mesh_scene():
    """A document with an inline icosphere OBJ (320 triangles: the server builds a BVH) and
    two spheres."""
    verts, faces = icosphere(2, 3.0, (0.0, 0.0, 10.0))
    data = base64.b64encode(obj_text(verts, faces).encode()).decode()
    doc = {"objects": [
        {"type": "mesh", "format": "obj", "data_base64": data, "name": "icosphere"},
        {"type": "sphere", "center": [4.5, 1.0, 12.0], "radius": 1.25},
        {"type": "sphere", "center": [-4.0, -2.0, 9.0], "radius": 0.75}]}
    return doc, (verts, faces)


def reference_objects(doc, mesh_geometry=None):
    """The reference's view of a document: [('sphere', c, r) | ('tris', [(a,b,c), ...])]."""
    out = []
    for obj in doc["objects"]:
        if obj["type"] == "sphere":
            out.append(("sphere", tuple(obj["center"]), obj["radius"]))
        elif obj["type"] == "triangle":
            out.append(("tris", [tuple(tuple(v) for v in obj["vertices"])]))
        elif obj["type"] == "mesh":
            verts, faces = mesh_geometry
            out.append(("tris", [(verts[a], verts[b], verts[c]) for a, b, c in faces]))
        else:
            raise ValueError(obj["type"])
    return out


def random_ray(rng, lo=(-6.0, -6.0, 4.0), hi=(6.0, 6.0, 16.0)):
    """A ray from outside the scene's box toward a random point near it (hits and misses),
    with a direction of random, non-unit length."""
    side = rng.random()
    if side < 0.6:
        o = [_num(rng, -3, 3), _num(rng, -3, 3), _num(rng, -4, 1)]
    else:
        o = [_num(rng, -20, 20), _num(rng, -20, 20), _num(rng, -10, 30)]
    target = [_num(rng, lo[i] - 1, hi[i] + 1) for i in range(3)]
    s = rng.uniform(0.05, 3.0)
    d = [(target[i] - o[i]) * s for i in range(3)]
    if d == [0.0, 0.0, 0.0]:
        d = [0.0, 0.0, 1.0]
    return o, d


def rng_for(seed, *parts):
    return random.Random("%s/%s" % (seed, "/".join(str(p) for p in parts)))
