#!/usr/bin/env python3
"""Checks the engine's layering from its #include lines, and that the server stays above it.

The engine's folders, low to high (docs/architecture.md):

    status.h query_types.h backend.h format.h  (the files at the top of engine/)
    math/ → geometry/ → scene/ → load/ → mesh/ → accel/ → query/ → points/ → shade/ → render/
    → explain/

Rules, each failure named with the file, the line and the include:
  1. No engine file includes a folder above its own.
  2. accel/ is reached only from accel/ and query/: the layers above trace through QueryEngine,
     so the precision policy lives in one place.
  3. accel/embree/ (EmbreeAccel's parts) is included only from accel/.
  4. testing/ (scenes for tests; it sits just above scene/) is included only by *_test.cpp files
     (and by its own headers).
  5. server/ never includes engine/accel/ or an Embree header.

Usage: check_layers.py [--engine] [--server] [ROOT]   (both checks by default; ROOT: the repo)
Exits 0 when every rule holds, 1 otherwise. Standard library only.
"""

import argparse
import os
import re
import sys

# Rank of each place in engine/; a file may include ranks up to its own.
TOP_LEVEL = (
    0  # engine/status.h, query_types.h, backend.h, format.h and their .cpp files
)
FOLDERS = [
    "math",
    "geometry",
    "scene",
    "load",
    "mesh",
    "accel",
    "query",
    "points",
    "shade",
    "render",
    "explain",
]
RANK = {folder: i + 1 for i, folder in enumerate(FOLDERS)}
RANK["testing"] = (
    RANK["scene"] + 0.5
)  # a helper for tests: includes scene/, used from load/ up

INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^">]+)[">]')
SOURCE_SUFFIXES = (".h", ".cpp", ".cpp.in")


def place(path: str) -> str:
    """The layer of a path below engine/ ("accel" for accel/embree/x.h, "" for top-level files)."""
    parts = path.split("/")
    return "" if len(parts) == 1 else parts[0]


def rank(where: str):
    return TOP_LEVEL if where == "" else RANK.get(where)


def sources(root: str, folder: str):
    for directory, _, names in os.walk(os.path.join(root, folder)):
        for name in sorted(names):
            if name.endswith(SOURCE_SUFFIXES):
                yield os.path.relpath(os.path.join(directory, name), root).replace(
                    os.sep, "/"
                )


def includes(root: str, path: str):
    with open(os.path.join(root, path), encoding="utf-8", errors="replace") as f:
        for number, line in enumerate(f, 1):
            m = INCLUDE.match(line)
            if m:
                yield number, m.group(1), m.group(2)


def check_engine(root: str) -> list:
    problems = []
    for path in sources(root, "engine"):
        inner = path[len("engine/") :]
        mine = place(inner)
        if rank(mine) is None:
            problems.append(
                f"{path}: folder engine/{mine}/ has no place in the layer order "
                "(add it to scripts/check_layers.py)"
            )
            continue
        is_test = path.endswith("_test.cpp")
        for number, bracket, target in includes(root, path):
            if bracket != '"' or not target.startswith("engine/"):
                continue
            theirs = place(target[len("engine/") :])
            at = f"{path}:{number}: includes {target}"
            if rank(theirs) is None:
                problems.append(
                    f"{at}: engine/{theirs}/ has no place in the layer order"
                )
            elif rank(theirs) > rank(mine):
                problems.append(
                    f"{at}: {mine or 'engine'}/ may not include {theirs}/, "
                    "which is above it"
                )
            elif theirs == "accel" and mine not in ("accel", "query"):
                problems.append(
                    f"{at}: only accel/ and query/ include accel/; "
                    f"{mine}/ goes through QueryEngine (engine/query)"
                )
            elif target.startswith("engine/accel/embree/") and mine != "accel":
                problems.append(
                    f"{at}: accel/embree/ is EmbreeAccel's inside; "
                    "include engine/accel/embree_accel.h"
                )
            elif theirs == "testing" and not is_test and mine != "testing":
                problems.append(f"{at}: engine/testing/ is for *_test.cpp files only")
    return problems


def check_server(root: str) -> list:
    problems = []
    for path in sources(root, "server"):
        for number, bracket, target in includes(root, path):
            at = f"{path}:{number}: includes {bracket}{target}{'>' if bracket == '<' else bracket}"
            if target.startswith("engine/accel/"):
                problems.append(
                    f"{at}: the server reaches the engine through engine/query, "
                    "never engine/accel"
                )
            elif target.startswith("embree"):
                problems.append(
                    f"{at}: the server knows nothing of Embree "
                    "(engine/backend.h reports its version)"
                )
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--engine", action="store_true", help="check engine/ only")
    parser.add_argument("--server", action="store_true", help="check server/ only")
    parser.add_argument(
        "root",
        nargs="?",
        default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
    )
    args = parser.parse_args()
    both = not args.engine and not args.server
    problems = []
    if args.engine or both:
        problems += check_engine(args.root)
    if args.server or both:
        problems += check_server(args.root)
    for p in problems:
        print(p, file=sys.stderr)
    if problems:
        print(
            f"check_layers: {len(problems)} include(s) break the layering",
            file=sys.stderr,
        )
        return 1
    print("check_layers: the layering holds")
    return 0


if __name__ == "__main__":
    sys.exit(main())
