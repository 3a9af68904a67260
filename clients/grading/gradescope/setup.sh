#!/usr/bin/env bash
# Gradescope runs this once when it builds the autograder image (as root). It needs Python 3.10+
# (tomllib, or Debian/Ubuntu's python3-tomli before 3.11) and a raycastd server that runs on
# the image: bin/raycastd from the zip when it starts there, else one built from the source
# tree the zip carries in raycastd-src/ (Debian 12 / Ubuntu 24.04 packages, scripts/setup.sh).
set -euo pipefail
src=/autograder/source
export DEBIAN_FRONTEND=noninteractive
apt-get update -q
apt-get install -y -q --no-install-recommends python3
if ! python3 -c 'import tomllib' 2>/dev/null; then
    apt-get install -y -q --no-install-recommends python3-tomli
fi
apt-get install -y -q --no-install-recommends python3-numpy || true  # optional: faster arrays
if [[ -x "$src/bin/raycastd" ]] && "$src/bin/raycastd" --help >/dev/null 2>&1; then
    echo "setup.sh: using the bundled bin/raycastd"
    exit 0
fi
if [[ ! -d "$src/raycastd-src" ]]; then
    echo "setup.sh: bin/raycastd does not run on this image and no raycastd-src/ to build" >&2
    exit 1
fi
cd "$src/raycastd-src"
scripts/setup.sh
cmake --preset release -DBUILD_TESTING=OFF -DRAYCASTD_BUILD_BENCH=OFF >/dev/null
cmake --build --preset release -j"$(nproc)" --target raycastd
mkdir -p "$src/bin"
cp build/release/server/raycastd "$src/bin/raycastd"
