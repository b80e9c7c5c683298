#!/usr/bin/env bash
# Installs the Debian 12 packages the project needs (only what is missing),
# then configures and builds in Release with Ninja (and ccache when present).
# Usage: scripts/setup.sh [build-dir]     (run as root, or with sudo available)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${1:-build}

PACKAGES=(
  cmake ninja-build g++ ccache pkg-config
  libeigen3-dev libceres-dev libembree-dev libopenimageio-dev openimageio-tools
  libopencv-dev libopencv-contrib-dev
  opencv-doc colmap
  libgtest-dev libgmock-dev libbenchmark-dev nlohmann-json3-dev libcli11-dev
  python3 python3-numpy python3-matplotlib python3-opencv python3-openimageio
  libcgal-dev libcgal-demo
  time slurm-wlm  # batch.sh's /usr/bin/time; a private single-node Slurm for scripts/test_slurm.sh
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" > /dev/null
fi

JOBS=$(nproc)
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$BUILD_DIR" -j "$JOBS"
