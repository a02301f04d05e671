#!/usr/bin/env bash
# Installs everything amhv needs to build, test and run, from Debian 12 packages only.
# Safe to run again: apt skips what is already there.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools
  glslang-tools glslang-dev spirv-tools
  libeigen3-dev libopenmesh-dev libopenexr-dev libpng-dev libcairo2-dev
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libopenvdb-dev libboost-iostreams-dev
  python3 python3-openvdb universal-ctags time
  libtinygltf-dev libnanoflann-dev
)
# Node.js and npm from Debian, unless the machine already has them (e.g. from NodeSource, whose
# nodejs bundles npm and conflicts with Debian's npm package).
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)

# The Khronos glTF validator exists only on the npm registry: installed into tools/npm/ (ignored by
# git), pinned, for the tests that validate every scene.glb.
gltf_validator="gltf-validator@2.0.0-dev.3.10"
install_npm_tools() {
  local prefix
  prefix="$(cd "$(dirname "$0")" && pwd)/npm"
  if [ -f "$prefix/node_modules/gltf-validator/package.json" ]; then
    echo "setup: $gltf_validator already in tools/npm"
    return
  fi
  echo "setup: installing $gltf_validator into tools/npm from the npm registry"
  npm install --no-audit --no-fund --loglevel=error --prefix "$prefix" "$gltf_validator" >/dev/null
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  install_npm_tools
  exit 0
fi

sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
install_npm_tools
echo "setup: done"
