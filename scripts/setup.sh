#!/usr/bin/env bash
# Installs the Debian 12 packages raycastd needs, and nothing else. Idempotent and quick when
# they are present: apt is only touched when a package is missing.
#   scripts/setup.sh          build + test dependencies (Python: the client's tests, black)
#   scripts/setup.sh --bench  also the benchmark peers (Open3D, NumPy, POV-Ray, matplotlib)
set -euo pipefail

packages=(
    build-essential cmake pkg-config git curl ca-certificates
    libembree-dev libtinygltf-dev libopenmesh-dev libcpp-httplib-dev libssl-dev
    nlohmann-json3-dev libstb-dev libtbb-dev libgtest-dev libgmock-dev libbenchmark-dev
    clang-format
    python3 python3-numpy python3-pip python3-setuptools black
)
if [[ "${1:-}" == "--bench" ]]; then
    packages+=(python3-open3d python3-matplotlib povray)
fi

missing=()
for p in "${packages[@]}"; do
    if [[ "$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null)" != "installed" ]]; then
        missing+=("$p")
    fi
done
if ((${#missing[@]} == 0)); then
    exit 0
fi

echo "setup: installing ${missing[*]}" >&2
sudo=()
if [[ "$(id -u)" != 0 ]]; then
    command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
    sudo=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -q
"${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
