#!/usr/bin/env bash
# Installs everything talus needs to build, test and post-process on Debian 12
# (bookworm): compilers, CMake/Ninja, PETSc, Eigen, parallel HDF5, VTK, Open MPI,
# Catch2, yaml-cpp, and the Python/X packages used by scripts/.
#
# Idempotent: when every package is already installed it does nothing (no
# apt-get update). Run as root, or as a user with sudo.
#
#   bash scripts/install_dependencies.sh
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  petsc-dev libeigen3-dev libhdf5-openmpi-dev libvtk9-dev
  libopenmpi-dev openmpi-bin catch2 libyaml-cpp-dev
  python3-numpy python3-matplotlib python3-vtk9 xvfb xauth hdf5-tools
  python3-yaml
)

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  if [[ "$status" != "install ok installed" ]]; then
    missing+=("$p")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install_dependencies: all ${#packages[@]} packages are already installed"
  exit 0
fi

echo "install_dependencies: installing ${#missing[@]} missing package(s): ${missing[*]}"

if [[ $(id -u) -eq 0 ]]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "install_dependencies: error: installing packages needs root, and sudo is not available." >&2
  echo "  Run this script as root, or install these packages first:" >&2
  echo "  ${missing[*]}" >&2
  exit 1
fi

if ! command -v apt-get >/dev/null 2>&1; then
  echo "install_dependencies: error: apt-get not found; this script is for Debian 12." >&2
  exit 1
fi

"${as_root[@]}" apt-get update
"${as_root[@]}" env DEBIAN_FRONTEND=noninteractive \
  apt-get install -y --no-install-recommends "${packages[@]}"
echo "install_dependencies: done"
