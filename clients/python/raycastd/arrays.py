"""Array queries over the binary endpoints, modelled on Open3D's `RaycastingScene` and trimesh.ray.

    with Client() as c:
        ans = c.cast_rays(scene, rays)          # rays: (..., 6) ox oy oz dx dy dz, any float dtype
        ans["t_hit"]                            # shaped like rays[..., 0]; inf on a miss

Every call sends its rays (or points) through the binary form of API.md ("Binary form"): packed
little-endian records, in chunks of `Client.chunk_rays` over the client's one keep-alive
connection. With NumPy the calls take array-likes and return arrays shaped like the input; without
NumPy (or with `Client(arrays="list")`) they take nested lists and return nested lists of the same
shape. The wire precision follows the input: float16 and float32 arrays travel as float32,
float64 and integer arrays as float64 (`dtype=` overrides it); lists travel as float64.
"""

from __future__ import annotations

import math
import re
import struct
from typing import TYPE_CHECKING, Any, Callable

from raycastd.errors import BadRequest

if TYPE_CHECKING:  # pragma: no cover
    from raycastd.client import Response, SceneRef

MISS_ID = 0xFFFFFFFF  # geometry_ids / primitive_ids of a miss (and of a point with no surface)


def load_numpy() -> Any:
    """The numpy module, or None when it is not installed."""
    try:
        import numpy
    except ImportError:
        return None
    return numpy


class ArrayQueries:
    """The array methods of `Client` (a mixin: it needs `request`, `scene_id` and `chunk_rays`)."""

    chunk_rays: int

    def __init__(self, arrays: str = "auto") -> None:
        if arrays not in ("auto", "numpy", "list"):
            raise ValueError(f"arrays must be 'auto', 'numpy' or 'list', not {arrays!r}")
        self._np = None if arrays == "list" else load_numpy()
        if arrays == "numpy" and self._np is None:
            raise ImportError("arrays='numpy' needs NumPy (Debian: apt-get install python3-numpy)")

    @property
    def uses_numpy(self) -> bool:
        """Whether the array queries take and return NumPy arrays."""
        return self._np is not None

    # -- rays --------------------------------------------------------------------------------

    def cast_rays(
        self,
        scene: "SceneRef",
        rays: Any = None,
        *,
        origins: Any = None,
        directions: Any = None,
        tmin: Any = 0.0,
        tmax: Any = math.inf,
        precision: str | None = None,
        dtype: str | None = None,
    ) -> dict[str, Any]:
        """Closest hits: `t_hit` (inf on a miss), `geometry_ids` and `primitive_ids`
        (`0xFFFFFFFF` on a miss), `primitive_uvs` (..., 2) and `primitive_normals` (..., 3),
        each shaped like the rays without their last axis."""
        batch = self._rays(rays, origins, directions, tmin, tmax, dtype)
        wide = batch.wire == "float64"
        rec = struct.Struct("<dII5d" if wide else "<fII5f")
        parts = self._send_rays(scene, batch, "closest", precision)
        if self._np is not None:
            np = self._np
            f = "<f8" if wide else "<f4"
            dt = np.dtype([("t", f), ("g", "<u4"), ("p", "<u4"), ("uv", f, 2), ("n", f, 3)])
            a = np.frombuffer(b"".join(parts), dtype=dt)
            s = batch.shape
            return {
                "t_hit": a["t"].reshape(s),
                "geometry_ids": a["g"].reshape(s),
                "primitive_ids": a["p"].reshape(s),
                "primitive_uvs": a["uv"].reshape(s + (2,)),
                "primitive_normals": a["n"].reshape(s + (3,)),
            }
        recs = [r for part in parts for r in rec.iter_unpack(part)]
        return {
            "t_hit": _shape([r[0] for r in recs], batch.shape),
            "geometry_ids": _shape([r[1] for r in recs], batch.shape),
            "primitive_ids": _shape([r[2] for r in recs], batch.shape),
            "primitive_uvs": _shape([[r[3], r[4]] for r in recs], batch.shape),
            "primitive_normals": _shape([[r[5], r[6], r[7]] for r in recs], batch.shape),
        }

    def test_occlusions(self, scene: "SceneRef", rays: Any = None, **kw: Any) -> Any:
        """Whether each ray hits anything in [tmin, tmax] (bool, shaped like the rays)."""
        return self._per_ray_u32(scene, rays, "any", kw, lambda v: v != 0, "bool")

    def count_intersections(self, scene: "SceneRef", rays: Any = None, **kw: Any) -> Any:
        """How many surfaces each ray crosses (a shared mesh edge once), shaped like the rays."""
        return self._per_ray_u32(scene, rays, "count", kw, int, "int64")

    def list_intersections(self, scene: "SceneRef", rays: Any = None, **kw: Any) -> dict[str, Any]:
        """Every hit of every ray, as flat arrays sorted by ray then t (Open3D's layout):
        `ray_splits` (N + 1: the hits of ray i are `ray_splits[i]:ray_splits[i+1]`), `ray_ids`,
        `t_hit`, `geometry_ids`, `primitive_ids`, `primitive_uvs`, `primitive_normals`."""
        batch = self._rays(
            rays,
            kw.pop("origins", None),
            kw.pop("directions", None),
            kw.pop("tmin", 0.0),
            kw.pop("tmax", math.inf),
            kw.pop("dtype", None),
        )
        wide = batch.wire == "float64"
        rec = struct.Struct("<dII5d" if wide else "<fII5f")
        splits, ray_ids, recs = [0], [], []
        ray = 0
        for part in self._send_rays(scene, batch, "all", kw.pop("precision", None)):
            pos = 0
            while pos < len(part):
                (n,) = struct.unpack_from("<I", part, pos)
                pos += 4
                for _ in range(n):
                    recs.append(rec.unpack_from(part, pos))
                    pos += rec.size
                ray_ids.extend([ray] * n)
                splits.append(splits[-1] + n)
                ray += 1
        if kw:
            raise TypeError(f"unexpected arguments: {', '.join(kw)}")
        cols = {
            "ray_splits": splits,
            "ray_ids": ray_ids,
            "t_hit": [r[0] for r in recs],
            "geometry_ids": [r[1] for r in recs],
            "primitive_ids": [r[2] for r in recs],
            "primitive_uvs": [[r[3], r[4]] for r in recs],
            "primitive_normals": [[r[5], r[6], r[7]] for r in recs],
        }
        if self._np is None:
            return cols
        np = self._np
        f = np.float64 if wide else np.float32
        return {
            "ray_splits": np.asarray(splits, dtype=np.int64),
            "ray_ids": np.asarray(ray_ids, dtype=np.int64),
            "t_hit": np.asarray(cols["t_hit"], dtype=f),
            "geometry_ids": np.asarray(cols["geometry_ids"], dtype=np.uint32),
            "primitive_ids": np.asarray(cols["primitive_ids"], dtype=np.uint32),
            "primitive_uvs": np.asarray(cols["primitive_uvs"], dtype=f).reshape(-1, 2),
            "primitive_normals": np.asarray(cols["primitive_normals"], dtype=f).reshape(-1, 3),
        }

    # -- points ------------------------------------------------------------------------------

    def compute_closest_points(
        self, scene: "SceneRef", query_points: Any, dtype: str | None = None
    ) -> dict[str, Any]:
        """The nearest surface point of each query point: `points` (..., 3), `distances`,
        `geometry_ids`, `primitive_ids` (`0xFFFFFFFF` when the scene is empty) and
        `primitive_uvs` (..., 2), shaped like the query points without their last axis."""
        batch = self._points(query_points, dtype)
        wide = batch.wire == "float64"
        rec = struct.Struct("<4dII2d" if wide else "<4fII2f")
        parts = self._send_points(scene, batch, "closest")
        s = batch.shape
        if self._np is not None:
            np = self._np
            f = "<f8" if wide else "<f4"
            dt = np.dtype([("p", f, 3), ("d", f), ("g", "<u4"), ("i", "<u4"), ("uv", f, 2)])
            a = np.frombuffer(b"".join(parts), dtype=dt)
            return {
                "points": a["p"].reshape(s + (3,)),
                "distances": a["d"].reshape(s),
                "geometry_ids": a["g"].reshape(s),
                "primitive_ids": a["i"].reshape(s),
                "primitive_uvs": a["uv"].reshape(s + (2,)),
            }
        recs = [r for part in parts for r in rec.iter_unpack(part)]
        return {
            "points": _shape([list(r[0:3]) for r in recs], s),
            "distances": _shape([r[3] for r in recs], s),
            "geometry_ids": _shape([r[4] for r in recs], s),
            "primitive_ids": _shape([r[5] for r in recs], s),
            "primitive_uvs": _shape([[r[6], r[7]] for r in recs], s),
        }

    def compute_distance(
        self, scene: "SceneRef", query_points: Any, dtype: str | None = None
    ) -> Any:
        """Unsigned distance of each point to the nearest surface."""
        return self._per_point_value(scene, query_points, "distance", dtype, None)

    def compute_signed_distance(
        self, scene: "SceneRef", query_points: Any, dtype: str | None = None
    ) -> Any:
        """Distance to the nearest surface, negative inside a solid (sphere, or a mesh by its
        topology's `sign` rule)."""
        return self._per_point_value(scene, query_points, "signed_distance", dtype, None)

    def compute_occupancy(
        self, scene: "SceneRef", query_points: Any, dtype: str | None = None
    ) -> Any:
        """1.0 where a point is inside (winding number ≥ ½, on the surface included), else 0.0
        (floats, as Open3D's `compute_occupancy` returns)."""
        return self._per_point_value(
            scene, query_points, "occupancy", dtype, lambda w: 1.0 if w >= 0.5 else 0.0
        )

    # -- plumbing ----------------------------------------------------------------------------

    def _per_ray_u32(
        self,
        scene: "SceneRef",
        rays: Any,
        mode: str,
        kw: dict[str, Any],
        convert: Callable[[int], Any],
        np_dtype: str,
    ) -> Any:
        batch = self._rays(
            rays,
            kw.pop("origins", None),
            kw.pop("directions", None),
            kw.pop("tmin", 0.0),
            kw.pop("tmax", math.inf),
            kw.pop("dtype", None),
        )
        precision = kw.pop("precision", None)
        if kw:
            raise TypeError(f"unexpected arguments: {', '.join(kw)}")
        data = b"".join(self._send_rays(scene, batch, mode, precision))
        if self._np is not None:
            np = self._np
            v = np.frombuffer(data, dtype="<u4").reshape(batch.shape)
            return (v != 0) if np_dtype == "bool" else v.astype(np_dtype)
        return _shape([convert(v) for (v,) in struct.iter_unpack("<I", data)], batch.shape)

    def _per_point_value(
        self,
        scene: "SceneRef",
        query_points: Any,
        query: str,
        dtype: str | None,
        convert: Callable[[float], float] | None,
    ) -> Any:
        batch = self._points(query_points, dtype)
        wide = batch.wire == "float64"
        data = b"".join(self._send_points(scene, batch, query))
        if self._np is not None:
            v = self._np.frombuffer(data, dtype="<f8" if wide else "<f4").reshape(batch.shape)
            return (v >= 0.5).astype(v.dtype) if convert is not None else v
        vals = [v for (v,) in struct.iter_unpack("<d" if wide else "<f", data)]
        return _shape([convert(v) for v in vals] if convert else vals, batch.shape)

    def _rays(
        self, rays: Any, origins: Any, directions: Any, tmin: Any, tmax: Any, dtype: str | None
    ) -> "_Batch":
        if (rays is None) == (origins is None or directions is None):
            raise TypeError("give either rays (..., 6) or both origins and directions (..., 3)")
        if self._np is not None:
            np = self._np
            if rays is not None:
                r = np.asarray(rays)
                if r.ndim < 1 or r.shape[-1] != 6:
                    raise ValueError(f"rays must have shape (..., 6), not {r.shape}")
                src = r.dtype
                o, d = r[..., 0:3], r[..., 3:6]
            else:
                o, d = np.asarray(origins), np.asarray(directions)
                src = np.result_type(o, d)
                o, d = np.broadcast_arrays(o, d)
                if o.ndim < 1 or o.shape[-1] != 3:
                    raise ValueError(f"origins/directions must have shape (..., 3), not {o.shape}")
            wire = dtype or _wire_dtype(src)
            shape = o.shape[:-1]
            rec = np.empty(shape + (8,), dtype="<f8" if wire == "float64" else "<f4")
            rec[..., 0:3] = o
            rec[..., 3:6] = d
            rec[..., 6] = tmin
            rec[..., 7] = tmax
            return _Batch(shape, wire, 32 if wire == "float32" else 64, rec.reshape(-1, 8))
        wire = dtype or "float64"
        if rays is not None:
            flat, shape = _flatten(rays, 6)
        else:
            o_flat, shape = _flatten(origins, 3)
            d_flat, d_shape = _flatten(directions, 3)
            if d_shape != shape:
                raise ValueError(f"origins {shape} and directions {d_shape} differ in shape")
            flat = [a + b for a, b in zip(o_flat, d_flat)]
        lo = _flatten_scalar(tmin, shape)
        hi = _flatten_scalar(tmax, shape)
        rows = [r + [a, b] for r, a, b in zip(flat, lo, hi)]
        return _Batch(shape, wire, 32 if wire == "float32" else 64, rows)

    def _points(self, points: Any, dtype: str | None) -> "_Batch":
        if self._np is not None:
            np = self._np
            p = np.asarray(points)
            if p.ndim < 1 or p.shape[-1] != 3:
                raise ValueError(f"points must have shape (..., 3), not {p.shape}")
            wire = dtype or _wire_dtype(p.dtype)
            flat = np.ascontiguousarray(
                p.reshape(-1, 3), dtype="<f8" if wire == "float64" else "<f4"
            )
            return _Batch(p.shape[:-1], wire, 12 if wire == "float32" else 24, flat)
        flat, shape = _flatten(points, 3)
        wire = dtype or "float64"
        return _Batch(shape, wire, 12 if wire == "float32" else 24, flat)

    def _send_rays(
        self, scene: "SceneRef", batch: "_Batch", mode: str, precision: str | None
    ) -> list[bytes]:
        path = f"/v1/scenes/{self.scene_id(scene)}/intersect"
        query = {"mode": mode, "precision": precision, "dtype": batch.wire}
        return self._send(path, query, batch, 8, "ray")

    def _send_points(self, scene: "SceneRef", batch: "_Batch", query: str) -> list[bytes]:
        path = f"/v1/scenes/{self.scene_id(scene)}/points"
        return self._send(path, {"query": query, "dtype": batch.wire}, batch, 3, "point")

    def _send(
        self, path: str, query: dict[str, Any], batch: "_Batch", width: int, what: str
    ) -> list[bytes]:
        parts = []
        n = len(batch.rows)
        step = max(1, self.chunk_rays)
        fmt = ("<%dd" if batch.wire == "float64" else "<%df") % width
        for start in range(0, n, step):
            rows = batch.rows[start : start + step]
            if self._np is not None and hasattr(rows, "tobytes"):
                body = rows.tobytes()
            else:
                pack = struct.Struct(fmt).pack
                body = b"".join(pack(*r) for r in rows)
            try:
                res: "Response" = self.request(  # type: ignore[attr-defined]
                    "POST", path, body, "application/octet-stream", query=query
                )
            except BadRequest as err:
                if start:  # the server counts from the chunk's first record
                    _shift_index(err, start, what)
                raise
            parts.append(res.body)
        return parts


def _wire_dtype(src: Any) -> str:
    """float32 for float dtypes of at most 4 bytes (float16, float32), float64 for the rest
    (float64, and integers, which float64 holds exactly)."""
    return "float32" if src.kind == "f" and src.itemsize <= 4 else "float64"


class _Batch:
    """Rays or points ready to send: the caller's shape, the wire dtype, records as rows."""

    def __init__(self, shape: tuple[int, ...], wire: str, record_bytes: int, rows: Any) -> None:
        if wire not in ("float32", "float64"):
            raise ValueError(f"dtype must be 'float32' or 'float64', not {wire!r}")
        self.shape = tuple(shape)
        self.wire = wire
        self.record_bytes = record_bytes
        self.rows = rows


def _shift_index(err: BadRequest, offset: int, what: str) -> None:
    """Rewrites `ray 3` / `/rays/3` in a chunk's error to the index in the whole batch."""
    plural = what + "s"
    err.message = re.sub(
        rf"\b{what} (\d+)", lambda m: f"{what} {int(m.group(1)) + offset}", err.message
    )
    if err.path:
        err.path = re.sub(
            rf"^/{plural}/(\d+)", lambda m: f"/{plural}/{int(m.group(1)) + offset}", err.path
        )
    err.args = (str(err),)


def _flatten(value: Any, width: int) -> tuple[list[list[float]], tuple[int, ...]]:
    """Nested lists ending in rows of `width` numbers → (rows, the leading shape)."""
    if _is_row(value, width):
        return [[float(v) for v in value]], ()
    items = list(value)
    if not items:
        return [], (0,)
    rows: list[list[float]] = []
    inner: tuple[int, ...] | None = None
    for item in items:
        r, s = _flatten(item, width)
        if inner is not None and s != inner:
            raise ValueError("ragged nested lists")
        inner = s
        rows.extend(r)
    return rows, (len(items),) + (inner or ())


def _is_row(value: Any, width: int) -> bool:
    try:
        return len(value) == width and all(isinstance(v, (int, float)) for v in value)
    except TypeError:
        return False


def _flatten_scalar(value: Any, shape: tuple[int, ...]) -> list[float]:
    n = math.prod(shape)
    if isinstance(value, (int, float)):
        return [float(value)] * n
    flat: list[float] = []

    def walk(v: Any) -> None:
        if isinstance(v, (int, float)):
            flat.append(float(v))
        else:
            for x in v:
                walk(x)

    walk(value)
    if len(flat) != n:
        raise ValueError(f"tmin/tmax has {len(flat)} values for {n} rays")
    return flat


def _shape(values: list[Any], shape: tuple[int, ...]) -> Any:
    """The flat list `values` nested to `shape` (a scalar for shape ())."""
    if not shape:
        return values[0]
    if len(shape) == 1:
        return values
    step = math.prod(shape[1:])
    return [_shape(values[i * step : (i + 1) * step], shape[1:]) for i in range(shape[0])]
