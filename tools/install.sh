#!/usr/bin/env bash
# Installs every Debian 12 package dypho needs, then configures and builds it.
# Safe to run twice. Usage: scripts/install.sh [BUILD_DIR]   (default: build)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${1:-$here/build}"

packages=(
  build-essential cmake ninja-build ccache pkg-config git
  libtorch-dev libopencv-dev libeigen3-dev libceres-dev libglm-dev
  libtinygltf-dev libnanoflann-dev zlib1g-dev libdeflate-dev nlohmann-json3-dev libyaml-cpp-dev libcli11-dev libstb-dev
  libgtest-dev libgmock-dev libbenchmark-dev clang libclang-rt-14-dev
  python3-dev pybind11-dev python3-numpy python3-pytest python3-opencv
  mesa-vulkan-drivers libvulkan-dev glslc vulkan-validationlayers libglfw3-dev xvfb xauth
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  echo "install.sh: installing ${missing[*]}"
  $sudo_cmd apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "install.sh: all Debian packages present"
fi

jobs="${DYPHO_JOBS:-$(nproc)}"
cmake -S "$here" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release ${DYPHO_CMAKE_ARGS:-}
cmake --build "$build_dir" -j "$jobs"
