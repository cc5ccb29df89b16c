#!/usr/bin/env bash
# Installs exactly the Debian 12 packages Palpa needs to build, test and run.
# Idempotent: when everything is present it returns in about a second
# without touching the network. Run as root (or with sudo available).
set -euo pipefail

PACKAGES=(
  # toolchain
  cmake ninja-build g++ pkg-config ccache
  # core libraries
  libeigen3-dev libopenmesh-dev libvtk9-dev nlohmann-json3-dev
  # scenario files: the organ's SHA-256 (libcrypto)
  libssl-dev
  # tissue maps: PNG images (OpenCV), nearest file point (nanoflann)
  libopencv-dev libnanoflann-dev
  # benchmark comparison (CGAL is header-only; it needs GMP/MPFR headers)
  libcgal-dev libgmp-dev libmpfr-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # the scenario-schema test validates shipped scenarios with python3's jsonschema
  python3 python3-jsonschema
  # workbench and rendering: Qt5 with VTK's widget, offscreen GL (OSMesa, EGL), Xvfb for GUI tests
  qtbase5-dev libvtk9-qt-dev libosmesa6-dev libegl-dev libgl-dev xvfb xauth
  # devices: SpaceMouse (hidapi), Falcon (libusb), OpenIGTLink bridge, emulated devices in tests
  libhidapi-dev libusb-1.0-0-dev libopenigtlink-dev umockdev libumockdev-dev
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
