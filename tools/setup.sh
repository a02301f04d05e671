#!/usr/bin/env bash
# Installs what amhv needs, from Debian 12 packages (and two tools from the npm registry).
#
#   bash tools/setup.sh          everything: build, run, and the whole test suite (what CI runs)
#   bash tools/setup.sh --run    only what building and running amhv needs (README's first command):
#                                no test framework, browser, Slurm, clang or validation layers
#
# Safe to run again: apt skips what is already there.
set -euo pipefail

profile=all
case "${1:-}" in
  --run) profile=run ;;
  "") ;;
  *) echo "setup: unknown option '$1' (use --run, or nothing for everything)" >&2; exit 2 ;;
esac

# Building and running amhv (the demo writes its page, so three.js comes too: fetched from the
# npm registry with curl and checked against its pinned SHA-512, no Node.js needed).
packages=(
  build-essential cmake pkg-config git curl ca-certificates
  libvulkan-dev mesa-vulkan-drivers glslang-tools
  libeigen3-dev libopenmesh-dev libopenexr-dev libpng-dev libcairo2-dev libfreetype-dev fonts-dejavu-core
  libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  libopenvdb-dev libboost-iostreams-dev
  libtinygltf-dev libnanoflann-dev zlib1g-dev
  libassimp-dev        # animated characters (glTF, FBX, Collada)
  libcpp-httplib-dev   # the page server of `amhv view --serve`
)
npm_tools=()
if [ "$profile" = all ]; then
  packages+=(
    vulkan-validationlayers vulkan-tools glslang-dev spirv-tools
    libgtest-dev libgmock-dev libbenchmark-dev
    python3 python3-openvdb universal-ctags time
    clang libclang-rt-14-dev   # the sanitizer job and the fuzz targets (libFuzzer)
    chromium
    slurm-wlm   # the one-node Slurm cluster of the scale-out test (tests/slurm_cluster.sh)
  )
  # The Khronos glTF validator, for the tests that validate every scene.glb.
  npm_tools+=("gltf-validator@2.0.0-dev.3.10")
  # Node.js and npm from Debian, unless the machine already has them (e.g. from NodeSource, whose
  # nodejs bundles npm and conflicts with Debian's npm package).
  command -v node >/dev/null 2>&1 || packages+=(nodejs)
  command -v npm >/dev/null 2>&1 || packages+=(npm)
fi

# three.js r147 (the last with classic scripts, which a page opened from file:// may load), which
# `amhv edit` copies beside the page it writes: the registry's tarball, its integrity pinned.
three_version=0.147.0
three_sha512=2cf4ceb256105c5926bdc7908c54cd9d55658b62da545e82f7d3efdf87c9ca9a7c35b40b6d396edca8a7674cd4460852e7311e84af95432bd6b8f67f4a6f1fcf
install_three() {
  local dir tmp
  dir="$(cd "$(dirname "$0")" && pwd)/npm/node_modules/three"
  if [ -f "$dir/package.json" ] && grep -q "\"version\": \"$three_version\"" "$dir/package.json"; then
    echo "setup: three@$three_version already in tools/npm"
    return
  fi
  echo "setup: fetching three@$three_version into tools/npm from the npm registry"
  tmp="$(mktemp -d)"
  curl -fsSL --retry 3 -o "$tmp/three.tgz" "https://registry.npmjs.org/three/-/three-$three_version.tgz"
  echo "$three_sha512  $tmp/three.tgz" | sha512sum -c --quiet - || { echo "setup: three.js tarball fails its checksum" >&2; rm -rf "$tmp"; exit 1; }
  rm -rf "$dir" && mkdir -p "$dir"
  tar -xzf "$tmp/three.tgz" -C "$dir" --strip-components=1
  rm -rf "$tmp"
}

# From the npm registry, into tools/npm/ (ignored by git), pinned: (for the tests) the glTF
# validator, then three.js (after npm, which removes packages it did not install).
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
  install_three
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
