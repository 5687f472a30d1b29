#!/usr/bin/env bash
# Installs everything talus needs to build, test and post-process on Debian 12
# (bookworm): compilers, CMake/Ninja, PETSc, Eigen, parallel HDF5, VTK, Open MPI,
# Catch2, yaml-cpp, and the Python/X packages used by scripts/.
#
# Idempotent: when every package is already installed it does nothing (no
# apt-get update). Run as root, or as a user with sudo.
#
#   bash scripts/install_dependencies.sh           # install what is missing
#   bash scripts/install_dependencies.sh --check   # only list what is missing (exit 1 if any)
#
# It never removes a package: it installs with --no-install-recommends, after
# simulating the installation (apt-get install -s), and stops with a message,
# changing nothing, if apt would remove anything. In particular it stops if
# python3-paraview is installed: that package (ParaView's Python, recommended
# by `apt-get install paraview`) Conflicts: python3-vtk9, which libvtk9-dev
# depends on, so the two cannot be installed together by dpkg. For ParaView on
# a build machine use scripts/install_paraview.sh instead (docs/output.md,
# "Installing ParaView").
set -euo pipefail

PROG=install_dependencies
check_only=0
case "${1:-}" in
  "") ;;
  --check) check_only=1 ;;
  -h|--help) sed -n '2,/^set -euo/p' "$0" | sed -e '$d' -e 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "$PROG: error: unknown argument '$1' (--check or nothing)" >&2; exit 2 ;;
esac

packages=(
  build-essential cmake ninja-build pkg-config
  petsc-dev libeigen3-dev libhdf5-openmpi-dev libvtk9-dev
  libopenmpi-dev openmpi-bin catch2 libyaml-cpp-dev
  python3-numpy python3-matplotlib python3-vtk9 xvfb xauth hdf5-tools
  python3-yaml python3-h5py
)

if ! command -v dpkg-query >/dev/null 2>&1; then
  echo "$PROG: error: dpkg-query not found; this script is for Debian 12." >&2
  exit 1
fi
installed() { [[ "$(dpkg-query -W -f='${Status}' "$1" 2>/dev/null || true)" == "install ok installed" ]]; }

missing=()
for p in "${packages[@]}"; do
  installed "$p" || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "$PROG: all ${#packages[@]} packages are already installed"
  exit 0
fi

paraview_conflict() {
  cat >&2 <<EOF
$PROG: error: python3-paraview is installed (ParaView's Python: pvpython,
  pvbatch; \`apt-get install paraview\` installs it as a recommendation). It
  Conflicts: python3-vtk9, which libvtk9-dev depends on, so installing the
  build set would remove it. Nothing changed. To build talus and keep ParaView:
      sudo apt-get remove python3-paraview     # keeps the package paraview (the GUI)
      bash scripts/install_dependencies.sh     # this script again
      bash scripts/install_paraview.sh         # pvpython/pvbatch beside python3-vtk9
  (docs/output.md, "Installing ParaView".)
EOF
}

if [[ $check_only -eq 1 ]]; then
  echo "$PROG: ${#missing[@]} of ${#packages[@]} packages missing: ${missing[*]}" >&2
  if installed python3-paraview; then paraview_conflict; fi
  exit 1
fi

if installed python3-paraview; then
  paraview_conflict
  exit 1
fi

echo "$PROG: installing ${#missing[@]} missing package(s): ${missing[*]}"

if [[ $(id -u) -eq 0 ]]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "$PROG: error: installing packages needs root, and sudo is not available." >&2
  echo "  Run this script as root, or install these packages first:" >&2
  echo "  ${missing[*]}" >&2
  exit 1
fi

if ! command -v apt-get >/dev/null 2>&1; then
  echo "$PROG: error: apt-get not found; this script is for Debian 12." >&2
  exit 1
fi

source "$(dirname "$0")/apt_install_safely.sh"
apt_install_safely "${packages[@]}"

still=()
for p in "${packages[@]}"; do installed "$p" || still+=("$p"); done
if [[ ${#still[@]} -gt 0 ]]; then
  echo "$PROG: error: still not installed: ${still[*]}" >&2
  exit 1
fi
echo "$PROG: done (ParaView on this machine: bash scripts/install_paraview.sh, not apt-get install paraview)"
