#!/usr/bin/env python3
"""The tutorial's Question 1 as a grading script would ask it: which sphere does the ray hit first?

Usage: which_sphere_first.py [http://127.0.0.1:8080]   (default: $RAYCASTD_URL, then 127.0.0.1:8080)
"""

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))

from raycastd import Client  # noqa: E402

# Three spheres of radius 2 (tutorial 7, Question 1) and a ray from the eye along +z.
SCENE = {
    "objects": [
        {"type": "sphere", "center": [0, 0, 10], "radius": 2},
        {"type": "sphere", "center": [0, 3, 8], "radius": 2},
        {"type": "sphere", "center": [0, 1, 9], "radius": 2},
    ]
}
RAY = {"origin": [0, 0, 0], "direction": [0, 0, 1]}

with Client(sys.argv[1] if len(sys.argv) > 1 else None) as client:  # None: $RAYCASTD_URL
    hit = client.intersect(SCENE, [RAY])["hits"][0]  # the closest hit, exact path
    print(f"first hit: {hit['name']} at t = {hit['t']}")  # sphere 3 at t = 9 - sqrt(3)
    for obj in client.explain(SCENE, RAY)["objects"]:  # the worked solution, per object
        print(f"  {obj['name']}: roots {obj['roots']}")
