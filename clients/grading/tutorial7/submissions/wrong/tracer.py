#!/usr/bin/env python3
"""The same student tracer (../correct/tracer.py) with the classic sphere bug: it takes the
larger root of the quadratic, the point where the ray leaves the sphere, instead of the smaller
one. Its t values are too large and its picture shows the spheres' far sides."""

import importlib.util
import pathlib
import sys

spec = importlib.util.spec_from_file_location(
    "tracer", pathlib.Path(__file__).resolve().parents[1] / "correct" / "tracer.py"
)
tracer = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tracer)


def hit_sphere_far_root(p, v, obj):
    roots = tracer.sphere_roots(p, v, obj["center"], obj["radius"])
    return roots[-1] if roots and roots[-1] >= 0 else None


tracer.hit_sphere = hit_sphere_far_root

if __name__ == "__main__":
    if sys.argv[1:2] == ["t"] and len(sys.argv) == 5:
        tracer.trace_t(*sys.argv[2:5])
    elif sys.argv[1:2] == ["image"] and len(sys.argv) == 7:
        tracer.render(sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5]), sys.argv[6])
    else:
        sys.exit(tracer.__doc__)
