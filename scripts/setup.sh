#!/usr/bin/env bash
# Installs the Debian 12 packages raycastd needs, and nothing else. Idempotent and quick when
# they are present: apt is only touched when a package is missing. The browser test of the
# preview page (tests/browser) also needs Debian's chromium, Node.js and npm, and the npm
# package playwright-core pinned in tests/browser/package-lock.json (`npm ci` there, only when
# the installed copy differs from the lock).
#   scripts/setup.sh          build + test dependencies (Python: the client's tests, black;
#                             clang and its libFuzzer runtime: the asan, tsan and fuzz presets;
#                             prometheus-client, yaml and nginx: tests/deploy, tests/scale)
#   scripts/setup.sh --bench  also the benchmark peers (Open3D, NumPy, POV-Ray, matplotlib)
set -euo pipefail

# What building raycastd needs: the Dockerfile's build stage installs exactly this list
# (tests/deploy/test_dockerfile.py compares the two).
build_packages=(
    build-essential cmake ninja-build pkg-config git curl ca-certificates
    libembree-dev libtinygltf-dev libopenmesh-dev libcpp-httplib-dev libssl-dev
    nlohmann-json3-dev libstb-dev zlib1g-dev libtbb-dev libgtest-dev libgmock-dev libbenchmark-dev
)
# What testing, formatting and fuzzing need besides.
packages=(
    "${build_packages[@]}"
    clang-format
    clang libclang-rt-14-dev
    python3 python3-numpy python3-pip python3-setuptools black
    python3-prometheus-client python3-yaml nginx
    chromium
)
# Node.js and npm: Debian's packages, unless a node and npm are there already (NodeSource's
# nodejs carries its own npm and conflicts with Debian's npm package).
command -v node >/dev/null || packages+=(nodejs)
command -v npm >/dev/null || packages+=(npm)
if [[ "${1:-}" == "--bench" ]]; then
    packages+=(python3-open3d python3-matplotlib povray)
fi

missing=()
for p in "${packages[@]}"; do
    if [[ "$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null)" != "installed" ]]; then
        missing+=("$p")
    fi
done
if ((${#missing[@]})); then
    echo "setup: installing ${missing[*]}" >&2
    sudo=()
    if [[ "$(id -u)" != 0 ]]; then
        command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
        sudo=(sudo)
    fi
    export DEBIAN_FRONTEND=noninteractive
    "${sudo[@]}" apt-get update -q
    "${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# playwright-core for tests/browser, at the version its lock file pins (never a browser download:
# the test drives /usr/bin/chromium).
browser_dir="$(cd "$(dirname "$0")/.." && pwd)/tests/browser"
wanted="$(sed -n '/"node_modules\/playwright-core"/,/}/s/.*"version": "\([^"]*\)".*/\1/p' "$browser_dir/package-lock.json")"
installed="$(sed -n 's/^  "version": "\([^"]*\)".*/\1/p' "$browser_dir/node_modules/playwright-core/package.json" 2>/dev/null || true)"
if [[ -n "$wanted" && "$installed" != "$wanted" ]]; then
    echo "setup: npm ci in tests/browser (playwright-core $wanted)" >&2
    (cd "$browser_dir" && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --prefer-offline --no-audit --no-fund >&2)
fi
