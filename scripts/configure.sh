#!/usr/bin/env bash
# cmake --preset PRESET [ARGS...], quietly. The presets build with Ninja (since stop 37); a
# build/<preset> configured earlier by Unix Makefiles would make cmake stop with "Does not match
# the generator used previously", so its cache is dropped first (the folder and whatever else it
# holds, such as bench results, stay).
set -euo pipefail
cd "$(dirname "$0")/.."
preset="$1"
shift
dir="build/$preset"
if [[ -f "$dir/CMakeCache.txt" ]] && ! grep -qx 'CMAKE_GENERATOR:INTERNAL=Ninja' "$dir/CMakeCache.txt"; then
    echo "configure: $dir was configured by another generator; configuring it afresh for Ninja" >&2
    rm -rf "$dir/CMakeCache.txt" "$dir/CMakeFiles"
fi
cmake --preset "$preset" "$@" >/dev/null
