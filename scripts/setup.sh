#!/usr/bin/env bash
# Installs the Debian 12 packages scalpelsim builds and tests with. Idempotent: when everything is
# present it only checks (a dpkg query, no network). Run as root (or with sudo available).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config clang-format
  libeigen3-dev libyaml-cpp-dev libcli11-dev nlohmann-json3-dev libgmp-dev
  libhidapi-dev libusb-1.0-0-dev libglfw3-dev libgl-dev libegl-dev libimgui-dev libstb-dev
  libegl-mesa0 libgl1-mesa-dri xvfb xauth
  doctest-dev libbenchmark-dev clang libclang-rt-14-dev
  libteem-dev gmsh tetgen python3-meshio python3-matplotlib
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
