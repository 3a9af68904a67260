#!/usr/bin/env python3
"""The smallest useful raycastd program: register a scene once, then query it by id.

Usage: minimal.py [http://127.0.0.1:8080]   (default: $RAYCASTD_URL, then 127.0.0.1:8080)
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))

from raycastd import Client  # noqa: E402

with Client(sys.argv[1] if len(sys.argv) > 1 else None) as client:
    print(client.health())  # {'status': 'ok'}
    scene = client.add_scene(  # content-addressed: the same document gets the same id
        {"objects": [{"type": "triangle", "vertices": [[0, 0, 5], [1, 0, 5], [0, 1, 5]]}]}
    )
    print("registered", scene["id"], "with", scene["triangles"], "triangle")
    rays = [{"origin": [0.2, 0.2, 0], "direction": [0, 0, 1]}]
    print(client.intersect(scene["id"], rays, fields=["t", "barycentric"]))  # only what is asked
    hits = client.cast_rays(scene["id"], [[0.2, 0.2, 0, 0, 0, 1]])  # the binary form, as arrays
    print("binary:", hits["t_hit"], hits["primitive_uvs"])  # NumPy arrays when it is installed
