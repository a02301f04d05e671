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
  libtinygltf-dev libnanoflann-dev zlib1g-dev
  chromium
  slurm-wlm   # the one-node Slurm cluster of the scale-out test (tests/slurm_cluster.sh)
)
# Node.js and npm from Debian, unless the machine already has them (e.g. from NodeSource, whose
# nodejs bundles npm and conflicts with Debian's npm package).
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)

# From the npm registry, into tools/npm/ (ignored by git), pinned: the Khronos glTF validator, for
# the tests that validate every scene.glb, and three.js, which `amhv edit` copies beside the page it
# writes (r147: the last with classic scripts, which a page opened from file:// may load).
npm_tools=("gltf-validator@2.0.0-dev.3.10" "three@0.147.0")
install_npm_tools() {
  local prefix tool name
  prefix="$(cd "$(dirname "$0")" && pwd)/npm"
  for tool in "${npm_tools[@]}"; do
    name="${tool%@*}"
    if [ -f "$prefix/node_modules/$name/package.json" ] && grep -q "\"version\": \"${tool##*@}\"" "$prefix/node_modules/$name/package.json"; then
      echo "setup: $tool already in tools/npm"
      continue
    fi
    echo "setup: installing $tool into tools/npm from the npm registry"
    npm install --no-audit --no-fund --loglevel=error --prefix "$prefix" "$tool" >/dev/null
  done
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
