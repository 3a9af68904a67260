#!/usr/bin/env bash
# Sets up, builds and runs raycastd on 127.0.0.1:8080 (override with PORT=...) with the demo
# scenes in clients/examples/ registered. Extra arguments go to raycastd.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/configure.sh release
cmake --build --preset release -j"$(nproc)" --target raycastd
scene_root=../shared/data/models
[[ -d "$scene_root" ]] || scene_root=clients/examples
exec build/release/server/raycastd --host 127.0.0.1 --port "${PORT:-8080}" \
    --scene-root "$scene_root" --data-dir "${DATA_DIR:-data}" \
    --demo clients/examples/tutorial-spheres.json "$@"
