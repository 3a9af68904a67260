#!/usr/bin/env bash
# Sets up, builds and runs the whole test suite: the Release build, then the ASan+UBSan build
# (skip the latter with --release-only). Each ends with ctest's summary line.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# Formatting first: it takes a second and names the one command that fixes it.
scripts/check_format.sh
jobs="$(nproc)"
presets=(release asan)
[[ "${1:-}" == "--release-only" ]] && presets=(release)
for preset in "${presets[@]}"; do
    echo "=== ${preset}: configure and build" >&2
    cmake --preset "$preset" >/dev/null
    cmake --build --preset "$preset" -j"$jobs"
    echo "=== ${preset}: test" >&2
    ctest --preset "$preset" -j"$jobs" --timeout 600
done
